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
# Cells of ``_plane_groups``' grid, in tolerances: coplanar partners share a cell or lie within a
# tolerance of its border (listed on both sides: 1 / 32 of the triangles per coordinate), and a
# unit normal's component spans about 1,000 tolerances (30 groups), so a floor's triangles are
# paired with each other but not with the walls'.
GROUP_CELL = 64.0
# The side every normal is turned to before their planes are compared (any direction few faces lie across).
SIDE = np.array([0.5773, 0.5774, 0.5775]) / np.linalg.norm([0.5773, 0.5774, 0.5775])


def coplanar_overlaps(corners: np.ndarray, owners: np.ndarray) -> np.ndarray:
    """(T,) bool: whether another triangle (of another owner) lies in each triangle's plane and
    overlaps its inside (``coplanar_overlap_pairs``)."""
    result = np.zeros(len(corners), dtype=bool)
    result[coplanar_overlap_pairs(corners, owners)[0]] = True
    return result


def coplanar_overlap_pairs(corners: np.ndarray, owners: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Pairs (a, b) of triangles, each pair both ways, sorted, where b (of another owner than a)
    lies in a's plane (within CONTACT_TOLERANCE of its size) and overlaps its inside (z-fighting
    faces, a card's two faces): neighbours that only share edges or corners do not count. The
    boxes are paired only within a plane's group (``_plane_groups``), each group's moved apart
    from the others' (a floor's triangles never meet the walls'). Separating axes in the plane:
    the two overlap unless the six edge normals part their projections by more than the
    tolerance."""
    areas, normals = areas_and_normals(corners)
    listed, group = _plane_groups(corners, normals, owners, np.flatnonzero(areas > 0))
    sizes = longest_edges(corners)

    def in_plane(first: np.ndarray, second: np.ndarray) -> np.ndarray:
        """Whether b, of another owner, lies in a's plane."""
        a, b = listed[first], listed[second]
        result = (owners[a] != owners[b]) & (np.abs((normals[a] * normals[b]).sum(axis=1)) >= 1 - PARALLEL)
        near = np.flatnonzero(result)
        a, b = a[near], b[near]
        heights = np.einsum("kcx,kx->kc", corners[b] - corners[a][:, :1], normals[a])
        result[near] = (np.abs(heights) <= CONTACT_TOLERANCE * sizes[a][:, None]).all(axis=1)
        return result

    low, high = padded_boxes(corners[listed])
    if len(listed):  # each group in a cell of its own of a grid of cells twice the scene's size
        span = 2 * float((high.max(axis=0) - low.min(axis=0)).max())
        side = int(np.ceil(np.cbrt(group.max() + 1)))
        shift = span * np.stack(np.unravel_index(group, (side,) * 3), axis=1)
        low, high = low + shift, high + shift
    first, second = spatial.overlapping_boxes(low, high, low, high, in_plane)
    pair = np.unique(listed[first] * len(corners) + listed[second])  # a pair may share two groups
    a, b = pair // len(corners), pair % len(corners)
    overlap = np.arange(len(a))  # the pairs no axis has parted yet: most part on the first
    for side in (0, 1):
        for i in range(3):
            still_a, still_b = a[overlap], b[overlap]
            triangle = still_a if side == 0 else still_b
            edge = corners[triangle, (i + 1) % 3] - corners[triangle, i]
            axis = np.cross(normals[still_a], edge)
            axis /= np.linalg.norm(axis, axis=1, keepdims=True)
            project_a = np.einsum("kcx,kx->kc", corners[still_a], axis)
            project_b = np.einsum("kcx,kx->kc", corners[still_b], axis)
            tolerance = CONTACT_TOLERANCE * sizes[still_a]
            apart = (project_a.max(axis=1) <= project_b.min(axis=1) + tolerance) | \
                (project_b.max(axis=1) <= project_a.min(axis=1) + tolerance)
            overlap = overlap[~apart]
    return a[overlap], b[overlap]


def _plane_groups(corners: np.ndarray, normals: np.ndarray, owners: np.ndarray,
                  chosen: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(triangle, group) listings of the triangles of ``chosen`` by their planes (unit normal n,
    turned to face SIDE, and offset d = n . x from the scene's middle), such that coplanar
    partners of different owners share a group: partners differ by at most t_n = sin 1e-3 in each
    component of n (PARALLEL) and t_d = 1e-3 R + CONTACT_TOLERANCE x the longest edge in d (R:
    the farthest corner from the middle). A triangle is listed in its plane's cell of a grid of
    cells GROUP_CELL x t in each of the four, and also in each neighbouring cell it lies within t
    of; a normal almost across SIDE is listed with both signs. Groups of a single owner are left
    out (a mesh's curved parts); groups are numbered from 0."""
    empty = np.zeros(0, dtype=np.int64)
    if len(chosen) < 2:
        return empty, empty
    middle = (corners.reshape(-1, 3).min(axis=0) + corners.reshape(-1, 3).max(axis=0)) / 2
    reach = float(np.linalg.norm(corners - middle, axis=2).max())
    tolerance = np.array([_NORMAL_SPREAD] * 3 + [_NORMAL_SPREAD * reach
                                                  + CONTACT_TOLERANCE * float(longest_edges(corners).max())])
    normal = normals[chosen] * np.where(normals[chosen] @ SIDE < 0, -1.0, 1.0)[:, None]
    triangle = chosen
    across = np.flatnonzero(np.abs(normal @ SIDE) <= 2 * _NORMAL_SPREAD)
    normal, triangle = np.concatenate([normal, -normal[across]]), np.concatenate([triangle, triangle[across]])
    plane = np.column_stack([normal, np.einsum("kx,kx->k", normal, corners[triangle, 0] - middle)]) / tolerance
    # cells centred on 0, not bordered there: an axis-aligned normal has two components at 0
    cells = np.floor(plane / GROUP_CELL + 0.5).astype(np.int64)
    inside = plane - (cells - 0.5) * GROUP_CELL  # in [0, GROUP_CELL)
    for axis in range(4):  # the neighbouring cells within t, axis by axis (at most 16 listings)
        for step in (-1, 1):
            near = inside[:, axis] <= 1.0 if step < 0 else inside[:, axis] >= GROUP_CELL - 1.0
            moved = cells[near].copy()
            moved[:, axis] += step
            cells, inside = np.concatenate([cells, moved]), np.concatenate([inside, inside[near]])
            triangle = np.concatenate([triangle, triangle[near]])
    cells -= cells.min(axis=0)
    _, group = np.unique(np.ravel_multi_index(cells.T, cells.max(axis=0) + 1), return_inverse=True)
    lowest = np.full(group.max() + 1, np.iinfo(np.int64).max)
    highest = np.full(group.max() + 1, np.iinfo(np.int64).min)
    np.minimum.at(lowest, group, owners[triangle])
    np.maximum.at(highest, group, owners[triangle])
    shared = lowest[group] != highest[group]
    _, group = np.unique(group[shared], return_inverse=True)
    return triangle[shared], group


def padded_boxes(corners: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Lowest and highest corners (k, 3) of the bounding boxes of triangles (k, 3, 3), grown by
    CONTACT_TOLERANCE of each triangle's size: what may meet a triangle lies in its box."""
    pad = (CONTACT_TOLERANCE * longest_edges(corners))[:, None]
    return corners.min(axis=1) - pad, corners.max(axis=1) + pad
