"""See-through surfaces (``Scene.opacity``): the light that reaches a point through surfaces of
opacity a_i is prod (1 - a_i) of what would reach it unblocked.

Independent truths: a sun straight down gives E / pi on a floor, and (1 - a) E / pi where it
shines through a plate of opacity a (two plates: the product); a square emitter seen wholly through
a plate gives (1 - a) F E with F the exact point-to-square form factor; a final gather through a
plate that fills the view reads B_plate + (1 - a) B_behind (Monte Carlo: within four standard
errors).
"""

from __future__ import annotations

import numpy as np
import pytest

from core import Scene, SunLight, bake
from core.mesh.discretize import discretize
from core.rays.visibility import Visibility
from core.solve.gather import gather
from core.transport.analytic import point_to_triangle

from scenes import box, grid, merge, quad

FLOOR_CELLS = 8


def floor_under_plates(opacities, emitter: bool = False) -> Scene:
    """A 2 x 2 floor (8 x 8 cells) at z = 0; plates of the given opacities at z = 0.5, 0.6, ...
    over its middle (x, y in 0.5..1.5), facing down; with ``emitter`` a 0.5 x 0.5 emitting square
    at z = 2 over the middle facing down, else a sun straight down."""
    parts = [grid([0, 0, 0], [2, 0, 0], [0, 2, 0], FLOOR_CELLS)]
    for level in range(len(opacities)):
        parts.append(quad([0.5, 0.5, 0.5 + 0.1 * level], [0, 1, 0], [1, 0, 0]))
    if emitter:
        parts.append(quad([0.75, 0.75, 2.0], [0, 0.5, 0], [0.5, 0, 0]))
    vertices, triangles = merge(*parts)
    count = len(triangles)
    floor = 2 * FLOOR_CELLS**2
    opacity = np.ones(count)
    for level, value in enumerate(opacities):
        opacity[floor + 2 * level: floor + 2 * level + 2] = value
    reflectance = np.zeros((count, 3))
    emission = np.zeros((count, 3))
    if emitter:
        emission[-2:] = 10.0
    lights = () if emitter else (SunLight([0, 0, -1], [3.0, 3.0, 3.0]),)
    return Scene(vertices, triangles, reflectance, emission, lights=lights, opacity=opacity)


def floor_lighting(scene: Scene, **knobs) -> tuple[np.ndarray, np.ndarray]:
    """Each floor corner's position (k, 3) and the light arriving there (k,)."""
    result = bake(scene, patch_size=0.25, near_field=False, **knobs)
    floor = 2 * FLOOR_CELLS**2
    positions = scene.vertices[scene.triangles[:floor]].reshape(-1, 3)
    return positions, result.corner_lighting[:floor, :, 0].reshape(-1)


def inside(positions: np.ndarray, low: float, high: float) -> np.ndarray:
    return ((positions[:, :2] > low) & (positions[:, :2] < high)).all(axis=1)


@pytest.mark.parametrize("opacities", [(0.5,), (0.3, 0.6), (1.0,), (0.0,)])
def test_a_sun_through_plates_lights_the_floor_by_their_transmittance(opacities):
    positions, lighting = floor_lighting(floor_under_plates(opacities))
    open_sky = 3.0 / np.pi
    under = inside(positions, 0.6, 1.4)
    beside = ~inside(positions, 0.4, 1.6)
    assert under.sum() >= 9 and beside.sum() >= 9
    np.testing.assert_allclose(lighting[beside], open_sky, rtol=1e-9)
    np.testing.assert_allclose(lighting[under], open_sky * np.prod(1 - np.array(opacities)), rtol=1e-9, atol=1e-12)


def test_an_emitter_seen_through_a_plate_gives_its_form_factor_times_the_transmittance():
    """Every ray from the floor's middle to the emitter crosses the plate (both 1 x 1 or smaller,
    the plate between): F (1 - a) E exactly, F from the closed form."""
    scene = floor_under_plates((0.4,), emitter=True)
    positions, lighting = floor_lighting(scene, split_direct=True)
    under = inside(positions, 0.9, 1.1)  # the floor's centre: the plate hides the whole emitter
    corners = scene.vertices[scene.triangles[-2:]]
    factors = sum(point_to_triangle(positions[under], np.tile([0.0, 0, 1], (under.sum(), 1)),
                                    np.repeat(triangle[None], under.sum(), axis=0)) for triangle in corners)
    assert under.sum() >= 1
    np.testing.assert_allclose(lighting[under], 0.6 * 10.0 * factors, rtol=2e-3)


def test_a_final_gather_through_a_see_through_plate_reads_it_and_what_lies_behind():
    """A point on the floor of a closed 2 x 2 x 2 box of value 1, under a plate of value 0.2 and
    opacity 0.5 across the box 1 above: the rays steeper than 45 degrees (half of a cosine-weighted
    hemisphere) meet the plate, and each stops there with the chance 0.5 and reads 0.2 / 0.5, or
    goes on to the box behind it; the others meet the walls below the plate."""
    walls_vertices, walls_triangles = box(2.0)
    plate = quad([0.0, 0.0, 1.0], [0, 2, 0], [2, 0, 0])  # z = 1 across the box, facing down
    vertices, triangles = merge((walls_vertices, walls_triangles), plate)
    count = len(triangles)
    opacity = np.ones(count)
    opacity[-2:] = 0.5
    scene = Scene(vertices, triangles, np.zeros((count, 3)), np.zeros((count, 3)), opacity=opacity)
    mesh = discretize(scene)
    front = mesh.front_patch_count
    visibility = Visibility(mesh.patch_corners[:front], two_sided=mesh.back_of_front >= 0,
                            owners=mesh.patch_triangle[:front], casting=mesh.front_casts, opacity=mesh.front_opacity)
    values = np.where((mesh.patch_opacity < 1)[:, None], 0.2, 1.0)
    point, normal = np.array([[1.0, 1.0, 0.0]]), np.array([[0.0, 0.0, 1.0]])
    found = gather(mesh, visibility, point, normal, values, 4096, seed=5)
    expected = 0.5 * 1.0 + 0.5 * (0.2 + 0.5 * 1.0)
    assert abs(found.light[0, 0] - expected) <= 4 * found.standard_error[0, 0]
    assert found.standard_error[0, 0] < 0.01


def test_monte_carlo_and_shooting_agree_through_a_plate():
    """The particles and the final gather pass the plate by chance, the shots by its
    transmittance: the same light under it, within the Monte Carlo bake's noise."""
    scene = floor_under_plates((0.5,), emitter=True)
    reflectance = np.where(scene.opacity[:, None] < 1, 0.3, np.full((1, 3), 0.5))  # the plate reflects 0.3 <= 0.5
    scene = Scene(scene.vertices, scene.triangles, reflectance, scene.emission, opacity=scene.opacity)
    shot = bake(scene, patch_size=0.25, near_field=False, tolerance=1e-6)
    traced = bake(scene, patch_size=0.25, near_field=False, monte_carlo_rays=1024, max_shots=1)
    floor = 2 * FLOOR_CELLS**2
    difference = traced.corner_lighting[:floor] - shot.corner_lighting[:floor]
    assert np.sqrt((difference**2).mean()) <= 0.03 * shot.corner_lighting[:floor].mean()


def test_reflectance_above_the_opacity_is_refused():
    with pytest.raises(ValueError, match="above its opacity"):
        Scene(np.eye(3), [[0, 1, 2]], [[0.6, 0.6, 0.6]], [[0, 0, 0]], opacity=[0.5])
