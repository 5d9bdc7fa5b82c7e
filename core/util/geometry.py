"""Small geometric helpers on arrays of triangles; no state."""

from __future__ import annotations

import numpy as np

# ``enclosing`` tests every point against every plane, up to this many pairs (a large scene is not
# a room, and is left without); a point this far behind a plane, as a fraction of the scene's
# extent, counts as on it (float32 coordinates resolve about 6e-8 of it).
ENCLOSING_PAIRS = 1 << 25
ENCLOSING_TOLERANCE = 1e-7
# The golden ratio's fractional part: the generator of the rank-1 lattices of sample points
# (i / n, i GOLDEN mod 1), evenly spread for any n.
GOLDEN = (np.sqrt(5) - 1) / 2
# ``solid_angle_directions`` keeps its points at least this share of the way in from each edge:
# from a point close to a source, many directions aim at its edges, and a ray stops short of the
# source's plane (``raycast``), so one aimed along a wall that meets the source's edge (a box
# against another) could stop before the wall.
INSIDE = 1e-3


def triangle_corners(vertices: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """(T, 3, 3) float64 corner positions of each triangle."""
    return vertices[triangles]


def area_vectors(corners: np.ndarray) -> np.ndarray:
    """(T, 3) half the cross product of two edges: area times unit normal (right-hand rule)."""
    return 0.5 * np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])


