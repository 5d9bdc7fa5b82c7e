"""Which boxes of one set overlap those of another: a uniform grid, not all pairs."""

from __future__ import annotations

import numpy as np

from . import parallel

# A box is listed in every grid cell it overlaps; one overlapping more than LARGE_CELLS cells is
# tested against every box of the other set instead.
LARGE_CELLS = 4096
# Grid cells are this many times the median box size: boxes against boxes, twice (Sponza's
# triangles against themselves: 2.2 s; at half, 5.0 s); points against boxes, half (the vertices of
# the 40 x 40 Cornell box against their near patches: 0.18 s; at twice, 0.93 s).
BOX_CELL = 2.0
POINT_CELL = 0.5
# Candidate pairs made at once (about 50 bytes each): bounds the memory of a dense cell.
PAIRS_PER_BLOCK = 1 << 22
# Up to this many pairs in all, every pair is tested: faster than building the grid.
EVERY_PAIR = 1 << 20


def overlapping_boxes(low_a: np.ndarray, high_a: np.ndarray, low_b: np.ndarray,
                      high_b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Index pairs (i, j), each once, sorted, of axis-aligned boxes (corners (n, 3)) of a and b
    that overlap or touch, through a grid (BOX_CELL, POINT_CELL)."""
    empty = np.zeros(0, dtype=np.int64)
    if len(low_a) == 0 or len(low_b) == 0:
        return empty, empty
    if len(low_a) * len(low_b) <= EVERY_PAIR:
        return _every_pair(low_a, high_a, np.arange(len(low_a)), low_b, high_b, np.arange(len(low_b)))
    sizes = np.concatenate([high_a - low_a, high_b - low_b]).max(axis=1)
    origin = np.minimum(low_a.min(axis=0), low_b.min(axis=0))
    spread = float((np.maximum(high_a.max(axis=0), high_b.max(axis=0)) - origin).max())
    points = not (high_a > low_a).any() or not (high_b > low_b).any()
    cell = (POINT_CELL if points else BOX_CELL) * float(np.median(sizes[sizes > 0])) if (sizes > 0).any() else spread
    cell = max(cell, spread / (1 << 20), np.finfo(float).tiny)  # at most 2^60 cells: int64 keys
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
