"""Small scenes built in code for the core tests."""

from __future__ import annotations

import numpy as np

from core import Scene


def quad(corner, u, v) -> tuple[np.ndarray, np.ndarray]:
    """Vertices (4, 3) and triangles (2, 3) of the parallelogram corner + [0,1] u + [0,1] v,
    facing u x v (counter-clockwise seen from the front)."""
    corner, u, v = (np.asarray(a, dtype=float) for a in (corner, u, v))
    vertices = np.array([corner, corner + u, corner + u + v, corner + v])
    return vertices, np.array([[0, 1, 2], [0, 2, 3]])


def merge(*parts) -> tuple[np.ndarray, np.ndarray]:
    """Concatenate (vertices, triangles) pairs into one mesh."""
    vertices, triangles, offset = [], [], 0
    for part_vertices, part_triangles in parts:
        vertices.append(part_vertices)
        triangles.append(part_triangles + offset)
        offset += len(part_vertices)
    return np.concatenate(vertices), np.concatenate(triangles)


def box(size: float = 1.0) -> tuple[np.ndarray, np.ndarray]:
    """A closed cube [0, size]^3 of 12 triangles facing inwards."""
    s = size
    return merge(
        quad([0, 0, 0], [s, 0, 0], [0, s, 0]),  # floor z=0, faces +z
        quad([0, 0, s], [0, s, 0], [s, 0, 0]),  # ceiling, faces -z
        quad([0, 0, 0], [0, s, 0], [0, 0, s]),  # x=0, faces +x
        quad([s, 0, 0], [0, 0, s], [0, s, 0]),  # x=s, faces -x
        quad([0, 0, 0], [0, 0, s], [s, 0, 0]),  # y=0, faces +y
        quad([0, s, 0], [s, 0, 0], [0, 0, s]),  # y=s, faces -y
    )


def uniform(vertices, triangles, reflectance, emission) -> Scene:
    """Scene with the same grey reflectance and emission on every triangle."""
    count = len(triangles)
    return Scene(vertices, triangles, np.full((count, 3), reflectance), np.full((count, 3), emission))


def lit_room(size: float = 1.0) -> Scene:
    """An open-topped, coloured room: floor, three walls, a block and a downward emitter above."""
    s = size
    floor = quad([0, 0, 0], [s, 0, 0], [0, s, 0])  # faces +z
    wall_x = quad([0, 0, 0], [0, s, 0], [0, 0, s])  # faces +x
    wall_y = quad([0, 0, 0], [0, 0, s], [s, 0, 0])  # faces +y
    wall_far = quad([s, 0, 0], [0, 0, s], [0, s, 0])  # faces -x
    block = quad([0.3 * s, 0.3 * s, 0.3 * s], [0, 0.3 * s, 0], [0.3 * s, 0, 0])  # a floating plate: faces -z
    block_top = quad([0.3 * s, 0.3 * s, 0.3 * s], [0.3 * s, 0, 0], [0, 0.3 * s, 0])  # and +z
    light = quad([0.35 * s, 0.35 * s, 0.95 * s], [0, 0.3 * s, 0], [0.3 * s, 0, 0])  # faces -z
    vertices, triangles = merge(floor, wall_x, wall_y, wall_far, block, block_top, light)
    reflectance = np.array(
        [[0.7, 0.7, 0.7]] * 2 + [[0.6, 0.1, 0.1]] * 2 + [[0.1, 0.6, 0.1]] * 2 + [[0.5, 0.5, 0.8]] * 2
        + [[0.8, 0.8, 0.8]] * 4 + [[0.0, 0.0, 0.0]] * 2
    )
    emission = np.zeros_like(reflectance)
    emission[-2:] = [10.0, 8.0, 6.0]
    return Scene(vertices, triangles, reflectance, emission)


def tetrahedron() -> tuple[np.ndarray, np.ndarray]:
    """A regular tetrahedron (edge 2 sqrt 2, centred on the origin) of 4 triangles facing
    inwards. By symmetry the exact form factor from the centroid of a face to each other face
    is 1/3 (the three fill its hemisphere equally)."""
    vertices = np.array([[1, 1, 1], [1, -1, -1], [-1, 1, -1], [-1, -1, 1]], dtype=float)
    triangles = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])  # counter-clockwise seen from inside
    return vertices, triangles


def grid(corner, u, v, cells: int) -> tuple[np.ndarray, np.ndarray]:
    """Vertices and triangles of the parallelogram corner + [0,1] u + [0,1] v split into
    cells x cells quads of two triangles each, facing u x v."""
    corner, u, v = (np.asarray(a, dtype=float) for a in (corner, u, v))
    steps = np.linspace(0.0, 1.0, cells + 1)
    s, t = (a.reshape(-1, 1) for a in np.meshgrid(steps, steps, indexing="ij"))
    vertices = corner + s * u + t * v
    i, j = (a.ravel() for a in np.meshgrid(np.arange(cells), np.arange(cells), indexing="ij"))
    a, b = i * (cells + 1) + j, (i + 1) * (cells + 1) + j  # (s, t) and (s + 1, t)
    return vertices, np.concatenate([np.stack([a, b, b + 1], 1), np.stack([a, b + 1, a + 1], 1)])
