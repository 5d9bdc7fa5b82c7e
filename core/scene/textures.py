"""Colours that vary over a surface, as per-triangle means: an image over each triangle's UV
footprint, and per-face means of them (a face's triangles share its corners' colours)."""

from __future__ import annotations

import numpy as np

from ..util.geometry import barycentric_grid

# A triangle is sampled at the centroids of n^2 congruent pieces, n its longest UV edge in pixels,
# at most this: a triangle spanning more pixels is read at MAX_DIVISIONS^2 points.
MAX_DIVISIONS = 64


def image_triangle_means(pixels: np.ndarray, uv: np.ndarray) -> np.ndarray:
    """(T, C) mean of the image ``pixels`` (H, W, C; row 0 at v = 0, as Blender stores images)
    over each triangle ``uv`` (T, 3, 2), the image repeated beyond [0, 1) (Blender's Repeat
    extension): the nearest pixel at the centroids of n^2 congruent pieces of the triangle (equal
    areas, so the plain mean is the area mean), n = the longest UV edge in pixels, at least 1 and
    at most MAX_DIVISIONS."""
    height, width = pixels.shape[:2]
    in_pixels = uv * [width, height]
    edges = np.linalg.norm(in_pixels - np.roll(in_pixels, 1, axis=1), axis=2).max(axis=1)
    divisions = np.clip(np.ceil(edges), 1, MAX_DIVISIONS).astype(np.int64)
    means = np.empty((len(uv), pixels.shape[2]))
    for n in np.unique(divisions):
        chosen = np.flatnonzero(divisions == n)
        weights, cells = barycentric_grid(int(n))
        centroids = weights[cells].mean(axis=1)  # (n^2, 3) barycentric centroid of each piece
        points = centroids @ in_pixels[chosen]  # (t, n^2, 2) in pixels
        column = np.floor(points[..., 0]).astype(np.int64) % width
        row = np.floor(points[..., 1]).astype(np.int64) % height
        means[chosen] = pixels[row, column].mean(axis=1)
    return means


def face_means(values: np.ndarray, areas: np.ndarray, face: np.ndarray) -> np.ndarray:
    """(T, C) the area-weighted mean of ``values`` (T, C) over the triangles of each face, given
    back to every triangle of it (``face`` (T,) the face of each triangle, ``areas`` (T,))."""
    _, group = np.unique(face, return_inverse=True)
    weight = np.bincount(group, weights=areas)
    sums = np.stack([np.bincount(group, weights=areas * values[:, c]) for c in range(values.shape[1])], axis=1)
    plain = np.stack([np.bincount(group, weights=values[:, c]) for c in range(values.shape[1])], axis=1)
    counts = np.bincount(group)
    means = np.where((weight > 0)[:, None], sums / np.where(weight > 0, weight, 1.0)[:, None], plain / counts[:, None])
    return means[group]
