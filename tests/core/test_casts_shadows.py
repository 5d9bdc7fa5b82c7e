"""Scene.casts_shadows: a surface that casts no shadow hides nothing (light reaches what is behind
it) but still receives, reflects and emits, as Cycles' Shadow ray visibility off. A floor under a
straight-down sun of irradiance E with a plate above it: the plate's lit top reflects upwards and
its unlit underside sends nothing down, so the floor is exactly rho E / pi under a plate that casts
no shadow (and in its shadow under one that does), while the plate's top is rho E / pi either way."""

import numpy as np
import pytest

from core import Scene, SunLight, bake
from tests.core.scenes import merge, quad

E, RHO = 2.0, 0.5


def floor_and_plate(plate_casts: bool) -> tuple[Scene, slice, slice]:
    floor = quad([0, 0, 0], [4, 0, 0], [0, 4, 0])                 # faces +z
    plate = quad([1, 1, 1], [2, 0, 0], [0, 2, 0])                 # faces +z, one-sided
    vertices, triangles = merge(floor, plate)
    casts = np.array([True, True, plate_casts, plate_casts])
    scene = Scene(vertices, triangles, np.full((4, 3), RHO), np.zeros((4, 3)),
                  lights=[SunLight([0, 0, -1], [E, E, E])], casts_shadows=casts)
    return scene, slice(0, 2), slice(2, 4)


@pytest.mark.parametrize("solver, monte_carlo", [("progressive", 0), ("progressive", 64), ("gauss_seidel", 0)])
def test_a_plate_that_casts_no_shadow_lets_the_sun_reach_the_floor(solver, monte_carlo):
    lit = RHO * E / np.pi
    for casts in (False, True):
        scene, floor, plate = floor_and_plate(casts)
        colours = bake(scene, solver=solver, monte_carlo_rays=monte_carlo, patch_size=0.25).corner_colors
        under = colours[floor][:, :, 0]  # the floor's four corners are outside the plate's shadow...
        assert np.allclose(under, lit, rtol=1e-3)
        assert np.allclose(colours[plate], lit, rtol=1e-3)  # the plate is lit either way
    shadowed = bake(floor_and_plate(True)[0], solver=solver, monte_carlo_rays=monte_carlo, patch_size=0.25)
    free = bake(floor_and_plate(False)[0], solver=solver, monte_carlo_rays=monte_carlo, patch_size=0.25)
    # ...but the floor's patches under the plate are dark with its shadow and lit without it
    assert shadowed.triangle_radiosity[floor].mean() < 0.8 * lit
    assert np.allclose(free.triangle_radiosity[floor], lit, rtol=1e-3)


def test_casts_shadows_must_be_one_bool_per_triangle():
    scene, _, _ = floor_and_plate(True)
    with pytest.raises(ValueError, match=r"casts_shadows must be a bool array of shape \(4,\)"):
        Scene(scene.vertices, scene.triangles, scene.reflectance, scene.emission, casts_shadows=np.ones(3, bool))
