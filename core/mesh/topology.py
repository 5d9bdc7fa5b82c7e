"""Which corners are one vertex, which triangles are connected, which have no area: the
topology every meshing step agrees on."""

from __future__ import annotations

import numpy as np

from ..util.geometry import areas_and_normals, longest_edges
from ..util.rows import sorted_labels

# A triangle whose area is below this fraction of its longest edge squared is treated as having
# zero area (its normal is rounding noise). An aspect ratio of 1e4 is 1e-4, far above this.
DEGENERATE_AREA_RATIO = 1e-14
# Vertices closer than this fraction of the scene's extent are one vertex for node merging.
WELD_TOLERANCE = 1e-9


def degenerate(corners: np.ndarray) -> np.ndarray:
    """(T,) bool: the triangles (T, 3, 3) whose area is at most DEGENERATE_AREA_RATIO of their
    longest edge squared (they make no patch and have no normal)."""
    return areas_and_normals(corners)[0] <= DEGENERATE_AREA_RATIO * longest_edges(corners) ** 2


def weld_corners(corners: np.ndarray, extent: float) -> np.ndarray:
    """(T, 3) id per corner; corners at the same position (within WELD_TOLERANCE of the scene's
    ``extent``) share an id."""
    points = corners.reshape(-1, 3)
    step = max(extent, np.finfo(float).tiny) * WELD_TOLERANCE
    keys = np.round((points - points.min(axis=0)) / step).astype(np.int64)
    return sorted_labels(keys)[1].reshape(-1, 3)


def connected_components(count: int, pairs: np.ndarray) -> np.ndarray:
    """Label (count,) per item: the smallest item index of its component (min-label propagation
    with pointer jumping)."""
    labels = np.arange(count)
    if len(pairs) == 0:
        return labels
    a, b = pairs.T
    while True:
        low = np.minimum(labels[a], labels[b])
        previous = labels.copy()
        np.minimum.at(labels, a, low)
        np.minimum.at(labels, b, low)
        labels = labels[labels]
        if np.array_equal(labels, previous):
            return labels
