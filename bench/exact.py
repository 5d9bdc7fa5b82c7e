"""Scenes whose baked corner values are known exactly, for the trade-off sweep (the tradeoffs study).

- ``furnace``: a closed cube whose faces all reflect rho and emit E. Every point sees only the
  cube, so B = E + rho B: B = E / (1 - rho) at every corner.
- ``parallel_squares``: a black, emitting unit square 1 above a parallel, grey, gridded unit
  square, nothing else (the rest is black sky). The receiver is flat, so it never sees itself,
  and the emitter reflects nothing: one bounce, B(x) = rho E F(x -> emitter) at each receiver
  corner x (the configuration of Howell's catalogue, B-3 by superposition, and of C-11 for the
  whole square).
- ``cie_room``: a black 4 m cube with a 1 m x 1 m Lambertian source of radiance L centred in its
  ceiling, in the manner of the analytic test cases of CIE 171:2006 ("Test cases to assess the
  accuracy of lighting computer programs"), whose test room is a 4 m x 4 m x 4 m cube (Ashdown,
  "CIE 171:2006 errata", lightinganalysts.com, on test case 5.8) and which check the direct
  illuminance from area sources against form factors. The report's own luminaire sizes and
  measuring points were not at hand, so this is CIE-style, not the test case itself. With black
  walls the light at a point x is direct only: G(x) = E_v(x) / pi = L F(x -> source), compared as
  ``BakeResult.corner_lighting`` (corner colours are all 0). With reflecting walls there is no
  closed form, so only the black room serves as analytic truth.

F(x -> polygon) is the exact unoccluded point-to-polygon form factor (Lambert's contour
integral), summed over the polygon's triangles by ``core.transport.analytic.point_to_triangle``; the core's
tests check it against Howell's catalogue (B-3, B-12) to 1e-12. The truth is evaluated at the
triangle corners themselves; the core evaluates a corner a little way towards its face's centre
(core.mesh.nodes.NODE_INSET of the scene's extent), which these smooth fields hardly notice.

Each scene is turned by one rigid motion (TURN), as the core's closed-form tests do: seen from an
axis-aligned hemicube, an axis-aligned square whose edges project onto pixel edges is integrated
exactly, which real scenes do not enjoy. A rigid motion leaves every exact value unchanged.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from core import Scene
from core.transport.analytic import point_to_triangle

FURNACE_REFLECTANCE = 0.8
FURNACE_EMISSION = 1.0
SQUARES_REFLECTANCE = 0.5
SQUARES_GRID = 4  # the receiver is 4 x 4 quads, so its 25 corners sample the field
ROOM_SIZE = 4.0  # m
ROOM_GRID = 4  # floor and walls are 4 x 4 quads of 1 m
SOURCE_EDGES = (0.0, 1.5, 2.5, 4.0)  # the ceiling's 3 x 3 grid; its centre cell is the 1 m source
RADIANCE = 1.0
_AXIS = np.array([1.0, 2.0, 3.0]) / np.sqrt(14.0)
_CROSS = np.cross(np.eye(3), _AXIS)
TURN = np.eye(3) + np.sin(0.7) * _CROSS + (1 - np.cos(0.7)) * _CROSS @ _CROSS  # 0.7 rad about (1, 2, 3)


class Exact(NamedTuple):
    """A scene and the exact value at each corner of each triangle of one BakeResult array.

    quantity : "corner_colors" (radiosity B) or "corner_lighting" (G = irradiance / pi).
    truth : (T, 3, 3) exact RGB value at each corner.
    compared : (T,) bool, the triangles whose corners the error is measured over.
    """

    scene: Scene
    quantity: str
    truth: np.ndarray
    compared: np.ndarray


def quad_grid(corner, u, v, cells: int) -> tuple[np.ndarray, np.ndarray]:
    """Vertices and triangles of the parallelogram corner + [0,1] u + [0,1] v split into
    cells x cells quads of two triangles, facing u x v."""
    corner, u, v = (np.asarray(a, dtype=float) for a in (corner, u, v))
    steps = np.linspace(0.0, 1.0, cells + 1)
    s, t = np.meshgrid(steps, steps, indexing="ij")
    vertices = corner + s.reshape(-1, 1) * u + t.reshape(-1, 1) * v
    i, j = (a.ravel() for a in np.meshgrid(np.arange(cells), np.arange(cells), indexing="ij"))
    a, b = i * (cells + 1) + j, (i + 1) * (cells + 1) + j  # (s, t) and (s + 1, t)
    triangles = np.concatenate([np.stack([a, b, b + 1], 1), np.stack([a, b + 1, a + 1], 1)])
    return vertices, triangles


def merge(parts: list[tuple[np.ndarray, np.ndarray]]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Concatenated vertices (turned by TURN) and triangles of ``parts``, and the part each
    triangle came from."""
    offsets = np.cumsum([0] + [len(vertices) for vertices, _ in parts[:-1]])
    vertices = np.concatenate([vertices for vertices, _ in parts]) @ TURN.T
    triangles = np.concatenate([triangles + offset for (_, triangles), offset in zip(parts, offsets)])
    part = np.concatenate([np.full(len(triangles), k) for k, (_, triangles) in enumerate(parts)])
    return vertices, triangles, part


def form_factor_to(points: np.ndarray, normals: np.ndarray, polygon: np.ndarray) -> np.ndarray:
    """(n,) exact unoccluded form factors from points (n, 3) facing normals (n, 3) to the
    union of the triangles ``polygon`` (k, 3, 3)."""
    n, k = len(points), len(polygon)
    return point_to_triangle(np.repeat(points, k, axis=0), np.repeat(normals, k, axis=0),
                             np.tile(polygon, (n, 1, 1))).reshape(n, k).sum(axis=1)


