"""Adaptive subdivision: split the patches where the solved radiosity changes fast.

A patch is split when its radiosity differs from a neighbour's on the same surface, or from the
colour of a vertex of its triangle that it touches, by more than a threshold (Cohen, Greenberg,
Immel and Brock 1986, "An efficient radiosity approach for realistic image synthesis": elements
are subdivided where the radiosity gradient is large).
Neighbours are patches sharing a corner, facing within the crease angle, of equal reflectance
and emission. Splitting is by edge midpoints into four congruent children; the T-junctions it
leaves between patches do no harm, since colours are read at the receiver nodes, which belong to
the input triangles and never change.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from ..util.geometry import area_vectors
from ..util.rows import sorted_labels
from .discretize import Discretization

# Patch corners closer than this fraction of the largest patch edge are one corner.
WELD_FRACTION = 1e-6


def to_split(mesh: Discretization, radiosity: np.ndarray, node_colors: np.ndarray, crease_angle: float,
             threshold: float) -> np.ndarray:
    """Indices of the front patches whose ``radiosity_jumps`` or ``corner_gaps`` exceed
    ``threshold`` times the area mean of the (largest channel of the) radiosity of the patches
    that emit nothing (of all patches if all emit)."""
    jumps = np.maximum(radiosity_jumps(mesh, radiosity, crease_angle), corner_gaps(mesh, node_colors, radiosity))
    return np.flatnonzero(jumps > threshold * radiosity_scale(mesh, radiosity))


def radiosity_scale(mesh: Discretization, radiosity: np.ndarray) -> float:
    """The area mean of the largest channel of the radiosity (P, C) of the patches that emit
    nothing (of all patches if all emit): what "fast" and "dark" are measured against."""
    quiet = ~mesh.patch_emission.any(axis=1)
    if not quiet.any():
        quiet = np.ones_like(quiet)
    return float(mesh.patch_areas[quiet] @ radiosity[quiet].max(axis=1) / mesh.patch_areas[quiet].sum())


def radiosity_jumps(mesh: Discretization, radiosity: np.ndarray, crease_angle: float) -> np.ndarray:
    """(F,) for each front patch, max over its neighbours n and channels c of |B_p,c - B_n,c|;
    ``radiosity`` (P, C), ``crease_angle`` in radians."""
    front = mesh.front_patch_count
    corners = mesh.patch_corners[:front]
    vertex = _welded_corners(corners)
    a, b = _patches_sharing_a_corner(vertex)
    normals = mesh.patch_normals[:front]
    same_surface = (
        ((normals[a] * normals[b]).sum(axis=1) >= np.cos(crease_angle) - 1e-12)
        & (mesh.patch_reflectance[a] == mesh.patch_reflectance[b]).all(axis=1)
        & (mesh.patch_emission[a] == mesh.patch_emission[b]).all(axis=1)
    )
    a, b = a[same_surface], b[same_surface]
    jumps = np.zeros(front)
    np.maximum.at(jumps, a, np.abs(radiosity[a] - radiosity[b]).max(axis=1))
    return jumps


def corner_gaps(mesh: Discretization, node_colors: np.ndarray, radiosity: np.ndarray) -> np.ndarray:
    """(F,) for each front patch, max over the receiver nodes at its own corners (nodes of its
    panel, within 1 % of its size of one of its corners) and channels of
    |c_node - B_p|: where a patch cannot show how light changes towards a vertex, which is
    where colours are read."""
    front = mesh.front_patch_count
    corners = mesh.patch_corners[:front]
    nodes = mesh.panel_node[mesh.patch_triangle[:front]]  # (F, 3) nodes of each patch's panel
    size = np.linalg.norm(corners[:, 1] - corners[:, 0], axis=1) + np.linalg.norm(corners[:, 2] - corners[:, 0], axis=1)
    gaps = np.zeros(front)
    for k in range(3):
        node = np.maximum(nodes[:, k], 0)
        distance = np.linalg.norm(corners - mesh.node_points[node][:, None, :], axis=2).min(axis=1)
        touching = (nodes[:, k] >= 0) & (distance <= 0.01 * size)
        gap = np.abs(node_colors[node] - radiosity[:front]).max(axis=1)
        gaps = np.maximum(gaps, np.where(touching, gap, 0.0))
    return gaps


def _welded_corners(corners: np.ndarray) -> np.ndarray:
    """(F, 3) id per patch corner, equal for corners at the same place."""
    points = corners.reshape(-1, 3)
    step = max(float(np.ptp(points, axis=0).max()), np.finfo(float).tiny) * WELD_FRACTION
    keys = np.round((points - points.min(axis=0)) / step).astype(np.int64)
    return sorted_labels(keys)[1].reshape(-1, 3)


def _patches_sharing_a_corner(vertex: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Every ordered pair (a, b), a != b, of patches with a corner in common (pairs may repeat)."""
    incident_vertex = vertex.ravel()
    incident_patch = np.repeat(np.arange(len(vertex)), 3)
    order = np.argsort(incident_vertex, kind="stable")
    incident_vertex, incident_patch = incident_vertex[order], incident_patch[order]
    starts = np.flatnonzero(np.r_[True, incident_vertex[1:] != incident_vertex[:-1]])
    sizes = np.diff(np.r_[starts, len(incident_vertex)])
    size = np.repeat(sizes, sizes)  # the size of each incidence's group
    first = np.repeat(starts, sizes)  # where each incidence's group starts
    a = np.repeat(incident_patch, size)
    within = np.arange(len(a)) - np.repeat(np.cumsum(size) - size, size)
    b = incident_patch[np.repeat(first, size) + within]
    keep = a != b
    return a[keep], b[keep]


