"""Which balls of one set overlap balls of another: a uniform grid instead of all pairs."""

from __future__ import annotations

import numpy as np

# A ball is listed in every cell its bounding box overlaps; the cell grows until the listings
# number at most this many per ball (plus a constant), so that one huge ball cannot blow it up.
LISTINGS_PER_BALL = 64


def overlapping(centres_a: np.ndarray, radii_a: np.ndarray, centres_b: np.ndarray,
                radii_b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Index pairs (i, j), each once, with |centres_a[i] - centres_b[j]| < radii_a[i] +
    radii_b[j]; centres (n, 3), radii (n,) >= 0."""
    empty = np.zeros(0, dtype=np.int64)
    if len(centres_a) == 0 or len(centres_b) == 0:
        return empty, empty
    origin = np.minimum((centres_a - radii_a[:, None]).min(axis=0), (centres_b - radii_b[:, None]).min(axis=0))
    radii = np.concatenate([radii_a, radii_b])
    spread = np.ptp(np.concatenate([centres_a, centres_b]), axis=0).max()
    cell = 2 * float(np.median(radii[radii > 0])) if (radii > 0).any() else spread
    cell = max(cell, spread * 1e-6, np.finfo(float).tiny)
    balls = len(centres_a) + len(centres_b)
    while True:
        boxes_a, boxes_b = _boxes(centres_a, radii_a, origin, cell), _boxes(centres_b, radii_b, origin, cell)
        if boxes_a[1].prod(axis=1).sum() + boxes_b[1].prod(axis=1).sum() <= LISTINGS_PER_BALL * balls + 4096:
            break
        cell *= 2
    cells_a, owner_a = _listings(*boxes_a)
    cells_b, owner_b = _listings(*boxes_b)
    shape = tuple(np.maximum(cells_a.max(axis=0), cells_b.max(axis=0)) + 1)
    key_a = np.ravel_multi_index(cells_a.T, shape)
    key_b = np.ravel_multi_index(cells_b.T, shape)
    order = np.argsort(key_b, kind="stable")
    key_b, owner_b = key_b[order], owner_b[order]
    start = np.searchsorted(key_b, key_a, side="left")
    count = np.searchsorted(key_b, key_a, side="right") - start
    first = np.repeat(owner_a, count)
    second = owner_b[np.repeat(start, count) + _ranks(count)]
    pairs = np.unique(first * len(centres_b) + second)
    first, second = pairs // len(centres_b), pairs % len(centres_b)
    close = np.linalg.norm(centres_a[first] - centres_b[second], axis=1) < radii_a[first] + radii_b[second]
    return first[close], second[close]


def _boxes(centres: np.ndarray, radii: np.ndarray, origin: np.ndarray, cell: float):
    """(n, 3) lowest grid cell of each ball's bounding box and (n, 3) its extent in cells."""
    low = np.floor((centres - radii[:, None] - origin) / cell).astype(np.int64)
    return low, np.floor((centres + radii[:, None] - origin) / cell).astype(np.int64) - low + 1


def _listings(low: np.ndarray, spans: np.ndarray):
    """(L, 3) grid cells of each box, and (L,) the box of each."""
    counts = spans.prod(axis=1)
    owner = np.repeat(np.arange(len(low)), counts)
    offset, span = _ranks(counts), spans[owner]
    cells = low[owner] + np.stack([offset // (span[:, 1] * span[:, 2]), (offset // span[:, 2]) % span[:, 1],
                                   offset % span[:, 2]], axis=1)
    return cells, owner


def _ranks(counts: np.ndarray) -> np.ndarray:
    """0, 1, ..., counts[0] - 1, 0, 1, ..., counts[1] - 1, ...: the rank within each run."""
    return np.arange(counts.sum()) - np.repeat(np.cumsum(counts) - counts, counts)
