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

from ..mesh.discretize import Discretization
from ..rays.visibility import Visibility
from ..util import parallel
from ..util.geometry import barycentric_grid, tangent_frames

# The patch is tested at the centroids of its SAMPLE_DIVISIONS x SAMPLE_DIVISIONS strata. Contact
# lines cut the larger patches (``mesh.contacts``), so those left partly buried are small, and 2 x 2
# points find them as well as 4 x 4 did, in a quarter of the time (docs/notes/experiments.md,
# "Sponza's noise, the top arches' bias, the final gather's rays").
SAMPLE_DIVISIONS = 2
RING = 6  # probe directions around the normal, at PROBE_ANGLE from it
PROBE_ANGLE = np.radians(60)
RAYS_PER_BLOCK = 1 << 18  # probe rays per block of work on the thread pool


def receiving_points(mesh: Discretization, visibility: Visibility) -> np.ndarray:
    """(P, 3) where each patch receives: its centroid, or for a patch partly buried, its
    unburied test point nearest the mean of its unburied test points. ``visibility`` holds the
    scene's triangles (``triangle_normals``, ``two_sided``)."""
    weights, cells = barycentric_grid(SAMPLE_DIVISIONS)
    points = weights[cells].mean(axis=1) @ mesh.patch_corners  # (P, S, 3)
    inside = buried(points, mesh.patch_normals, visibility)
    partly = inside.any(axis=1) & ~inside.all(axis=1)
    result = mesh.patch_centroids.copy()
    if not partly.any():
        return result
    points, free = points[partly], ~inside[partly]
    mean = (points * free[..., None]).sum(axis=1) / free.sum(axis=1, keepdims=True)
    distance = np.where(free, ((points - mean[:, None]) ** 2).sum(axis=2), np.inf)
    result[partly] = points[np.arange(len(points)), distance.argmin(axis=1)]
    return result


def buried(points: np.ndarray, normals: np.ndarray, visibility: Visibility) -> np.ndarray:
    """(P, S) bool: whether every probe ray from points (P, S, 3) on surfaces facing normals
    (P, 3) first meets the back of a triangle. The ray along the normal goes first, the ring only
    from the points where it met a back (elsewhere the point is free whatever the ring meets):
    in a room most points see a front along their normal, so most of the ring is never cast.
    Where every triangle is two-sided (the add-on's default) or has the whole scene in front of
    it (``Visibility.enclosing``: no ray from a surface meets its back), no point is buried: none
    is cast."""
    patches, samples = points.shape[:2]
    if (visibility.two_sided | visibility.enclosing).all():
        return np.zeros((patches, samples), dtype=bool)
    origins = points.reshape(-1, 3)
    lift = normals[np.arange(patches * samples) // samples]  # not np.repeat, which holds the GIL
    candidates = np.flatnonzero(_meets_a_back(origins, lift, lift, visibility))
    if len(candidates) == 0:
        return np.zeros((patches, samples), dtype=bool)
    tangent, bitangent = tangent_frames(lift[candidates])
    angles = 2 * np.pi * np.arange(RING) / RING
    ring = (np.cos(PROBE_ANGLE) * lift[candidates][:, None]
            + np.sin(PROBE_ANGLE) * (np.cos(angles)[None, :, None] * tangent[:, None]
                                     + np.sin(angles)[None, :, None] * bitangent[:, None]))  # (k, RING, 3)
    each = candidates[np.arange(len(candidates) * RING) // RING]
    back = _meets_a_back(origins[each], ring.reshape(-1, 3), lift[each], visibility)
    buried = np.zeros(patches * samples, dtype=bool)
    buried[candidates] = back.reshape(-1, RING).all(axis=1)
    return buried.reshape(patches, samples)


def _meets_a_back(origins: np.ndarray, directions: np.ndarray, lift: np.ndarray, visibility: Visibility) -> np.ndarray:
    """(n,) bool: whether the ray from each origin (n, 3; lifted off its surface along ``lift``)
    along ``directions`` (n, 3, unit) first meets the back of a one-sided triangle; in blocks on
    the thread pool."""

    def block(start: int) -> np.ndarray:
        chunk = slice(start, start + RAYS_PER_BLOCK)
        hit = visibility.nearest(origins[chunk], directions[chunk], lift[chunk])
        index = np.maximum(hit, 0)
        facing = (directions[chunk] * visibility.triangle_normals[index]).sum(axis=1) > 0
        return (hit >= 0) & facing & ~visibility.two_sided[index]

    parts = list(parallel.map_ordered(block, range(0, len(origins), RAYS_PER_BLOCK)))
    return np.concatenate(parts) if parts else np.zeros(0, dtype=bool)
