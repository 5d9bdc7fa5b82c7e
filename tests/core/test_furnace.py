"""Furnace: a closed box whose surfaces all have reflectance rho and emission E. Every point
sees only the box, so B = E + rho B everywhere: B = E / (1 - rho) exactly."""

import numpy as np
import pytest

from core import Scene, bake
from tests.core.scenes import box, uniform

REFLECTANCES = [0.0, 0.5, 0.9, 0.99, 0.999]
EMISSION = 2.0
# One patch per triangle keeps progressive refinement at rho = 0.999 (about 7,000 sweeps of the
# 12 patches) to a couple of seconds.
ONE_PATCH_PER_TRIANGLE = 10.0
# The solvers stop when their error estimate is below this; it is 1/10 of the 0.1 % the issue
# demands at rho = 0.999, so passing shows the estimate is honest, not merely the tolerance.
TOLERANCE = 1e-4


@pytest.mark.parametrize("reflectance", REFLECTANCES)
@pytest.mark.parametrize(
    "method, solver",
    [("raycast", "progressive"), ("raycast", "jacobi"), ("raycast", "gauss_seidel"),
     ("hemicube", "jacobi"), ("hemicube", "gauss_seidel")],
)
def test_furnace_bakes_to_emission_over_one_minus_reflectance(method, solver, reflectance):
    """Ray casting's analytic form factors and the hemicube's exact pixel factors both sum to 1
    over a closed box, so only the solver's stopping error remains: within 0.1 %."""
    scene = uniform(*box(), reflectance, EMISSION)
    result = bake(scene, method, solver, patch_size=ONE_PATCH_PER_TRIANGLE, tolerance=TOLERANCE,
                  ambient=False, hemicube_resolution=32)
    expected = EMISSION / (1 - reflectance)
    np.testing.assert_allclose(result.corner_colors, expected, rtol=1e-3)
    np.testing.assert_allclose(result.triangle_radiosity, expected, rtol=1e-3)


def box_areas():
    vertices, triangles = box()
    corners = vertices[triangles]
    return 0.5 * np.linalg.norm(np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]), axis=1)


@pytest.mark.parametrize("reflectance", [0.5, 0.9])
def test_progressive_hemicube_conserves_energy_in_the_furnace(reflectance):
    """Progressive refinement with hemicubes shoots through reciprocity, F_pq = A_q F_qp / A_p
    (Cohen et al. 1988): each shot hands on exactly rho times its power, so the area-weighted
    mean is exact to the stopping tolerance. Single patches carry the error of the form factor
    measured at the shooter's centre instead of the receiver's; at a room's corners that error
    does not shrink with the patch size (the geometry there is self-similar). Measured at
    rho = 0.9 over patch sizes 1/2 to 1/8 and resolutions 32 to 128: 6.3-8.5 % at corner
    vertices, 0.03-0.9 % in triangle means. Hence 10 % and 1 %."""
    scene = uniform(*box(), reflectance, EMISSION)
    result = bake(scene, "hemicube", "progressive", patch_size=0.5, tolerance=TOLERANCE, ambient=False)
    expected = EMISSION / (1 - reflectance)
    mean = np.average(result.triangle_radiosity, axis=0, weights=box_areas())
    np.testing.assert_allclose(mean, expected, rtol=TOLERANCE * 2)
    np.testing.assert_allclose(result.triangle_radiosity, expected, rtol=0.01)
    np.testing.assert_allclose(result.corner_colors, expected, rtol=0.10)


def test_the_ambient_term_completes_the_unshot_light_in_the_furnace():
    """The ambient estimate adds rho * (sum A U / sum A) / (1 - rho): before any shot the
    unshot light is uniform, so every value is exact; after some shots the total energy still
    is (each unit of unshot power is worth rho / (1 - rho) more in a uniform closed scene), and
    every value is closer than without the term."""
    scene = uniform(*box(), 0.9, EMISSION)
    expected = EMISSION / 0.1
    unshot = bake(scene, patch_size=ONE_PATCH_PER_TRIANGLE, max_shots=0)
    np.testing.assert_allclose(unshot.corner_colors, expected, rtol=1e-12)
    with_ambient = bake(scene, patch_size=ONE_PATCH_PER_TRIANGLE, max_shots=3)
    without = bake(scene, patch_size=ONE_PATCH_PER_TRIANGLE, max_shots=3, ambient=False)
    assert with_ambient.stats["shots"] == 3 and not with_ambient.stats["converged"]
    mean = np.average(with_ambient.triangle_radiosity, axis=0, weights=box_areas())
    np.testing.assert_allclose(mean, expected, rtol=1e-12)
    error_with = np.abs(with_ambient.corner_colors - expected).max()
    error_without = np.abs(without.corner_colors - expected).max()
    assert error_with < 0.1 * error_without


@pytest.mark.parametrize("reflectance", [0.9, 0.99])
def test_the_ambient_term_stays_positive_and_close_after_one_shot_of_finer_patches(reflectance):
    """One emitting triangle in a box of finer patches, stopped after one shot: the ambient term
    stands for nearly all the light. The share of shot light that lands on patches is measured
    (1 in a closed box), so the result is positive and near the exact area mean
    E A_emitter / (A (1 - rho)); ray-cast columns, sampled at receiver centroids, are not
    exactly reciprocal, so the one shot hands on its power within a few per mille (measured
    0.08 % at rho = 0.9 and 0.99), hence 1 %."""
    vertices, triangles = box()
    scene = uniform(vertices, triangles, reflectance, 0.0)
    emission = np.zeros((len(triangles), 3))
    emission[0] = 1.0
    scene = Scene(vertices, triangles, scene.reflectance, emission)
    result = bake(scene, patch_size=0.3, max_shots=1)
    exact_mean = box_areas()[0] / box_areas().sum() / (1 - reflectance)
    assert result.stats["captured_fraction"] == 1.0
    assert (result.corner_colors > 0).all()
    mean = np.average(result.triangle_radiosity[:, 0], weights=box_areas())  # closed box: sum A B = sum A E / (1 - rho)
    np.testing.assert_allclose(mean, exact_mean, rtol=0.01)
