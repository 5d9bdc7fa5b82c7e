"""The path-traced reference (bench/pathtrace.py) against exact answers: the furnace (every
bounce: G = E / (1 - rho)), the contour integral of a square emitter (the direct light alone), a
blocker that hides it, and the back of a two-sided emitter."""

import numpy as np
import pytest

from core import Scene
from core.transport.analytic import point_to_triangle
from core.mesh.discretize import discretize
from bench.pathtrace import path_traced
from core.rays.visibility import Visibility
from tests.core.scenes import box, merge, quad, uniform


def traced(scene: Scene, points, normals, paths: int, patch_size: float = 10.0):
    mesh = discretize(scene, patch_size)
    front = mesh.front_patch_count
    visibility = Visibility(mesh.patch_corners[:front], two_sided=mesh.back_of_front >= 0)
    return path_traced(mesh, visibility, np.asarray(points, float), np.asarray(normals, float), paths, seed=1)


POINTS = np.array([[0.5, 0.5, 0.0], [0.2, 0.7, 0.0], [0.0, 0.3, 0.6], [0.9, 0.9, 1.0]])
NORMALS = np.array([[0, 0, 1.0], [0, 0, 1.0], [1.0, 0, 0], [0, 0, -1.0]])


@pytest.mark.parametrize("reflectance, paths", [(0.5, 20000), (0.9, 20000), (0.995, 4000)])
def test_in_a_furnace_the_light_arriving_is_emission_over_one_minus_reflectance(reflectance, paths):
    """A closed box, every face emitting E = 2 and reflecting rho: the radiosity everywhere, and so
    the light arriving at any point, is E / (1 - rho). Within 4 standard errors (each at most 3 % of
    it), so the paths' bounces, roulette and emitter sampling all count right. At rho = 0.995 a path
    bounces 200 times on average: with at most 256 bounces the paths read 0.72 of the light."""
    found = traced(uniform(*box(), reflectance, 2.0), POINTS, NORMALS, paths, patch_size=0.5)
    expected = 2.0 / (1 - reflectance)
    assert (np.abs(found.light - expected) <= 4 * found.standard_error).all(), (found, expected)
    assert (found.standard_error < 0.03 * expected).all()


def floor_and_light(two_sided: bool = False, blocker: bool = False) -> Scene:
    """A black floor, a unit-square emitter (E = 3) 0.5 above it facing down, and optionally a black
    plate between them that covers the emitter's whole view of the floor's centre."""
    parts = [quad([-2, -2, 0], [4, 0, 0], [0, 4, 0]), quad([-0.5, -0.5, 0.5], [0, 1, 0], [1, 0, 0])]
    if blocker:
        parts.append(quad([-1.5, -1.5, 0.25], [3, 0, 0], [0, 3, 0]))
    vertices, triangles = merge(*parts)
    count = len(triangles)
    emission = np.zeros((count, 3))
    emission[2:4] = 3.0
    return Scene(vertices, triangles, np.zeros((count, 3)), emission,
                 two_sided=np.arange(count) >= 2 if two_sided else None)


def test_the_direct_light_of_a_square_is_its_emission_times_the_form_factor():
    """Nothing reflects: G(x) = E F(x -> square), F by the contour integral; within 4 standard
    errors, each under 1 % of G from 20,000 paths."""
    points = np.array([[0.0, 0.0, 0.0], [0.4, -0.3, 0.0], [1.5, 1.0, 0.0]])
    normals = np.tile([0.0, 0.0, 1.0], (3, 1))
    scene = floor_and_light()
    found = traced(scene, points, normals, 20000)
    square = scene.vertices[scene.triangles[2:4]]
    exact = 3.0 * sum(point_to_triangle(points, normals, np.repeat(square[[k]], 3, axis=0)) for k in range(2))
    assert (np.abs(found.light[:, 0] - exact) <= 4 * found.standard_error[:, 0]).all(), (found, exact)
    assert (found.standard_error[:, 0] < 0.01 * exact).all()