def split(mesh: Discretization, chosen: np.ndarray) -> tuple[Discretization, np.ndarray]:
    """Split the front patches ``chosen`` (indices, with their backs) into four by their edge
    midpoints. Returns the new discretisation and, for each of its patches, the index of the
    patch it comes from in ``mesh`` (itself or its parent). Front patches stay grouped by input
    triangle in order; receiver nodes are unchanged."""
    front = mesh.front_patch_count
    is_chosen = np.zeros(front, dtype=bool)
    is_chosen[chosen] = True
    kept = np.flatnonzero(~is_chosen)
    parents = np.flatnonzero(is_chosen)
    children = _midpoint_children(mesh.patch_corners[parents])  # (4k, 3, 3), four per parent
    front_parent = np.concatenate([kept, np.repeat(parents, 4)])
    front_corners = np.concatenate([mesh.patch_corners[kept], children])
    order = np.argsort(mesh.patch_triangle[front_parent], kind="stable")
    front_parent, front_corners = front_parent[order], front_corners[order]

    has_back = mesh.back_of_front[front_parent] >= 0
    back_front = np.flatnonzero(has_back)  # new front patches that have a back
    back_of_front = np.full(len(front_parent), -1, dtype=np.int64)
    back_of_front[back_front] = len(front_parent) + np.arange(len(back_front))
    origin = np.concatenate([front_parent, mesh.back_of_front[front_parent[back_front]]])
    patch_corners = np.concatenate([front_corners, front_corners[back_front][:, ::-1]])
    refined = replace(
        mesh,
        patch_corners=patch_corners,
        patch_areas=np.linalg.norm(area_vectors(patch_corners), axis=1),
        patch_normals=mesh.patch_normals[origin],  # exactly as its parent (recomputed: rounding)
        patch_centroids=patch_corners.mean(axis=1),
        patch_reflectance=mesh.patch_reflectance[origin],
        patch_emission=mesh.patch_emission[origin],
        patch_triangle=mesh.patch_triangle[origin],
        patch_piece=mesh.patch_piece[origin],
        patch_casts=None if mesh.patch_casts is None else mesh.patch_casts[origin],
        patch_opacity=None if mesh.patch_opacity is None else mesh.patch_opacity[origin],
        front_patch_count=len(front_parent),
        back_of_front=back_of_front,
    )
    return refined, origin


def children(origin: np.ndarray, previous_count: int) -> np.ndarray:
    """Indices of the patches ``split`` made new (those sharing their origin with a sibling)."""
    return np.flatnonzero(np.bincount(origin, minlength=previous_count)[origin] > 1)


def _midpoint_children(corners: np.ndarray) -> np.ndarray:
    """(4k, 3, 3): triangles (a, b, c) -> (a, ab, ca), (ab, b, bc), (ca, bc, c), (ab, bc, ca),
    all facing as their parent, four consecutive children per parent."""
    a, b, c = corners[:, 0], corners[:, 1], corners[:, 2]
    ab, bc, ca = (a + b) / 2, (b + c) / 2, (c + a) / 2
    return np.stack([
        np.stack([a, ab, ca], axis=1),
        np.stack([ab, b, bc], axis=1),
        np.stack([ca, bc, c], axis=1),
        np.stack([ab, bc, ca], axis=1),
    ], axis=1).reshape(-1, 3, 3)
