"""The hemicube's pixels: directions and exact delta form factors."""

import numpy as np
import pytest

from core.transport import hemicube


@pytest.mark.parametrize("resolution", [2, 8, 64, 250])
def test_delta_form_factors_of_a_full_hemicube_sum_to_one(resolution):
    """Each pixel's factor is the exact integral of the seed's density over the pixel, so the
    five faces tile the hemisphere and the sum is 1 to rounding (about 1e-16 per pixel)."""
    directions, factors = hemicube.pixels(resolution)
    assert len(factors) == 3 * resolution**2
    assert abs(factors.sum() - 1.0) < 1e-12
    assert (factors > 0).all()
    np.testing.assert_allclose(np.linalg.norm(directions, axis=1), 1.0, rtol=1e-15)
    assert (directions[:, 2] > 0).all()


def midpoint_integral(density, u_range, v_range, samples=400):
    """Independent check: the density integrated with a fine midpoint rule."""
    u = np.linspace(*u_range, samples + 1)
    v = np.linspace(*v_range, samples + 1)
    uu, vv = np.meshgrid((u[:-1] + u[1:]) / 2, (v[:-1] + v[1:]) / 2, indexing="ij")
    return density(uu, vv).sum() * (u[1] - u[0]) * (v[1] - v[0])


def test_pixel_factors_are_the_integrals_of_the_seed_densities():
    """Top face dF = dA / (pi (x^2 + y^2 + 1)^2), side face dF = z dA / (pi (y^2 + z^2 + 1)^2):
    compare a top pixel and a side pixel with a 400 x 400 midpoint rule (error ~1e-6 of the
    pixel's value for these smooth integrands, so 1e-5)."""
    resolution = 8
    directions, factors = hemicube.pixels(resolution)
    edges = np.linspace(-1, 1, resolution + 1)
    half_edges = np.linspace(0, 1, resolution // 2 + 1)
    top = lambda x, y: 1 / (np.pi * (x * x + y * y + 1) ** 2)
    side = lambda y, z: z / (np.pi * (y * y + z * z + 1) ** 2)
    i, j = 2, 5  # top pixel (x index, y index), stored x-major
    expected_top = midpoint_integral(top, edges[i : i + 2], edges[j : j + 2])
    np.testing.assert_allclose(factors[i * resolution + j], expected_top, rtol=1e-5)
    i, k = 6, 1  # first side face (+x), pixel (y index, z index)
    expected_side = midpoint_integral(side, edges[i : i + 2], half_edges[k : k + 2])
    np.testing.assert_allclose(factors[resolution**2 + i * (resolution // 2) + k], expected_side, rtol=1e-5)


def test_directions_pass_through_pixel_centres():
    directions, _ = hemicube.pixels(4)
    top = directions[:16] / directions[:16, 2:3]
    centres = np.array([-0.75, -0.25, 0.25, 0.75])
    np.testing.assert_allclose(top[:, 0], np.repeat(centres, 4))
    np.testing.assert_allclose(top[:, 1], np.tile(centres, 4))


@pytest.mark.parametrize("resolution", [0, 3, -2])
def test_a_bad_resolution_is_refused(resolution):
    with pytest.raises(ValueError, match="hemicube resolution must be an even number >= 2"):
        hemicube.pixels(resolution)
