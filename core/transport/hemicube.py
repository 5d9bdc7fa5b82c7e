"""The hemicube (Cohen and Greenberg 1985): a half-cube of unit half-width around a point, with
a full top face of N x N pixels and four half side faces of N x N/2 pixels; each pixel carries
its delta form factor and shows the nearest surface through it.

Delta form factors, in the cube's frame (normal along z):
    top face, pixel at (x, y, 1):  dF = dA / (pi (x^2 + y^2 + 1)^2)
    side face, pixel at (1, y, z): dF = z dA / (pi (y^2 + z^2 + 1)^2)
Each pixel's dF is the exact integral of these densities over the pixel (not the midpoint value),
from their antiderivatives (the differential-area-to-rectangle factors, Howell B-3 and B-14):
    top:  G(x, y) = 1/(2 pi) [x/sqrt(1+x^2) atan(y/sqrt(1+x^2)) + y/sqrt(1+y^2) atan(x/sqrt(1+y^2))]
    side: K(y, z) = 1/(2 pi) [atan(y) - atan(y/sqrt(1+z^2)) / sqrt(1+z^2)]
so the pixels of a hemicube tile the hemisphere and their factors sum to 1 to rounding. The
nearest surface per pixel is found by a ray through the pixel's centre, which is what a z-buffer
sampling at pixel centres computes.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np

from ..mesh.discretize import Discretization
from ..rays.visibility import Visibility
from ..util.geometry import tangent_frames


def _top(x, y):
    sx, sy = np.sqrt(1 + x * x), np.sqrt(1 + y * y)
    return (x / sx * np.arctan(y / sx) + y / sy * np.arctan(x / sy)) / (2 * np.pi)


def _side(y, z):
    sz = np.sqrt(1 + z * z)
    return (np.arctan(y) - np.arctan(y / sz) / sz) / (2 * np.pi)


def _pixel_integrals(antiderivative, u_edges, v_edges):
    u0, v0 = np.meshgrid(u_edges[:-1], v_edges[:-1], indexing="ij")
    u1, v1 = np.meshgrid(u_edges[1:], v_edges[1:], indexing="ij")
    return (
        antiderivative(u1, v1) - antiderivative(u0, v1) - antiderivative(u1, v0) + antiderivative(u0, v0)
    ).ravel()


@lru_cache(maxsize=8)
def pixels(resolution: int) -> tuple[np.ndarray, np.ndarray]:
    """Unit directions (3 N^2, 3) through the pixel centres, in the cube's frame (normal +z), and
    the delta form factor (3 N^2,) of each pixel; ``resolution`` N is even."""
    if resolution < 2 or resolution % 2:
        raise ValueError(f"hemicube resolution must be an even number >= 2, got {resolution}")
    full = np.linspace(-1.0, 1.0, resolution + 1)
    half = np.linspace(0.0, 1.0, resolution // 2 + 1)
    full_mid, half_mid = (full[:-1] + full[1:]) / 2, (half[:-1] + half[1:]) / 2
    u, v = (a.ravel() for a in np.meshgrid(full_mid, full_mid, indexing="ij"))
    directions = [np.stack([u, v, np.ones_like(u)], axis=1)]
    factors = [_pixel_integrals(_top, full, full)]
    w, h = (a.ravel() for a in np.meshgrid(full_mid, half_mid, indexing="ij"))
    one = np.ones_like(w)
    for direction in (
        np.stack([one, w, h], axis=1),
        np.stack([-one, w, h], axis=1),
        np.stack([w, one, h], axis=1),
        np.stack([w, -one, h], axis=1),
    ):
        directions.append(direction)
        factors.append(_pixel_integrals(_side, full, half))
    directions = np.concatenate(directions)
    directions /= np.linalg.norm(directions, axis=1, keepdims=True)
    for array in (directions, factors := np.concatenate(factors)):
        array.setflags(write=False)
    return directions, factors


def visible_patches(
    points: np.ndarray, normals: np.ndarray, resolution: int, visibility: Visibility, mesh: Discretization
) -> tuple[np.ndarray, np.ndarray]:
    """Hemicubes at ``points`` (m, 3) facing ``normals`` (m, 3): the patch of ``mesh`` seen in
    each pixel (``visibility`` traces its front patches).

    Returns (m, 3 N^2) int patch indices (-1: nothing, or the back of a one-sided patch) and the
    pixels' delta form factors (3 N^2,). A front patch seen from behind is its back patch.
    """
    local, factors = pixels(resolution)
    tangent, bitangent = tangent_frames(normals)
    frames = np.stack([tangent, bitangent, normals], axis=1)  # (m, 3 axes, 3)
    directions = local @ frames  # (m, 3 N^2, 3)
    origins = np.broadcast_to(points[:, None, :], directions.shape).reshape(-1, 3)
    lift = np.broadcast_to(normals[:, None, :], directions.shape).reshape(-1, 3)
    hit = visibility.nearest(origins, directions.reshape(-1, 3), lift).reshape(len(points), -1)
    seen = hit.copy()
    struck = hit >= 0
    from_behind = np.zeros_like(struck)
    from_behind[struck] = np.einsum("nx,nx->n", directions[struck], mesh.patch_normals[hit[struck]]) > 0
    seen[from_behind] = mesh.back_of_front[hit[from_behind]]
    return seen, factors


def form_factor_rows(
    points: np.ndarray, normals: np.ndarray, resolution: int, visibility: Visibility, mesh: Discretization
) -> np.ndarray:
    """(m, P) form factors from points to every patch: the sum of dF over the pixels showing it."""
    patch_count = mesh.patch_count
    seen, factors = visible_patches(points, normals, resolution, visibility, mesh)
    rows = np.broadcast_to(np.arange(len(points))[:, None], seen.shape)
    shown = seen >= 0
    weights = np.broadcast_to(factors, seen.shape)[shown]
    flat = np.bincount(rows[shown] * patch_count + seen[shown], weights=weights, minlength=len(points) * patch_count)
    return flat.astype(np.float64, copy=False).reshape(len(points), patch_count)  # int when nothing is seen