def areas_and_normals(corners: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Areas (T,) and unit normals (T, 3); a zero-area triangle gets a zero normal."""
    vectors = area_vectors(corners)
    areas = np.linalg.norm(vectors, axis=1)
    normals = np.divide(vectors, areas[:, None], out=np.zeros_like(vectors), where=areas[:, None] > 0)
    return areas, normals


def longest_edges(corners: np.ndarray) -> np.ndarray:
    """(T,) length of each triangle's longest edge."""
    edges = corners[:, [1, 2, 0]] - corners
    return np.linalg.norm(edges, axis=2).max(axis=1)


def tangent_frames(normals: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Two unit tangents (n, 3) each, orthogonal to the unit ``normals`` and to each other: the
    first two rows of ``orthonormal_frames``."""
    frames = orthonormal_frames(normals)
    return frames[:, 0], frames[:, 1]


def orthonormal_frames(normals: np.ndarray) -> np.ndarray:
    """(n, 3, 3) frames about unit ``normals`` (n, 3): rows a unit tangent, a unit bitangent
    (tangent x bitangent = normal) and the normal, written in place (stacking them took longer
    than computing them).

    Branchless construction of Duff et al., "Building an Orthonormal Basis, Revisited" (JCGT 2017).
    """
    x, y, z = normals[:, 0], normals[:, 1], normals[:, 2]
    sign = np.where(z >= 0, 1.0, -1.0)
    a = -1.0 / (sign + z)
    b = x * y * a
    frames = np.empty((len(normals), 3, 3))
    frames[:, 0, 0], frames[:, 0, 1], frames[:, 0, 2] = 1 + sign * x * x * a, sign * b, -sign * x
    frames[:, 1, 0], frames[:, 1, 1], frames[:, 1, 2] = b, sign + y * y * a, -y
    frames[:, 2] = normals
    return frames


def barycentric_grid(divisions: int) -> tuple[np.ndarray, np.ndarray]:
    """Regular split of a triangle into ``divisions**2`` congruent sub-triangles.

    Returns grid points as barycentric weights (G, 3) and sub-triangles (divisions**2, 3) as
    indices into the grid, with the parent's orientation. Grid point (i, j) sits at
    a + i/n (b - a) + j/n (c - a).
    """
    n = divisions
    i, j = np.array([(i, j) for j in range(n + 1) for i in range(n + 1 - j)]).T
    index = {(a, b): k for k, (a, b) in enumerate(zip(i.tolist(), j.tolist()))}
    weights = np.stack([n - i - j, i, j], axis=1) / n
    cells = []
    for jj in range(n):
        for ii in range(n - jj):
            cells.append((index[ii, jj], index[ii + 1, jj], index[ii, jj + 1]))
            if ii + jj + 2 <= n:
                cells.append((index[ii + 1, jj], index[ii + 1, jj + 1], index[ii, jj + 1]))
    return weights, np.array(cells, dtype=np.int64)


def subdivide(corners: np.ndarray, divisions: int) -> np.ndarray:
    """(T * divisions**2, 3, 3): each triangle of ``corners`` (T, 3, 3) split regularly
    (``barycentric_grid``), its sub-triangles consecutive."""
    weights, cells = barycentric_grid(divisions)
    points = weights @ corners  # (T, G, 3)
    return points[:, cells].reshape(-1, 3, 3)


def barycentric(points: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """(K, 3) barycentric coordinates of points (K, 3) in the planes of triangles (K, 3, 3)."""
    a, b, c = triangles[:, 0], triangles[:, 1], triangles[:, 2]
    normal = np.cross(b - a, c - a)
    total = (normal ** 2).sum(axis=1)
    weight_a = np.einsum("kx,kx->k", np.cross(c - b, points - b), normal) / total
    weight_b = np.einsum("kx,kx->k", np.cross(a - c, points - c), normal) / total
    return np.stack([weight_a, weight_b, 1 - weight_a - weight_b], axis=1)


def enclosing(corners: np.ndarray, tolerance: float) -> np.ndarray:
    """(T,) bool: the triangles (T, 3, 3) with every corner of the set at most ``tolerance`` behind
    their plane, as a room's walls; degenerate ones are not. None are when that is more than
    ENCLOSING_PAIRS tests. Nothing lies behind such a triangle (up to ``tolerance``): a segment
    between two points on or in front of it stays in the closed half-space before it, and its
    back faces no surface."""
    result = np.zeros(len(corners), dtype=bool)
    if len(corners) ** 2 // 2 > ENCLOSING_PAIRS:  # a closed mesh has about half as many vertices as triangles
        return result
    points = np.unique(corners.reshape(-1, 3), axis=0)
    if len(points) * len(corners) > ENCLOSING_PAIRS:
        return result
    normals = areas_and_normals(corners)[1]
    offsets = np.einsum("tx,tx->t", normals, corners[:, 0])
    rows = max(1, ENCLOSING_PAIRS // 64 // len(points))  # about 4 MiB of heights at a time
    for start in range(0, len(corners), rows):
        planes = slice(start, start + rows)
        result[planes] = (points @ normals[planes].T).min(axis=0) - offsets[planes] >= -tolerance
    return result & normals.any(axis=1)


def uniform_points(corners: np.ndarray, uv: np.ndarray) -> np.ndarray:
    """(n, 3) points of triangles ``corners`` (n, 3, 3), uniform in area for uniform ``uv``
    (n, 2): (1 - sqrt(u)) a + sqrt(u) (1 - v) b + sqrt(u) v c. Leading axes broadcast: corners
    (k, 1, 3, 3) and uv (k, m, 2) give (k, m, 3), m points of each triangle."""
    root = np.sqrt(uv[..., :1])
    return (1 - root) * corners[..., 0, :] + root * (1 - uv[..., 1:]) * corners[..., 1, :] \
        + root * uv[..., 1:] * corners[..., 2, :]


def cosine_directions(normals: np.ndarray, uv: np.ndarray) -> np.ndarray:
    """(n, ..., 3) unit directions about unit ``normals`` (n, 3) from points ``uv`` (n, ..., 2) of
    the unit square, distributed as cos(theta) / pi when uv is uniform (Malley's method: a uniform
    point of the unit disc, r = sqrt(u), phi = 2 pi v, lifted to the hemisphere); each normal's
    frame is built once for all its points. The angle's cosine and sine are taken in float32 (to
    about 3e-7, as the rays are traced), several times faster than in float64."""
    angle = (2 * np.pi * uv[..., 1]).astype(np.float32)
    radius = np.sqrt(uv[..., 0])
    local = np.empty((*uv.shape[:-1], 3))  # (n, ..., 3) in the frame (tangent, bitangent, normal)
    local[..., 0], local[..., 1] = radius * np.cos(angle), radius * np.sin(angle)
    local[..., 2] = np.sqrt(np.maximum(1.0 - uv[..., 0], 0.0))
    frames = orthonormal_frames(normals)
    per_normal = int(np.prod(uv.shape[1:-1]))
    return (local.reshape(len(normals), per_normal, 3) @ frames).reshape(local.shape)


def solid_angle_directions(points: np.ndarray, corners: np.ndarray, uv: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(k, S, 3) float32 unit directions from ``points`` (k, 3) into triangles ``corners`` (k, 3, 3),
    uniform in the solid angle each triangle subtends for uniform ``uv`` (k, S, 2) (Arvo,
    "Stratified sampling of spherical triangles", 1995, as Pharr, Jakob and Humphreys write it,
    "Physically Based Rendering", 4th ed., 6.5.4: u picks the area of a sub-triangle A' = u A, v
    a point along its last arc); and (k, S, 3) float32 the offsets from each point to where its
    directions meet the triangle. The area of the spherical triangle is alpha + beta + gamma - pi,
    its angles' sum. What is per triangle is computed in float64, what is per sample in float32
    (to about 1e-6, as rays are traced). The points are kept INSIDE of the way in from each edge
    (that rounding, where a triangle is seen almost edge-on, would put some outside it)."""
    a, b, c = (_unit(corners[:, corner] - points) for corner in range(3))
    n_ab, n_bc, n_ca = _unit(np.cross(a, b)), _unit(np.cross(b, c)), _unit(np.cross(c, a))
    alpha = _angle(n_ab, -n_ca)
    spread = _angle(n_bc, -n_ab) + _angle(n_ca, -n_bc) + alpha - np.pi  # the solid angle
    across_a = _unit(c - np.einsum("kx,kx->k", c, a)[:, None] * a)  # c made orthogonal to a
    single = np.float32
    cos_alpha, sin_alpha = (value.astype(single)[:, None] for value in (np.cos(alpha), np.sin(alpha)))
    a_b = np.einsum("kx,kx->k", a, b).astype(single)[:, None]
    # A' + pi = pi + u A: its cosine and sine are minus those of u A
    sub_area = uv[..., 0].astype(single) * spread.astype(single)[:, None]
    cos_area, sin_area = -np.cos(sub_area), -np.sin(sub_area)
    sin_phi = sin_area * cos_alpha - cos_area * sin_alpha
    cos_phi = cos_area * cos_alpha + sin_area * sin_alpha
    k1, k2 = cos_phi + cos_alpha, sin_phi - sin_alpha * a_b
    denominator = (k2 * sin_phi + k1 * cos_phi) * sin_alpha
    denominator[denominator == 0] = np.finfo(single).tiny
    cos_b = np.clip((k2 + (k2 * cos_phi - k1 * sin_phi) * cos_alpha) / denominator, -1, 1)
    sin_b = np.sqrt(1 - cos_b * cos_b)
    a, b, across_a = (vector.astype(single).T[:, :, None] for vector in (a, b, across_a))  # (3, k, 1)
    arc_end = cos_b * a + sin_b * across_a  # (3, k, S): c' on the arc from a to c
    along = arc_end[0] * b[0] + arc_end[1] * b[1] + arc_end[2] * b[2]
    cos_t = 1 - uv[..., 1].astype(single) * (1 - along)
    sin_t = np.sqrt(np.maximum(1 - cos_t * cos_t, 0))
    across_b = arc_end - along * b
    length = np.sqrt(across_b[0] * across_b[0] + across_b[1] * across_b[1] + across_b[2] * across_b[2])
    across_b *= sin_t / np.where(length > 0, length, 1)
    directions = cos_t * b + across_b  # (3, k, S)
    first, second = corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]
    normal = np.cross(first, second)
    height = np.einsum("kx,kx->k", normal, corners[:, 0] - points)[:, None]
    normal, to_corner = (vector.astype(single).T[:, :, None] for vector in (normal, corners[:, 0] - points))
    facing = directions[0] * normal[0] + directions[1] * normal[1] + directions[2] * normal[2]
    facing[facing == 0] = np.finfo(single).tiny
    # the barycentric coordinates (1 - s - t, s, t) of where the directions meet the plane, kept
    # INSIDE of the way from each edge
    from_corner = directions * (height.astype(single) / facing) - to_corner  # (3, k, S)
    first_first, first_second, second_second = (np.einsum("kx,kx->k", u, v) for u, v in (
        (first, first), (first, second), (second, second)))
    scale = 1 / (first_first * second_second - first_second**2)
    # s = (|e2|^2 (q . e1) - (e1 . e2) (q . e2)) / det: q dotted with the dual vectors of the edges
    dual_first, dual_second = ((scale[:, None] * vector).astype(single).T[:, :, None] for vector in (
        second_second[:, None] * first - first_second[:, None] * second,
        first_first[:, None] * second - first_second[:, None] * first))
    s = from_corner[0] * dual_first[0] + from_corner[1] * dual_first[1] + from_corner[2] * dual_first[2]
    t = from_corner[0] * dual_second[0] + from_corner[1] * dual_second[1] + from_corner[2] * dual_second[2]
    np.clip(s, INSIDE, 1 - 2 * INSIDE, out=s)
    np.clip(t, INSIDE, 1 - 2 * INSIDE, out=t)
    excess = np.maximum((s + t - (1 - INSIDE)) / 2, 0)
    s -= excess
    t -= excess
    first, second = (vector.astype(single).T[:, :, None] for vector in (first, second))
    offsets = np.empty(s.shape + (3,), dtype=single)
    for axis in range(3):
        offsets[..., axis] = to_corner[axis] + s * first[axis] + t * second[axis]
    return np.moveaxis(directions, 0, 2), offsets


def _unit(vectors: np.ndarray) -> np.ndarray:
    """``vectors`` (..., 3) over their lengths (zero ones left zero)."""
    length = np.sqrt(np.einsum("...x,...x->...", vectors, vectors))[..., None]
    return vectors / np.where(length > 0, length, 1.0)


def _angle(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """(...,) the angle between unit vectors (..., 3), accurate near 0 and pi (from half the
    chord, not the dot product's arc cosine)."""
    dot = np.einsum("...x,...x->...", u, v)
    chord = np.where((dot < 0)[..., None], u + v, v - u)
    half = np.arcsin(np.minimum(np.sqrt(np.einsum("...x,...x->...", chord, chord)) / 2, 1.0))
    return np.where(dot < 0, np.pi - 2 * half, 2 * half)
