"""The light a block's bottom corner gathers from the floor it stands on, where the block's own
shadow starts at that corner (core/touching.py), against a quadrature of the exact answer.

A black block [0, A]^3 stands on a grey floor of reflectance RHO; a point light of power P hangs
at LIGHT, in front of the block's face y = 0 and to the left of its face x = A. The face x = A
looks away from the light; the node at its bottom corner (A, 0, 0) sees only the floor in front
of it (x > A), lit by the light except in the block's shadow, whose edge leaves that very corner
(the line from the light's foot through it). The node at the face's other bottom corner
(A, A, 0) sits in the shadow, the lit side beyond the edge that leaves that corner. Nothing
else reflects (the block is black, the scene open), so a node's light is exactly one bounce
off the floor:

    G(p) = RHO int_{x > A} cos_p cos_x / (pi r^2) G_floor(x) dA,
    G_floor(x) = P cos / (4 pi^2 d^2) (0 in the shadow),

at the node's point p (where core.mesh.discretize evaluates it). The integral is taken in polar
coordinates about p's foot on the floor, with radii spaced logarithmically from far below p's
height (micrometres) to the floor's edge, and the shadow tested exactly against the block.
"""

import numpy as np
import pytest

from core import Scene, bake
from core.reconstruct import nearfield, touching
from core.mesh.discretize import discretize
from core.scene.lights import PointLight
from core.transport.formfactors import FormFactorEngine
from tests.core.scenes import grid, merge, quad

A, HALF_FLOOR, RHO = 0.5, 3.0, 0.8
LIGHT = np.array([-1.0, -0.6, 2.0])
POWER = 40.0


def block_on_floor() -> Scene:
    a = A
    vertices, triangles = merge(
        quad([-HALF_FLOOR, -HALF_FLOOR, 0], [2 * HALF_FLOOR, 0, 0], [0, 2 * HALF_FLOOR, 0]),  # floor, up
        quad([a, 0, 0], [0, a, 0], [0, 0, a]),  # x = A, faces +x
        quad([0, 0, 0], [0, 0, a], [0, a, 0]),  # x = 0, faces -x
        quad([0, 0, 0], [a, 0, 0], [0, 0, a]),  # y = 0, faces -y
        quad([0, a, 0], [0, 0, a], [a, 0, 0]),  # y = A, faces +y
        quad([0, 0, a], [a, 0, 0], [0, a, 0]),  # top, faces +z
    )
    reflectance = np.zeros((len(triangles), 3))
    reflectance[:2] = RHO
    return Scene(vertices, triangles, reflectance, np.zeros((len(triangles), 3)),
                 lights=(PointLight(LIGHT, np.full(3, POWER)),))


def in_shadow(points: np.ndarray) -> np.ndarray:
    """Whether the segment from each floor point (n, 3) to the light crosses the block (slabs)."""
    direction = LIGHT - points
    with np.errstate(divide="ignore", invalid="ignore"):
        low = (0.0 - points) / direction
        high = (A - points) / direction
    near = np.nanmax(np.minimum(low, high), axis=1)
    far = np.nanmin(np.maximum(low, high), axis=1)
    return (near <= far) & (far > 1e-12) & (near < 1.0)


def exact_lighting(point: np.ndarray, angles: int = 4000, radii: int = 600) -> float:
    """G at ``point`` (on the plane x = A, facing +x, just above the floor) from the floor."""
    height = point[2]
    phi = -np.pi / 2 + (np.arange(angles) + 0.5) * np.pi / angles  # off +x, towards +y
    cos_phi, sin_phi = np.cos(phi), np.sin(phi)
    # distance from the foot to the floor's edge along each direction (x > A side only)
    to_x = (HALF_FLOOR - point[0]) / cos_phi
    to_y = np.where(sin_phi > 0, HALF_FLOOR - point[1], -HALF_FLOOR - point[1]) / np.where(sin_phi == 0, 1, sin_phi)
    reach = np.minimum(to_x, np.where(sin_phi == 0, np.inf, to_y))
    total = 0.0
    for cos_a, sin_a, end in zip(cos_phi, sin_phi, reach):
        u = np.linspace(np.log(1e-4 * height), np.log(end), radii + 1)
        rho = np.exp((u[1:] + u[:-1]) / 2)
        step = np.diff(np.exp(u))
        floor = np.stack([point[0] + rho * cos_a, point[1] + rho * sin_a, np.zeros_like(rho)], axis=1)
        r2 = rho * rho + height * height
        kernel = (rho * cos_a) * height / (np.pi * r2 * r2)  # cos_p cos_x / (pi r^2), both times r
        offset = LIGHT - floor
        d2 = (offset ** 2).sum(axis=1)
        light = POWER * offset[:, 2] / np.sqrt(d2) / (4 * np.pi ** 2 * d2) * ~in_shadow(floor)
        total += np.sum(kernel * light * rho * step) * np.pi / angles
    return RHO * total


