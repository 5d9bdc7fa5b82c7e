"""Where each patch receives light: its centroid, unless part of the patch is buried.

A patch straddling the footprint of an object standing on it (a block on a floor) has part of
its area inside that object, where no light arrives. Received at its centroid, the patch is
black or lit depending on which side of the contact line the centroid falls, at any patch size;
yet only its visible part is ever seen. Such a patch receives instead at the unburied sample
point nearest the mean of its unburied sample points.

A point is buried when every probe ray from it (its normal and a ring of six directions 60
degrees off it) meets the back of a one-sided triangle first: all it sees is the inside of a
solid. (The back of a two-sided triangle is a surface like any other.)
"""

from __future__ import annotations

import numpy as np

from .discretize import Discretization
from .geometry import barycentric_grid, tangent_frames
from .visibility import Visibility

SAMPLE_DIVISIONS = 4  # the patch is tested at the centroids of its 4 x 4 strata
RING = 6  # probe directions around the normal, at PROBE_ANGLE from it
PROBE_ANGLE = np.radians(60)


def receiving_points(mesh: Discretization, visibility: Visibility) -> np.ndarray:
    """(P, 3) where each patch receives: its centroid, or for a patch partly buried, its
    unburied test point nearest the mean of its unburied test points. ``visibility`` holds the
    scene's triangles (``triangle_normals``, ``two_sided``)."""
    weights, cells = barycentric_grid(SAMPLE_DIVISIONS)
    points = np.einsum("sb,pbx->psx", weights[cells].mean(axis=1), mesh.patch_corners)  # (P, S, 3)
    buried = _buried(points, mesh.patch_normals, visibility)
    partly = buried.any(axis=1) & ~buried.all(axis=1)
    result = mesh.patch_centroids.copy()
    if not partly.any():
        return result
    points, free = points[partly], ~buried[partly]
    mean = (points * free[..., None]).sum(axis=1) / free.sum(axis=1, keepdims=True)
    distance = np.where(free, ((points - mean[:, None]) ** 2).sum(axis=2), np.inf)
    result[partly] = points[np.arange(len(points)), distance.argmin(axis=1)]
    return result


def _buried(points: np.ndarray, normals: np.ndarray, visibility: Visibility) -> np.ndarray:
    """(P, S) bool: whether every probe ray from points (P, S, 3) on surfaces facing normals
    (P, 3) first meets the back of a triangle."""
    tangent, bitangent = tangent_frames(normals)
    angles = 2 * np.pi * np.arange(RING) / RING
    ring = (np.cos(PROBE_ANGLE) * normals[:, None]
            + np.sin(PROBE_ANGLE) * (np.cos(angles)[None, :, None] * tangent[:, None]
                                     + np.sin(angles)[None, :, None] * bitangent[:, None]))
    directions = np.concatenate([normals[:, None], ring], axis=1)  # (P, D, 3)
    patches, samples, probes = points.shape[0], points.shape[1], directions.shape[1]
    origins = np.repeat(points, probes, axis=1).reshape(-1, 3)
    rays = np.tile(directions, (1, samples, 1)).reshape(-1, 3)
    lift = np.repeat(normals, samples * probes, axis=0)
    hit = visibility.nearest(origins, rays, lift)
    hit_normals = visibility.triangle_normals[np.maximum(hit, 0)]
    back = (hit >= 0) & ((rays * hit_normals).sum(axis=1) > 0) & ~visibility.two_sided[np.maximum(hit, 0)]
    return back.reshape(patches, samples, probes).all(axis=2)