def corner_factors(vertices: np.ndarray, triangles: np.ndarray, polygon: np.ndarray) -> np.ndarray:
    """(T, 3) F(corner -> polygon) at each corner of each triangle, facing the triangle's normal."""
    corners = vertices[triangles]
    normals = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    factors = form_factor_to(corners.reshape(-1, 3), np.repeat(normals, 3, axis=0), polygon)
    return factors.reshape(-1, 3)


def grey(values: np.ndarray) -> np.ndarray:
    """(..., 3) the same value in R, G and B."""
    return np.repeat(np.asarray(values, dtype=float)[..., None], 3, axis=-1)


def furnace() -> Exact:
    """The unit cube, 2 triangles per face facing inwards, all reflecting FURNACE_REFLECTANCE and
    emitting FURNACE_EMISSION: B = E / (1 - rho) at every corner, all corners compared."""
    faces = [quad_grid(corner, u, v, 1) for corner, u, v in _cube_faces(1.0)]
    vertices, triangles, _ = merge(faces)
    count = len(triangles)
    scene = Scene(vertices, triangles, grey(np.full(count, FURNACE_REFLECTANCE)),
                  grey(np.full(count, FURNACE_EMISSION)))
    truth = np.full((count, 3, 3), FURNACE_EMISSION / (1 - FURNACE_REFLECTANCE))
    return Exact(scene, "corner_colors", truth, np.ones(count, dtype=bool))


def parallel_squares() -> Exact:
    """The emitting unit square at z = 1 facing down (E = 1, black) over the receiving unit square
    at z = 0 facing up (rho = SQUARES_REFLECTANCE, SQUARES_GRID x SQUARES_GRID quads):
    B = rho E F(corner -> emitter) at the receiver's corners, which are compared."""
    receiver = quad_grid([0, 0, 0], [1, 0, 0], [0, 1, 0], SQUARES_GRID)
    emitter = quad_grid([0, 0, 1], [0, 1, 0], [1, 0, 0], 1)
    vertices, triangles, part = merge([receiver, emitter])
    lit = part == 0
    scene = Scene(vertices, triangles, grey(np.where(lit, SQUARES_REFLECTANCE, 0.0)), grey(np.where(lit, 0.0, 1.0)))
    factors = corner_factors(vertices, triangles, vertices[triangles[~lit]])
    truth = grey(np.where(lit[:, None], SQUARES_REFLECTANCE * factors, 1.0))
    return Exact(scene, "corner_colors", truth, lit)


def cie_room() -> Exact:
    """The black ROOM_SIZE cube, floor and walls ROOM_GRID x ROOM_GRID quads, the ceiling the 3 x 3
    grid SOURCE_EDGES whose centre cell emits RADIANCE downwards: G = L F(corner -> source) at
    every corner but the source's, which are compared."""
    size = ROOM_SIZE
    floor, _ceiling, *walls = _cube_faces(size)
    parts = [quad_grid(corner, u, v, ROOM_GRID) for corner, u, v in (floor, *walls)]
    edges = np.array(SOURCE_EDGES)
    for i in range(3):
        for j in range(3):  # ceiling cells face down: u = +y, v = +x
            if i == j == 1:
                source_part = len(parts)
            corner = [edges[i], edges[j], size]
            parts.append(quad_grid(corner, [0, edges[j + 1] - edges[j], 0], [edges[i + 1] - edges[i], 0, 0], 1))
    vertices, triangles, part = merge(parts)
    source = part == source_part
    count = len(triangles)
    scene = Scene(vertices, triangles, np.zeros((count, 3)), grey(np.where(source, RADIANCE, 0.0)))
    factors = corner_factors(vertices, triangles, vertices[triangles[source]])
    truth = grey(np.where(source[:, None], 0.0, RADIANCE * factors))
    return Exact(scene, "corner_lighting", truth, ~source)


def _cube_faces(size: float) -> list[tuple[list[float], list[float], list[float]]]:
    """(corner, u, v) of the six faces of the cube [0, size]^3, facing inwards (u x v): floor,
    ceiling, then the walls x = 0, x = size, y = 0, y = size."""
    s = size
    return [
        ([0, 0, 0], [s, 0, 0], [0, s, 0]),
        ([0, 0, s], [0, s, 0], [s, 0, 0]),
        ([0, 0, 0], [0, s, 0], [0, 0, s]),
        ([s, 0, 0], [0, 0, s], [0, s, 0]),
        ([0, 0, 0], [0, 0, s], [s, 0, 0]),
        ([0, s, 0], [s, 0, 0], [0, 0, s]),
    ]


PROBLEMS = {"furnace": furnace, "parallel_squares": parallel_squares, "cie_room": cie_room}

DESCRIPTIONS = {
    "furnace": f"closed unit cube, every face reflecting rho = {FURNACE_REFLECTANCE:g} and emitting "
    f"E = {FURNACE_EMISSION:g}: B = E / (1 - rho) = {FURNACE_EMISSION / (1 - FURNACE_REFLECTANCE):g} at every corner "
    "(all corners compared, since all emit)",
    "parallel_squares": f"black emitting unit square (E = 1) 1 above a parallel unit square of "
    f"rho = {SQUARES_REFLECTANCE:g} split {SQUARES_GRID} x {SQUARES_GRID}, open: B = rho E F(corner -> emitter) "
    "(exact point-to-polygon factor), at the receiver's corners",
    "cie_room": f"CIE 171:2006-style {ROOM_SIZE:g} m black cube, floor and walls split {ROOM_GRID} x {ROOM_GRID}, "
    f"a 1 m x 1 m source of radiance L = {RADIANCE:g} centred in the ceiling: direct light only, "
    "G = E_v / pi = L F(corner -> source), compared as the corners' lighting (corner_lighting)",
}