def test_an_emitter_hidden_behind_a_plate_sends_nothing():
    found = traced(floor_and_light(blocker=True), [[0.0, 0.0, 0.0], [0.5, 0.5, 0.0]], [[0, 0, 1.0]] * 2, 2000)
    assert np.all(found.light == 0) and np.all(found.standard_error == 0)


def test_a_two_sided_emitter_shines_from_its_back_too():
    """A point 0.5 above the square, facing it: the back emits only when the emitter is two-sided,
    then as much as the front does below (the same form factor, mirrored)."""
    above, below = [[0.0, 0.0, 1.0]], [[0.0, 0.0, 0.0]]
    one = traced(floor_and_light(), above, [[0, 0, -1.0]], 4000)
    two = traced(floor_and_light(two_sided=True), above, [[0, 0, -1.0]], 20000)
    front = traced(floor_and_light(two_sided=True), below, [[0, 0, 1.0]], 20000)
    assert np.all(one.light == 0)
    spread = np.hypot(two.standard_error[0, 0], front.standard_error[0, 0])
    assert abs(two.light[0, 0] - front.light[0, 0]) <= 4 * spread
    assert two.light[0, 0] > 0.5


SKY = 2.0


def sky_traced(with_square: bool, point, normal):
    """A 4 x 4 floor of reflectance 0.6 at z = 0 under a uniform sky S, and (``with_square``) a black
    unit square 0.5 above its centre facing down: G at ``point`` facing ``normal`` from 20,000
    paths, and the corners of the triangles."""
    parts = [quad([-2, -2, 0], [4, 0, 0], [0, 4, 0])]
    if with_square:
        parts.append(quad([-0.5, -0.5, 0.5], [0, 1, 0], [1, 0, 0]))
    vertices, triangles = merge(*parts)
    reflectance = np.zeros((len(triangles), 3))
    reflectance[:2] = 0.6
    scene = Scene(vertices, triangles, reflectance, np.zeros((len(triangles), 3)), sky=np.full(3, SKY))
    mesh = discretize(scene, 10.0)
    front = mesh.front_patch_count
    visibility = Visibility(mesh.patch_corners[:front], two_sided=mesh.back_of_front >= 0)
    found = path_traced(mesh, visibility, np.array([point], float), np.array([normal], float), 20000, seed=1,
                        sky=scene.sky)
    return found, vertices[triangles]


def form_factor(point, normal, triangles) -> float:
    """F from ``point`` facing ``normal`` to the union of ``triangles`` (k, 3, 3), by the contour integral."""
    return float(sum(point_to_triangle(np.array([point], float), np.array([normal], float), triangle[None])[0]
                     for triangle in triangles))


def test_a_uniform_sky_arrives_where_a_bounce_leaves_the_scene():
    """Under a uniform sky S: a point on the floor facing up sees the sky but for the black square,
    G = S (1 - F(x -> square)); a point 0.3 above the floor alone, facing down, sees the floor,
    whose radiosity is rho S everywhere (its points see only the sky), and the sky around it,
    G = rho S F(x -> floor) + S (1 - F(x -> floor)). Within 4 standard errors, each under 1 % of G
    from 20,000 paths."""
    cases = [(True, [0.1, -0.2, 0.0], [0.0, 0.0, 1.0], lambda f: SKY * (1 - f), slice(2, 4)),
             (False, [1.0, 0.5, 0.3], [0.0, 0.0, -1.0], lambda f: SKY * (1 - 0.4 * f), slice(0, 2))]
    for with_square, point, normal, expected, seen in cases:
        found, corners = sky_traced(with_square, point, normal)
        exact = expected(form_factor(point, normal, corners[seen]))
        assert abs(found.light[0, 0] - exact) <= 4 * found.standard_error[0, 0], (found, exact)
        assert found.standard_error[0, 0] < 0.01 * exact
        assert exact < 0.9 * SKY  # the square and the floor each take their part
