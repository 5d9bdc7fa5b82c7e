"""Which boxes of one set overlap those of another, and which points lie in which boxes: a
uniform grid, not all pairs."""

from __future__ import annotations

from typing import Callable

import numpy as np

from . import parallel

# A box is listed in every grid cell it overlaps; one overlapping more than LARGE_CELLS cells is
# tested against every box of the other set instead.
LARGE_CELLS = 4096
# Grid cells are this many times the median box size: boxes against boxes, twice (a box is listed
# in few cells); points against boxes, half (each point falls in one cell, and smaller cells
# test fewer boxes per point). Both chosen by timing the large scenes (docs/notes/experiments.md).
BOX_CELL = 2.0
POINT_CELL = 0.5
# Candidate pairs made at once (about 50 bytes each): bounds the memory of a dense cell.
PAIRS_PER_BLOCK = 1 << 22
# Boxes whose cells are listed at once by ``points_in_boxes`` (about 40 bytes per cell).
LISTINGS_PER_BLOCK = 1 << 20
# Up to this many pairs in all, every pair is tested: faster than building the grid.
EVERY_PAIR = 1 << 20


def overlapping_boxes(low_a: np.ndarray, high_a: np.ndarray, low_b: np.ndarray,
                      high_b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Index pairs (i, j), each once, sorted, of axis-aligned boxes (corners (n, 3)) of a and b
    that overlap or touch, through a grid (BOX_CELL)."""
    empty = np.zeros(0, dtype=np.int64)
    if len(low_a) == 0 or len(low_b) == 0:
        return empty, empty
    if len(low_a) * len(low_b) <= EVERY_PAIR:
        return _every_pair(low_a, high_a, np.arange(len(low_a)), low_b, high_b, np.arange(len(low_b)))
    sizes = np.concatenate([high_a - low_a, high_b - low_b]).max(axis=1)
    origin = np.minimum(low_a.min(axis=0), low_b.min(axis=0))
    spread = float((np.maximum(high_a.max(axis=0), high_b.max(axis=0)) - origin).max())
    cell = _cell_size(sizes, spread, BOX_CELL)
    boxes_a = _cells(low_a, high_a, origin, cell)
    boxes_b = _cells(low_b, high_b, origin, cell)
    large_a = np.flatnonzero(boxes_a[1].prod(axis=1) > LARGE_CELLS)
    large_b = np.flatnonzero(boxes_b[1].prod(axis=1) > LARGE_CELLS)
    small_a = np.setdiff1d(np.arange(len(low_a)), large_a)
    small_b = np.setdiff1d(np.arange(len(low_b)), large_b)
    parts = [_grid_pairs(boxes_a, small_a, boxes_b, small_b, (low_a, high_a, low_b, high_b)),
             _every_pair(low_a, high_a, large_a, low_b, high_b, np.arange(len(low_b)))]
    second, first = _every_pair(low_b, high_b, large_b, low_a, high_a, small_a)
    parts.append((first, second))
    keys = np.unique(np.concatenate([a * len(low_b) + b for a, b in parts]))
    return keys // len(low_b), keys % len(low_b)


def points_in_boxes(points: np.ndarray, low: np.ndarray, high: np.ndarray,
                    keep: Callable[[np.ndarray, np.ndarray], np.ndarray] | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Index pairs (i, j), each once, of the points (n, 3) lying in or on the boxes (corners
    (m, 3)) for which ``keep(i, j)`` (index arrays to a bool mask; None: all) holds, in a fixed
    order. Each point falls in one cell of a grid (POINT_CELL), so each pair is found once, and
    ``keep`` runs on the candidates block by block on the pool's threads: a caller's filters
    never see the whole candidate set at once."""
    empty = np.zeros(0, dtype=np.int64)
    if len(points) == 0 or len(low) == 0:
        return empty, empty
    origin = np.minimum(points.min(axis=0), low.min(axis=0))
    spread = float((np.maximum(points.max(axis=0), high.max(axis=0)) - origin).max())
    cell = _cell_size((high - low).max(axis=1), spread, POINT_CELL)
    cells, spans = _cells(low, high, origin, cell)
    point_cells = np.floor((points - origin) / cell).astype(np.int64)
    shape = tuple(np.maximum(point_cells.max(axis=0), (cells + spans - 1).max(axis=0)) + 1)
    point_keys = np.ravel_multi_index(point_cells.T, shape)
    by_cell = np.argsort(point_keys, kind="stable")
    sorted_keys = point_keys[by_cell]
    listed = spans.prod(axis=1)
    large = listed > LARGE_CELLS
    everything = np.arange(len(points))

    def accept(first: np.ndarray, second: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        inside = ((low[second] <= points[first]) & (points[first] <= high[second])).all(axis=1)
        first, second = first[inside], second[inside]
        if keep is not None and len(first):
            chosen = keep(first, second)
            first, second = first[chosen], second[chosen]
        return first, second

    def listed_block(boxes: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        listing, owner = _listings(cells[boxes], spans[boxes])
        keys = np.ravel_multi_index(listing.T, shape)
        start = np.searchsorted(sorted_keys, keys, side="left")
        count = np.searchsorted(sorted_keys, keys, side="right") - start
        total = np.cumsum(count)
        found, begin = [], 0
        while begin < len(keys):  # at most PAIRS_PER_BLOCK candidates at once
            end = max(begin + 1, int(np.searchsorted(total, (total[begin - 1] if begin else 0) + PAIRS_PER_BLOCK)))
            chunk = slice(begin, end)
            first = by_cell[np.repeat(start[chunk], count[chunk]) + ranks(count[chunk])]
            found.append(accept(first, boxes[np.repeat(owner[chunk], count[chunk])]))
            begin = end
        return _joined(found)

    def large_block(box: int) -> tuple[np.ndarray, np.ndarray]:
        return _joined([accept(chunk, np.full(len(chunk), box))  # every point, PAIRS_PER_BLOCK at once
                        for chunk in np.array_split(everything, -(-len(points) // PAIRS_PER_BLOCK))])

    if len(points) * len(low) <= EVERY_PAIR:  # every pair, the boxes split among the threads
        shares = np.array_split(np.arange(len(low)), min(parallel.THREADS, len(low)))
        return _joined(list(parallel.map_ordered(
            lambda boxes: accept(np.tile(everything, len(boxes)), np.repeat(boxes, len(points))), shares)))
    small = np.flatnonzero(~large)
    bounds = np.searchsorted(np.cumsum(listed[small]), np.arange(LISTINGS_PER_BLOCK, listed[small].sum(),
                                                                  LISTINGS_PER_BLOCK))
    blocks = [(listed_block, boxes) for boxes in np.split(small, bounds)] + \
        [(large_block, box) for box in np.flatnonzero(large)]
    return _joined(list(parallel.map_ordered(lambda job: job[0](job[1]), blocks)))


def _joined(parts: list[tuple[np.ndarray, np.ndarray]]) -> tuple[np.ndarray, np.ndarray]:
    """The (first, second) index pairs of ``parts`` one after another."""
    empty = np.zeros(0, dtype=np.int64)
    return np.concatenate([empty, *(first for first, _ in parts)]), np.concatenate([empty, *(second for _, second in parts)])


def _cell_size(sizes: np.ndarray, spread: float, times: float) -> float:
    """Grid cells ``times`` the median of the positive box ``sizes`` (the scene's ``spread`` if
    none), and at most 2^60 of them (int64 keys)."""
    cell = times * float(np.median(sizes[sizes > 0])) if (sizes > 0).any() else spread
    return max(cell, spread / (1 << 20), np.finfo(float).tiny)


def _boxes_touch(low_a, high_a, first, low_b, high_b, second) -> np.ndarray:
    """Whether boxes ``first`` of a touch boxes ``second`` of b (index arrays that broadcast)."""
    return ((low_a[first] <= high_b[second]) & (low_b[second] <= high_a[first])).all(axis=-1)


def _grid_pairs(boxes_a, chosen_a, boxes_b, chosen_b, corners):
    """The touching pairs among the chosen boxes, through the cells they share."""
    empty = np.zeros(0, dtype=np.int64)
    if len(chosen_a) == 0 or len(chosen_b) == 0:
        return empty, empty
    low_a, high_a, low_b, high_b = corners
    cells_a, owner_a = _listings(boxes_a[0][chosen_a], boxes_a[1][chosen_a])
    cells_b, owner_b = _listings(boxes_b[0][chosen_b], boxes_b[1][chosen_b])
    shape = tuple(np.maximum(cells_a.max(axis=0), cells_b.max(axis=0)) + 1)
    key_a = np.ravel_multi_index(cells_a.T, shape)
    key_b = np.ravel_multi_index(cells_b.T, shape)
    order = np.argsort(key_b, kind="stable")
    key_b, owner_b = key_b[order], chosen_b[owner_b[order]]
    owner_a = chosen_a[owner_a]
    start = np.searchsorted(key_b, key_a, side="left")
    count = np.searchsorted(key_b, key_a, side="right") - start
    total = np.cumsum(count)
    bounds, begin = [], 0
    while begin < len(key_a):  # listings of a in blocks of at most PAIRS_PER_BLOCK candidate pairs
        end = max(begin + 1, int(np.searchsorted(total, (total[begin - 1] if begin else 0) + PAIRS_PER_BLOCK)))
        bounds.append((begin, end))
        begin = end

    def block(bound: tuple[int, int]) -> np.ndarray:
        chunk = slice(*bound)
        first = np.repeat(owner_a[chunk], count[chunk])
        second = owner_b[np.repeat(start[chunk], count[chunk]) + ranks(count[chunk])]
        touch = _boxes_touch(low_a, high_a, first, low_b, high_b, second)
        return np.unique(first[touch] * len(low_b) + second[touch])

    keys = np.unique(np.concatenate([empty, *parallel.map_ordered(block, bounds)]))
    return keys // len(low_b), keys % len(low_b)


def _every_pair(low_a, high_a, chosen_a, low_b, high_b, chosen_b):
    """The touching pairs of the chosen boxes of a with the chosen of b, all tested."""
    firsts, seconds = [np.zeros(0, dtype=np.int64)], [np.zeros(0, dtype=np.int64)]
    rows = max(1, PAIRS_PER_BLOCK // max(1, len(chosen_b)))
    for begin in range(0, len(chosen_a), rows):
        block = chosen_a[begin:begin + rows]
        row, column = np.nonzero(_boxes_touch(low_a, high_a, block[:, None], low_b, high_b, chosen_b[None]))
        firsts.append(block[row])
        seconds.append(chosen_b[column])
    return np.concatenate(firsts), np.concatenate(seconds)


def _cells(low: np.ndarray, high: np.ndarray, origin: np.ndarray, cell: float):
    """(n, 3) lowest grid cell of each box and (n, 3) its extent in cells."""
    first = np.floor((low - origin) / cell).astype(np.int64)
    return first, np.floor((high - origin) / cell).astype(np.int64) - first + 1


def _listings(first: np.ndarray, spans: np.ndarray):
    """(L, 3) grid cells of each box, and (L,) the box of each."""
    counts = spans.prod(axis=1)
    owner = np.repeat(np.arange(len(first)), counts)
    offset, span = ranks(counts), spans[owner]
    cells = first[owner] + np.stack([offset // (span[:, 1] * span[:, 2]), (offset // span[:, 2]) % span[:, 1],
                                     offset % span[:, 2]], axis=1)
    return cells, owner


def ranks(counts: np.ndarray) -> np.ndarray:
    """0, 1, ..., counts[0] - 1, 0, 1, ..., counts[1] - 1, ...: the rank within each run."""
    return np.arange(counts.sum()) - np.repeat(np.cumsum(counts) - counts, counts)
