"""split_direct: the light straight from the lights, the sky and the emitters, apart from the rest
(reconstruct.corners.direct_and_indirect). A floor alone under a sun has no other light: all of it
is direct. Under a small emitting square (nothing else but the floor), the direct light at a
floor corner is E F(corner -> square), F by the closed form of a point and a parallel rectangle
(B-3); the two parts add up to the bake's colours."""

import numpy as np
import pytest

from core import Scene, SunLight, bake
from core.reconstruct.corners import direct_and_indirect
from tests.core.scenes import grid, merge, quad
from tests.core.test_form_factor_closed_forms import b3_anywhere


def test_a_floor_under_the_sun_has_only_direct_light():
    vertices, triangles = grid([0, 0, 0], [2, 0, 0], [0, 2, 0], 2)
    count = len(triangles)
    scene = Scene(vertices, triangles, np.full((count, 3), 0.5), np.zeros((count, 3)),
                  lights=[SunLight([0.2, 0.1, -1], [2.0] * 3)])
    result = bake(scene, split_direct=True)
    direct, indirect = direct_and_indirect(scene, result.corner_lighting, result.corner_direct, lighting_only=False)
    np.testing.assert_allclose(direct, result.corner_colors, rtol=1e-12)
    np.testing.assert_allclose(indirect, 0.0, atol=1e-12)


@pytest.mark.parametrize("lighting_only", [False, True])
def test_the_direct_light_of_an_emitter_is_its_form_factor_times_its_emission(lighting_only):
    floor = grid([-1, -1, 0], [2, 0, 0], [0, 2, 0], 2)
    emitter = quad([-0.25, -0.25, 1.0], [0, 0.5, 0], [0.5, 0, 0])  # faces down
    vertices, triangles = merge(floor, emitter)
    count = len(triangles)
    reflectance, emission = np.full((count, 3), 0.6), np.zeros((count, 3))
    reflectance[-2:], emission[-2:] = 0.0, 10.0
    scene = Scene(vertices, triangles, reflectance, emission)
    result = bake(scene, split_direct=True, rays_per_form_factor=64)
    direct, indirect = direct_and_indirect(scene, result.corner_lighting, result.corner_direct, lighting_only)
    total = result.corner_lighting if lighting_only else result.corner_colors
    np.testing.assert_allclose(direct + indirect, total, rtol=1e-12, atol=1e-15)
    assert (indirect >= 0).all()
    corners = vertices[triangles[:-2]]  # (T, 3, 3) of the floor
    factor = b3_anywhere(corners[..., 0], corners[..., 1], -0.25, 0.25, -0.25, 0.25, 1.0)
    expected = 10.0 * factor * (1.0 if lighting_only else 0.6)
    np.testing.assert_allclose(direct[:-2, :, 0], expected, rtol=0.02)