def corner_of_face(scene: Scene, position) -> tuple[int, int]:
    """(triangle, corner) of face x = A (triangles 2 and 3) at ``position``."""
    face = np.arange(2, 4)
    at = np.argwhere(np.linalg.norm(scene.vertices[scene.triangles[face]] - position, axis=2) < 1e-12)
    return int(face[at[0, 0]]), int(at[0, 1])


@pytest.fixture(scope="module")
def corners():
    """The scene, and for the bottom corners of face x = A at y = 0 (where the lit side of the
    shadow's edge is in view) and at y = A (in the shadow, the lit side beyond its edge): the
    (triangle, corner) and the exact light where the node is evaluated."""
    scene = block_on_floor()
    mesh = discretize(scene)
    found = []
    for position in ([A, 0, 0], [A, A, 0]):
        triangle, which = corner_of_face(scene, position)
        found.append((triangle, which, exact_lighting(mesh.node_points[mesh.corner_node[triangle, which]])))
    return scene, found


def test_the_corner_where_the_shadow_starts_reads_the_floor_it_sees(corners):
    """Measured: lit side 1.8 % over the exact 0.0195, shadowed side 0.00017 for the exact 0.00001
    (0.9 % of the lit side's light). Without the polar reading: 138 % and 3.5 %."""
    scene, ((lit, lit_corner, lit_exact), (dark, dark_corner, dark_exact)) = corners
    lighting = bake(scene).corner_lighting
    assert abs(lighting[lit, lit_corner, 0] / lit_exact - 1) < 0.03
    assert abs(lighting[dark, dark_corner, 0] - dark_exact) < 0.02 * lit_exact


def test_without_the_polar_reading_the_corner_is_off(corners, monkeypatch):
    scene, ((lit, lit_corner, lit_exact), _) = corners
    monkeypatch.setattr(touching, "MIN_FORM_FACTOR", np.inf)  # no pair read anew
    assert abs(bake(scene).corner_lighting[lit, lit_corner, 0] / lit_exact - 1) > 0.5


@pytest.mark.parametrize("probed", [touching.MAX_PROBED_PAIRS, 5])
def test_touching_pairs_found_in_two_parts_are_those_found_at_once(probed, monkeypatch):
    """A re-solve adds the near pairs of newly lit patches to those it kept (``touching.joined``):
    their reading points and probed cells must be those ``touching_pairs`` finds for all the pairs
    at once, also when only the ``probed`` largest form factors are probed."""
    monkeypatch.setattr(touching, "MAX_PROBED_PAIRS", probed)
    # a room's corner of 4 x 4 grids, a patch per triangle: every patch corner has an output node
    vertices, triangles = merge(grid([0, 0, 0], [2, 0, 0], [0, 2, 0], 4), grid([0, 0, 0], [0, 0, 1], [2, 0, 0], 4),
                                grid([0, 0, 0], [0, 2, 0], [0, 0, 1], 4))
    scene = Scene(vertices, triangles, np.full((len(triangles), 3), 0.5), np.zeros((len(triangles), 3)))
    mesh = discretize(scene)
    engine = FormFactorEngine(mesh)
    radiosity = np.ones((mesh.patch_count, 3))
    half = np.arange(mesh.patch_count) % 2 == 0
    a, b = (nearfield.near_field(scene, mesh, radiosity, engine.point_form_factors, lit, interpolate=False)
            for lit in (half, ~half))
    at_once = touching.touching_pairs(nearfield.joined(a, b), mesh)
    in_parts = touching.joined(touching.touching_pairs(a, mesh), touching.touching_pairs(b, mesh))
    found = sum(len(block[0]) for block in at_once.probed)
    assert found > 5 if probed > 5 else found == 5
    for name in ("receiver", "patch", "form_factor", "weights", "corner_receiver"):
        np.testing.assert_array_equal(getattr(in_parts.near, name), getattr(at_once.near, name))
    assert len(in_parts.probed) == len(at_once.probed)
    for mine, theirs in zip(in_parts.probed, at_once.probed):
        for part, expected in zip(mine, theirs):
            np.testing.assert_array_equal(part, expected)
