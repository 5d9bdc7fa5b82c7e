"""Which boxes of one set overlap those of another, and which points lie in which boxes: through
grids, not all pairs."""

from __future__ import annotations

from typing import Callable

import numpy as np

from . import parallel
from .progress import heartbeat

# ``points_in_boxes`` lists a box in every cell it overlaps of a grid whose cells are at least
# 1 / BOX_SPAN of its size: at most BOX_SPAN + 1 cells per axis.
BOX_SPAN = 16
# ``overlapping_boxes`` lists a box in a grid whose cells are between 1 / LISTED_CELLS and twice
# that of its listed size (``_listed_sizes``): up to 3 x 3 x 3 cells (9 x 9 along a huge flat box's
# sides). Finer cells list each box in more of them (a flat face in some twenty at 4), coarser ones
# put more boxes in each; 2 was the fastest on the breakfast room's coplanar pairs and contact lines
# (docs/notes/experiments.md).
LISTED_CELLS = 2.0
# A box over HUGE_BOX times the median size is listed by the larger of its smallest side and
# 1 / FLAT_SPAN of its largest (``_listed_sizes``): a floor or a wall, in cells a few times finer
# than itself, meets only the small boxes near its plane, not all those in its cell's height. The
# breakfast room's contact lines 4.7 -> 3.3 s (8 to 32 times alike; FLAT_SPAN 2: 4.2 s, 8: 3.4 s).
HUGE_BOX = 16.0
FLAT_SPAN = 4.0
# Grid cells of points against boxes are this many times the median box size: each point falls in
# one cell, and smaller cells test fewer boxes per point (timed on the large scenes).
POINT_CELL = 0.5
# Candidate pairs made at once (about 50 bytes each): bounds the memory of a dense cell.
PAIRS_PER_BLOCK = 1 << 22
# Cells of boxes listed at once by ``points_in_boxes``, and queries of one block of
# ``overlapping_boxes`` (about 40 and 130 bytes each).
LISTINGS_PER_BLOCK = 1 << 20
# Up to this many pairs in all, every pair is tested: faster than building the grid.
EVERY_PAIR = 1 << 20


