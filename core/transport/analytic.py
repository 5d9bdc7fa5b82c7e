"""Exact form factor from a differential area to a triangle, clipped at the receiver's horizon.

Lambert's contour formula (Cohen and Wallace, "Radiosity and Realistic Image Synthesis", 1993,
eq. 4.20; Baum, Rushmeier and Winget 1989):

    F(dA -> A) = 1/(2 pi) * sum_k gamma_k * n . (R_k x R_k+1) / |R_k x R_k+1|

with R_k the unit vectors from the point to the polygon's vertices, gamma_k the angle between
R_k and R_k+1, and n the receiver's normal. It holds only for the part of the polygon above the
receiver's tangent plane, so the triangle is clipped to that half-space first. A triangle shines
from its front only: a point behind its plane gets zero.
"""

from __future__ import annotations

import numpy as np


def point_to_triangle(points: np.ndarray, normals: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """(n,) float64 form factors from points (n, 3) with unit normals (n, 3) to the front of
    triangles (n, 3, 3), pairwise, without occlusion."""
    relative = triangles - points[:, None, :]  # (n, 3, 3)
    x, y, z = relative[..., 0], relative[..., 1], relative[..., 2]  # (n, 3) each
    ex, ey, ez = x[:, 1] - x[:, 0], y[:, 1] - y[:, 0], z[:, 1] - z[:, 0]
    fx, fy, fz = x[:, 2] - x[:, 0], y[:, 2] - y[:, 0], z[:, 2] - z[:, 0]
    nx, ny, nz = ey * fz - ez * fy, ez * fx - ex * fz, ex * fy - ey * fx  # e x f, twice the area
    double_area = np.sqrt(nx * nx + ny * ny + nz * nz)
    # Heights below this count as zero: rounding noise when the point lies in the triangle's
    # plane or the triangle in the point's (a patch must not see itself or its coplanar
    # neighbours), scaled by the triangle's size and by the coordinates' magnitude.
    size = np.sqrt(np.maximum(ex * ex + ey * ey + ez * ez, fx * fx + fy * fy + fz * fz))
    zero = 1e-9 * size + 1e-13 * _largest(np.abs(triangles).reshape(-1, 9))
    in_front = -(nx * x[:, 0] + ny * y[:, 0] + nz * z[:, 0])  # the point's height over the triangle, times 2A
    facing = in_front > zero * double_area
    height = (relative @ normals[:, :, None])[..., 0]  # (n, 3) above the receiver's plane
    result = np.zeros(len(points))
    above = facing & (_largest(height) > zero)
    whole = above & (np.minimum(np.minimum(height[:, 0], height[:, 1]), height[:, 2]) >= 0)
    index = np.flatnonzero(whole)
    result[index] = _contour(relative[index], normals[index])
    index = np.flatnonzero(above & ~whole)
    if len(index):
        result[index] = _contour(_clip_above(relative[index], height[index]), normals[index])
    return result


def _largest(values: np.ndarray) -> np.ndarray:
    """(n,) the largest of each row of (n, k): column by column, several times faster than
    ``max(axis=1)`` over a short axis."""
    result = values[:, 0].copy()
    for column in range(1, values.shape[1]):
        np.maximum(result, values[:, column], out=result)
    return result


def _contour(polygon: np.ndarray, normals: np.ndarray) -> np.ndarray:
    """Lambert's sum over closed polygons (n, k, 3) given relative to the point (computed on
    (k, n) rows, each coordinate contiguous)."""
    x, y, z = np.ascontiguousarray(polygon.transpose(2, 1, 0))  # (k, n) each
    length = np.maximum(np.sqrt(x * x + y * y + z * z), np.finfo(float).tiny)
    ux, uy, uz = x / length, y / length, z / length
    vx, vy, vz = (np.roll(u, -1, axis=0) for u in (ux, uy, uz))  # the next corner's
    cx, cy, cz = uy * vz - uz * vy, uz * vx - ux * vz, ux * vy - uy * vx
    sine = np.sqrt(cx * cx + cy * cy + cz * cz)
    gamma = np.arctan2(sine, ux * vx + uy * vy + uz * vz)
    projected = cx * normals[:, 0] + cy * normals[:, 1] + cz * normals[:, 2]
    terms = np.divide(gamma * projected, sine, out=np.zeros_like(sine), where=sine > 0)
    return np.abs(terms.sum(axis=0)) / (2 * np.pi)


def _clip_above(corners: np.ndarray, height: np.ndarray) -> np.ndarray:
    """Sutherland-Hodgman clip of triangles (n, 3, 3) to height >= 0, as 6 ordered slots per
    triangle (each vertex, then the crossing on the edge that follows it); unused slots repeat
    the previous used point so they add zero-length edges to the contour."""
    following = np.roll(corners, -1, axis=1)
    next_height = np.roll(height, -1, axis=1)
    inside = height >= 0
    crosses = inside != (next_height >= 0)
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.where(crosses, height / (height - next_height), 0.0)
    crossing = corners + t[..., None] * (following - corners)
    slots = np.stack([corners, crossing], axis=2).reshape(len(corners), 6, 3)
    used = np.stack([inside, crosses], axis=2).reshape(len(corners), 6)
    # forward-fill unused slots cyclically from the last used one
    twice = np.concatenate([used, used], axis=1)
    latest = np.maximum.accumulate(np.where(twice, np.arange(12), 0), axis=1)[:, 6:] % 6
    return np.take_along_axis(slots, latest[..., None], axis=1)
