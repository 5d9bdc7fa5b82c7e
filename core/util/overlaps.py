"""Which triangles touch, and which lie over each other in one plane: pairs found through a
grid of their bounding boxes (``spatial``), then tested exactly."""

from __future__ import annotations

import numpy as np

from . import spatial
from .geometry import areas_and_normals, longest_edges

CONTACT_TOLERANCE = 1e-6  # distance to a plane, as a fraction of the triangle's longest edge, that counts as on it
# 1 - |cos| below which two triangles are coplanar (or parallel) and do not cut each other: an angle
# of 1e-3 radians. It absorbs float32 rounding (Blender's coordinates: 6e-8 of a 1 m scene, 1e-5
# radians on a 1 cm triangle) and near-flat modelling (a twisted quad split into a fine grid bends
# by a few 1e-4 radians from cell to cell, and must not cut itself along its shared edges), while
# a cylinder of 1,000 sides still bends by 6e-3 radians.
PARALLEL = 1 - np.cos(1e-3)
_NORMAL_SPREAD = 1.01 * np.sin(1e-3)  # how far apart two unit normals PARALLEL apart can be in a component
# Cells per axis of ``_sharing_a_plane``'s grids: each coordinate over its tolerance spans at most
# 2 / 1e-3 / 2 of them (a component of a unit normal, or an offset at most the reach).
_CELLS = 1 << 12
# The side every normal is turned to before their planes are compared (any direction few faces lie across).
SIDE = np.array([0.5773, 0.5774, 0.5775]) / np.linalg.norm([0.5773, 0.5774, 0.5775])


def coplanar_overlaps(corners: np.ndarray, owners: np.ndarray) -> np.ndarray:
    """(T,) bool: whether another triangle (of another owner) lies in each triangle's plane and
    overlaps its inside (``coplanar_overlap_pairs``)."""
    result = np.zeros(len(corners), dtype=bool)
    result[coplanar_overlap_pairs(corners, owners)[0]] = True
    return result


def coplanar_overlap_pairs(corners: np.ndarray, owners: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Pairs (a, b) of triangles, each pair both ways, where b (of another owner than a) lies in
    a's plane (within CONTACT_TOLERANCE of its size) and overlaps its inside (z-fighting faces, a
    card's two faces): neighbours that only share edges or corners do not count. Separating axes
    in the plane: the two overlap unless the six edge normals part their projections by more
    than the tolerance."""
    areas, normals = areas_and_normals(corners)
    valid = _sharing_a_plane(corners, normals, owners, np.flatnonzero(areas > 0))
    sizes = longest_edges(corners)

    def in_plane(first: np.ndarray, second: np.ndarray) -> np.ndarray:
        """Whether b, of another owner, lies in a's plane."""
        a, b = valid[first], valid[second]
        result = (owners[a] != owners[b]) & (np.abs((normals[a] * normals[b]).sum(axis=1)) >= 1 - PARALLEL)
        near = np.flatnonzero(result)
        a, b = a[near], b[near]
        heights = np.einsum("kcx,kx->kc", corners[b] - corners[a][:, :1], normals[a])
        result[near] = (np.abs(heights) <= CONTACT_TOLERANCE * sizes[a][:, None]).all(axis=1)
        return result

    low, high = padded_boxes(corners[valid])
    first, second = spatial.overlapping_boxes(low, high, low, high, in_plane)
    a, b = valid[first], valid[second]
    tolerance = CONTACT_TOLERANCE * sizes[a]
    overlap = np.ones(len(a), dtype=bool)
    for triangle in (a, b):
        for i in range(3):
            edge = corners[triangle, (i + 1) % 3] - corners[triangle, i]
            axis = np.cross(normals[a], edge)
            axis /= np.linalg.norm(axis, axis=1, keepdims=True)
            project_a = np.einsum("kcx,kx->kc", corners[a], axis)
            project_b = np.einsum("kcx,kx->kc", corners[b], axis)
            apart = (project_a.max(axis=1) <= project_b.min(axis=1) + tolerance) | \
                (project_b.max(axis=1) <= project_a.min(axis=1) + tolerance)
            overlap &= ~apart
    return a[overlap], b[overlap]


def _sharing_a_plane(corners: np.ndarray, normals: np.ndarray, owners: np.ndarray, chosen: np.ndarray) -> np.ndarray:
    """The triangles of ``chosen`` that may have a coplanar partner of another owner: those whose
    plane (unit normal n, turned to face SIDE, and offset d = n . x from the scene's middle) lies
    near another's. Coplanar partners differ by at most t_n = sin 1e-3 in each component of n
    (PARALLEL) and t_d = 1e-3 R + CONTACT_TOLERANCE x the longest edge in d (R: the farthest
    corner from the middle); two values at most t apart share a cell of size 2t in one of two grids
    offset by t, so a pair shares a cell in all four in one of the 16 grids offset so. A normal
    almost across SIDE is kept with both signs. Conservative: every triangle of a coplanar pair is
    kept; a mesh's curved parts are not."""
    if len(chosen) < 2:
        return chosen
    middle = (corners.reshape(-1, 3).min(axis=0) + corners.reshape(-1, 3).max(axis=0)) / 2
    reach = float(np.linalg.norm(corners - middle, axis=2).max())
    tolerance = np.array([_NORMAL_SPREAD] * 3 + [_NORMAL_SPREAD * reach
                                                  + CONTACT_TOLERANCE * float(longest_edges(corners).max())])
    normal = normals[chosen] * np.where(normals[chosen] @ SIDE < 0, -1.0, 1.0)[:, None]
    triangle = chosen
    across = np.flatnonzero(np.abs(normal @ SIDE) <= 2 * _NORMAL_SPREAD)
    normal, triangle = np.concatenate([normal, -normal[across]]), np.concatenate([triangle, triangle[across]])
    plane = np.column_stack([normal, np.einsum("kx,kx->k", normal, corners[triangle, 0] - middle)]) / tolerance
    kept = np.zeros(len(corners), dtype=bool)
    for offsets in np.ndindex(2, 2, 2, 2):
        cells = np.floor((plane + np.array(offsets)) / 2).astype(np.int64) + _CELLS // 2
        _, cell = np.unique(((cells[:, 0] * _CELLS + cells[:, 1]) * _CELLS + cells[:, 2]) * _CELLS + cells[:, 3],
                            return_inverse=True)
        lowest = np.full(cell.max() + 1, np.iinfo(np.int64).max)
        highest = np.full(cell.max() + 1, np.iinfo(np.int64).min)
        np.minimum.at(lowest, cell, owners[triangle])
        np.maximum.at(highest, cell, owners[triangle])
        kept[triangle[lowest[cell] != highest[cell]]] = True
    return chosen[kept[chosen]]


def padded_boxes(corners: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Lowest and highest corners (k, 3) of the bounding boxes of triangles (k, 3, 3), grown by
    CONTACT_TOLERANCE of each triangle's size: what may meet a triangle lies in its box."""
    pad = (CONTACT_TOLERANCE * longest_edges(corners))[:, None]
    return corners.min(axis=1) - pad, corners.max(axis=1) + pad