def overlapping_boxes(low_a: np.ndarray, high_a: np.ndarray, low_b: np.ndarray, high_b: np.ndarray,
                      keep: Callable[[np.ndarray, np.ndarray], np.ndarray] | None = None
                      ) -> tuple[np.ndarray, np.ndarray]:
    """Index pairs (i, j), each once, sorted, of axis-aligned boxes (corners (n, 3)) of a and b
    that overlap or touch and for which ``keep(i, j)`` (index arrays to a bool mask; None: all)
    holds, ``keep`` run block by block on the pool's threads. Through a grid per size (cells
    doubling from level to level): each box is listed in the few cells of its size's grid it
    overlaps (``_levels``), and paired there with every box no larger listed in the same cells; a
    pair counts in the one cell that holds the lowest corner of the boxes' overlap. Boxes of every
    size cost alike: in one grid, a wall listed in thousands of the small boxes' cells would meet
    each neighbour once per cell they share, and tiny boxes crowded into one cell would each meet
    all the others."""
    empty = np.zeros(0, dtype=np.int64)
    if len(low_a) == 0 or len(low_b) == 0:
        return empty, empty

    def kept(pairs: tuple[np.ndarray, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
        if keep is None or len(pairs[0]) == 0:
            return pairs
        chosen = keep(*pairs)
        return pairs[0][chosen], pairs[1][chosen]

    if len(low_a) * len(low_b) <= EVERY_PAIR:
        return kept(_every_pair(low_a, high_a, np.arange(len(low_a)), low_b, high_b, np.arange(len(low_b))))
    origin = np.minimum(low_a.min(axis=0), low_b.min(axis=0))
    spread = float((np.maximum(high_a.max(axis=0), high_b.max(axis=0)) - origin).max())
    extent_a, extent_b = high_a - low_a, high_b - low_b
    base = _cell_size(np.concatenate([extent_a.max(axis=1), extent_b.max(axis=1)]), spread, 1.0)
    level_a, level_b = (_levels(_listed_sizes(extent, base), base, spread) for extent in (extent_a, extent_b))
    # one set against itself: each pair of boxes of different levels is found once, by the larger's
    # level, and turned round for the other way
    itself = low_a is low_b and high_a is high_b
    jobs = []
    for level in np.union1d(level_a, level_b):
        cell = base * 2.0 ** int(level)
        # b's boxes of this level against a's no larger, and a's of this level against b's smaller
        jobs.append((low_a, high_a, np.flatnonzero(level_a <= level), low_b, high_b, np.flatnonzero(level_b == level),
                     cell, False))
        if not itself:
            jobs.append((low_b, high_b, np.flatnonzero(level_b < level), low_a, high_a,
                         np.flatnonzero(level_a == level), cell, True))
    # each job's listings are made on the pool too, ahead of the blocks that read them
    made = parallel.map_ordered(lambda job: _cell_pairs(*job[:7], origin), jobs)
    blocks = ((block, job[7]) for job, job_blocks in zip(jobs, made) for block in job_blocks)

    def key(block, swapped: bool) -> np.ndarray:
        found, listed = block()
        first, second = kept((listed, found) if swapped else (found, listed))
        if itself:
            smaller = np.flatnonzero(level_a[found] < level_a[listed])
            turned = kept((listed[smaller], found[smaller]))
            first, second = np.concatenate([first, turned[0]]), np.concatenate([second, turned[1]])
        return first * len(low_b) + second

    keys = np.sort(np.concatenate([empty, *parallel.map_ordered(lambda job: key(*job), blocks)]))
    return keys // len(low_b), keys % len(low_b)


def points_in_boxes(points: np.ndarray, low: np.ndarray, high: np.ndarray,
                    keep: Callable[[np.ndarray, np.ndarray], np.ndarray] | None = None
                    ) -> tuple[np.ndarray, np.ndarray]:
    """Index pairs (i, j), each once, of the points (n, 3) lying in or on the boxes (corners
    (m, 3)) for which ``keep(i, j)`` (index arrays to a bool mask; None: all) holds, in a fixed
    order. Each box is listed in the cells it overlaps of a grid of cells POINT_CELL x the median
    box, or, for a box over BOX_SPAN of them, of a grid twice, four times, ... as coarse (a wall
    among small patches lists a few hundred cells, not every point); each point falls in one cell
    of each grid, so each pair is found once, and ``keep`` runs on the candidates block by block
    on the pool's threads: a caller's filters never see the whole candidate set at once."""
    empty = np.zeros(0, dtype=np.int64)
    if len(points) == 0 or len(low) == 0:
        return empty, empty
    everything = np.arange(len(points))

    by_axis = [(np.ascontiguousarray(points[:, axis]), np.ascontiguousarray(low[:, axis]),
                np.ascontiguousarray(high[:, axis])) for axis in range(3)]

    def accept(first: np.ndarray, second: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        for coordinates, lows, highs in by_axis:  # axis by axis, each on the pairs left: most fail the first
            coordinate = coordinates[first]
            inside = (lows[second] <= coordinate) & (coordinate <= highs[second])
            first, second = first[inside], second[inside]
        if keep is not None and len(first):
            chosen = keep(first, second)
            first, second = first[chosen], second[chosen]
        return first, second

    if len(points) * len(low) <= EVERY_PAIR:  # every pair, the boxes split among the threads
        shares = np.array_split(np.arange(len(low)), min(parallel.THREADS, len(low)))
        return _joined(list(parallel.map_ordered(
            lambda boxes: accept(np.tile(everything, len(boxes)), np.repeat(boxes, len(points))), shares)))
    origin = np.minimum(points.min(axis=0), low.min(axis=0))
    spread = float((np.maximum(points.max(axis=0), high.max(axis=0)) - origin).max())
    sizes = (high - low).max(axis=1)
    base = _cell_size(sizes, spread, POINT_CELL)
    with np.errstate(divide="ignore"):
        level = np.maximum(np.ceil(np.log2(sizes / (BOX_SPAN * base))), 0).astype(np.int64)
    blocks = []
    for coarser in np.unique(level):
        heartbeat()
        grid = _PointGrid(points, low, high, origin, base * 2.0 ** int(coarser))
        boxes = np.flatnonzero(level == coarser)
        listed = grid.spans[boxes].prod(axis=1)
        bounds = np.searchsorted(np.cumsum(listed), np.arange(LISTINGS_PER_BLOCK, listed.sum(), LISTINGS_PER_BLOCK))
        blocks += [(grid, chunk) for chunk in np.split(boxes, bounds)]
    return _joined(list(parallel.map_ordered(lambda job: job[0].pairs(job[1], accept), blocks)))


def in_front(low: np.ndarray, high: np.ndarray, origins: np.ndarray, normals: np.ndarray,
             margin: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Boxes (corners (n, 3)) cut down to cover only their part with n . (x - o) >= -margin, in
    front of the plane through ``origins`` (n, 3) facing ``normals`` (n, 3): along each axis i
    with n_i != 0, x_i is bounded by o_i - (margin + max over the box of sum_{j != i} n_j (x_j -
    o_j)) / n_i. A box whose plane is near an axis loses the half behind it; a box behind its
    plane is left empty (low > high)."""
    rise = np.maximum(normals * (low - origins), normals * (high - origins))  # (n, 3) the most each axis adds
    others = rise.sum(axis=1, keepdims=True) - rise
    with np.errstate(divide="ignore", invalid="ignore"):
        bound = origins - (margin[:, None] + others) / normals
    return (np.where(normals > 0, np.maximum(low, bound), low),
            np.where(normals < 0, np.minimum(high, bound), high))


class _PointGrid:
    """The points sorted by their cell of a grid (cells of size ``cell`` from ``origin``), and
    the cells each box overlaps."""

    def __init__(self, points: np.ndarray, low: np.ndarray, high: np.ndarray, origin: np.ndarray,
                 cell: float) -> None:
        self.cells, self.spans = _cells(low, high, origin, cell)
        point_keys = _cell_keys(np.floor((points - origin) / cell).astype(np.int64))
        self.by_cell = np.argsort(point_keys, kind="stable")
        self.sorted_keys = point_keys[self.by_cell]

    def pairs(self, boxes: np.ndarray, accept) -> tuple[np.ndarray, np.ndarray]:
        """``accept(points, boxes)`` of the candidate pairs of ``boxes``: the points in their cells,
        at most PAIRS_PER_BLOCK at once."""
        keys, owner, _ = _listed_cells(self.cells[boxes], self.spans[boxes])
        start = np.searchsorted(self.sorted_keys, keys, side="left")
        count = np.searchsorted(self.sorted_keys, keys, side="right") - start
        total = np.cumsum(count)
        found, begin = [], 0
        while begin < len(keys):
            end = max(begin + 1, int(np.searchsorted(total, (total[begin - 1] if begin else 0) + PAIRS_PER_BLOCK)))
            chunk = slice(begin, end)
            run = runs(count[chunk])
            first = self.by_cell[start[chunk][run] + ranks(count[chunk], run)]
            found.append(accept(first, boxes[owner[chunk][run]]))
            begin = end
        return _joined(found)


def _joined(parts: list[tuple[np.ndarray, np.ndarray]]) -> tuple[np.ndarray, np.ndarray]:
    """The (first, second) index pairs of ``parts`` one after another."""
    empty = np.zeros(0, dtype=np.int64)
    return (np.concatenate([empty, *(first for first, _ in parts)]),
            np.concatenate([empty, *(second for _, second in parts)]))


def _cell_size(sizes: np.ndarray, spread: float, times: float) -> float:
    """Grid cells ``times`` the median of the positive box ``sizes`` (the scene's ``spread`` if
    none), and at most 2^60 of them (int64 keys)."""
    cell = times * float(np.median(sizes[sizes > 0])) if (sizes > 0).any() else spread
    return max(cell, spread / (1 << 20), np.finfo(float).tiny)


def _listed_sizes(extent: np.ndarray, base: float) -> np.ndarray:
    """(n,) the size by which boxes of sides ``extent`` (n, 3) choose their grid (``_levels``):
    the largest side, or for a box over HUGE_BOX x ``base``, the larger of its smallest side and
    1 / FLAT_SPAN of its largest."""
    largest, smallest = extent.max(axis=1), extent.min(axis=1)
    return np.where(largest > HUGE_BOX * base, np.maximum(largest / FLAT_SPAN, smallest), largest)


def _levels(sizes: np.ndarray, base: float, spread: float) -> np.ndarray:
    """(n,) the grid level of boxes listed by ``sizes`` (n,; ``_listed_sizes``): the level l whose
    cells, ``base`` x 2^l, are between 1 / LISTED_CELLS and twice that size (a box spans at most
    3 cells per axis, 9 along the long sides of a huge flat one), at least the level where the
    boxes' ``spread`` is 2^19 cells and at most where it is 1."""
    lowest = np.floor(np.log2(spread / base)) - 19
    with np.errstate(divide="ignore"):
        level = np.ceil(np.log2(sizes / (LISTED_CELLS * base)))
    return np.clip(level, lowest, np.ceil(np.log2(spread / base))).astype(np.int64)


def _cell_pairs(low_q, high_q, queried, low_l, high_l, listed, cell: float, origin: np.ndarray):
    """Blocks of work, each a function giving touching pairs (q, l) as index arrays, of boxes
    ``queried`` and ``listed``, both listed in every cell of size ``cell`` they overlap: a pair
    counts in the one cell holding the lowest corner of the boxes' overlap, where both are listed.
    That cell is, axis by axis, the later of the two boxes' first cells, so each pair is made there
    alone: a listing of l carries a flag per axis, whether its cell is l's first along it
    (``_listed_cells``), and a query of q in a cell past q's first along an axis reads only the
    listings flagged on it (``_ACCEPTED``). The boxes are then tested axis by axis on the pairs
    left, as most candidates part along one axis (a small box beside a wall, in the wall's cell)."""
    if len(queried) == 0 or len(listed) == 0:
        return []
    keys_l, owner_l, flags_l = _listed_cells(*_cells(low_l[listed], high_l[listed], origin, cell))
    keys_q, owner_q, flags_q = _listed_cells(*_cells(low_q[queried], high_q[queried], origin, cell))
    # the listings sorted by cell, then flags: the cell keys, and each cell's buckets, one per flags
    sorted_keys = keys_l * _FLAGS + flags_l
    order = np.argsort(sorted_keys, kind="stable")
    listed_cells, owner_l = sorted_keys[order] // _FLAGS, owner_l[order]
    new_cell = np.concatenate([[True], listed_cells[1:] != listed_cells[:-1]])
    cell_keys = listed_cells[new_cell]
    bucket = (np.cumsum(new_cell) - 1) * _FLAGS + flags_l[order]
    bucket_ends = np.cumsum(np.bincount(bucket, minlength=len(cell_keys) * _FLAGS))
    bucket_starts = np.concatenate([[0], bucket_ends[:-1]]).reshape(-1, _FLAGS)
    bucket_counts = np.diff(bucket_ends, prepend=0).reshape(-1, _FLAGS)
    reads = bucket_counts @ _ACCEPTED.T.astype(np.int64)  # (cells, 8) the listings a query needing those flags reads
    row = np.minimum(np.searchsorted(cell_keys, keys_q), len(cell_keys) - 1)
    shared = cell_keys[row] == keys_q
    row, listing_q = row[shared], np.flatnonzero(shared)
    needed = flags_q[listing_q] ^ (_FLAGS - 1)  # the axes along which the query's cell is past its box's first
    total = np.cumsum(reads[row, needed])

    def ranges(chunk: slice) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The runs of sorted listings the queries of ``chunk`` read: their starts, lengths and
        queries. A query in its box's first cell (most of them) reads its cell's whole run, any
        other the cell's buckets holding the flags it needs."""
        query = np.arange(chunk.start, chunk.stop)
        whole = needed[chunk] == 0
        whole_query, part_query = query[whole], query[~whole]
        part_row = row[part_query]
        part_counts = np.where(_ACCEPTED[needed[part_query]], bucket_counts[part_row], 0)  # (k, 8)
        which, bucket = np.nonzero(part_counts)
        return (np.concatenate([bucket_starts[row[whole_query], 0], bucket_starts[part_row[which], bucket]]),
                np.concatenate([reads[row[whole_query], 0], part_counts[which, bucket]]),
                np.concatenate([whole_query, part_query[which]]))

    sides = [(np.ascontiguousarray(low_q[queried, axis]), np.ascontiguousarray(high_q[queried, axis]),
              np.ascontiguousarray(low_l[listed, axis]), np.ascontiguousarray(high_l[listed, axis]))
             for axis in range(3)]

    def block(chunk: slice) -> tuple[np.ndarray, np.ndarray]:
        start, count, query = ranges(chunk)
        run = runs(count)
        second = owner_l[start[run] + ranks(count, run)]
        first = owner_q[listing_q[query[run]]]
        for low_first, high_first, low_second, high_second in sides:  # axis by axis, on the pairs left
            touch = (low_first[first] <= high_second[second]) & (low_second[second] <= high_first[first])
            first, second = first[touch], second[touch]
        return queried[first], listed[second]

    blocks, begin = [], 0
    while begin < len(row):  # at most PAIRS_PER_BLOCK candidate pairs and LISTINGS_PER_BLOCK queries at once
        end = max(begin + 1, int(np.searchsorted(total, (total[begin - 1] if begin else 0) + PAIRS_PER_BLOCK)))
        end = min(end, begin + LISTINGS_PER_BLOCK)
        blocks.append(lambda chunk=slice(begin, end): block(chunk))
        begin = end
    return blocks


# A listing's flags: bit a set where its cell is its box's first along axis a.
_FLAGS = 8
# _ACCEPTED[needed, flags]: a query needing the flags ``needed`` reads listings whose flags hold them all.
_ACCEPTED = (np.arange(_FLAGS)[None, :] & np.arange(_FLAGS)[:, None]) == np.arange(_FLAGS)[:, None]


def _listed_cells(first: np.ndarray, spans: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(L,) the key (``_cell_keys``) of each grid cell of boxes whose first cells are ``first``
    (n, 3) and extents in cells ``spans`` (n, 3), (L,) the box of each, and (L,) its flags: bit a
    set where the cell is the box's first along axis a."""
    counts = spans.prod(axis=1)
    owner = runs(counts)
    offset = ranks(counts, owner)
    across, along = (spans[:, 1] * spans[:, 2])[owner], spans[owner, 2]  # cells per step along x and y
    x, left = np.divmod(offset, across)
    y, z = np.divmod(left, along)
    keys = _cell_keys(first)[owner] + (x * _KEY_SIDE + y) * _KEY_SIDE + z
    return keys, owner, (x == 0) + 2 * (y == 0) + 4 * (z == 0)


# Grid coordinates are in [0, 2^20] (``_cell_size``, ``_levels``): a cell's key is its coordinates in this base.
_KEY_SIDE = np.int64((1 << 20) + 2)


def _cell_keys(cells: np.ndarray) -> np.ndarray:
    """(n,) int64 key of grid cells (n, 3), each coordinate in [0, 2^20]."""
    return (cells[:, 0] * _KEY_SIDE + cells[:, 1]) * _KEY_SIDE + cells[:, 2]


def _every_pair(low_a, high_a, chosen_a, low_b, high_b, chosen_b):
    """The touching pairs of the chosen boxes of a with the chosen of b, all tested (axis by axis,
    on contiguous columns: several times faster than comparing rows of three)."""
    firsts, seconds = [np.zeros(0, dtype=np.int64)], [np.zeros(0, dtype=np.int64)]
    rows = max(1, PAIRS_PER_BLOCK // max(1, len(chosen_b)))
    b_low, b_high = np.ascontiguousarray(low_b[chosen_b].T), np.ascontiguousarray(high_b[chosen_b].T)  # (3, m)
    for begin in range(0, len(chosen_a), rows):
        block = chosen_a[begin:begin + rows]
        a_low, a_high = low_a[block].T, high_a[block].T  # (3, k)
        touch = (a_low[0, :, None] <= b_high[0]) & (b_low[0] <= a_high[0, :, None])
        for axis in (1, 2):
            touch &= a_low[axis, :, None] <= b_high[axis]
            touch &= b_low[axis] <= a_high[axis, :, None]
        row, column = np.nonzero(touch)
        firsts.append(block[row])
        seconds.append(chosen_b[column])
    return np.concatenate(firsts), np.concatenate(seconds)


def _cells(low: np.ndarray, high: np.ndarray, origin: np.ndarray, cell: float):
    """(n, 3) lowest grid cell of each box and (n, 3) its extent in cells."""
    first = np.floor((low - origin) / cell).astype(np.int64)
    return first, np.floor((high - origin) / cell).astype(np.int64) - first + 1


def ranks(counts: np.ndarray, run: np.ndarray | None = None) -> np.ndarray:
    """0, 1, ..., counts[0] - 1, 0, 1, ..., counts[1] - 1, ...: the rank within each run
    (``run``: ``runs(counts)``, when known)."""
    run = runs(counts) if run is None else run
    return np.arange(len(run)) - (np.cumsum(counts) - counts)[run]


def runs(counts: np.ndarray) -> np.ndarray:
    """0 counts[0] times, 1 counts[1] times, ...: np.repeat(np.arange(len(counts)), counts), by a
    cumulative sum of run starts, as np.repeat is not: it holds the GIL (0.6 s on 20 M entries),
    and no progress can be reported meanwhile (``progress.relayed``)."""
    total = int(counts.sum())
    starts = np.zeros(total, dtype=np.int64)
    ends = np.cumsum(counts)[:-1]
    np.add.at(starts, ends[ends < total], 1)
    return np.cumsum(starts)
