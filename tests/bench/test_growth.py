"""The growth study's scene family and slope (bench/studies/growth.py), on a scene of one triangle."""

import numpy as np

from bench.studies.growth import SPACING, slope, slopes, tiled
from tests.bench.test_scenes import floor


def test_tiles_are_copies_side_by_side_that_never_touch():
    one = floor()
    scene = tiled(one, 3)
    assert len(scene.triangles) == 9 and len(scene.vertices) == 27
    corners = scene.vertices[scene.triangles]
    low, high = corners.min(axis=1), corners.max(axis=1)
    for k in range(1, 9):  # each copy is the first moved by whole multiples of the spacing
        offset = corners[k] - corners[0]
        assert np.allclose(offset, offset[0]) and offset[0, 1] == 0.0
    # every two copies' boxes are apart along some axis by (SPACING - 1) x the scene's width (1 here)
    gaps = [np.maximum(low[j] - high[i], low[i] - high[j]).max() for i in range(9) for j in range(9) if i != j]
    assert min(gaps) >= (SPACING - 1) - 1e-12
    np.testing.assert_array_equal(scene.reflectance, np.tile(one.reflectance, (9, 1)))


def test_the_slope_of_a_power_law_is_its_exponent():
    counts = [10.0, 40.0, 160.0]
    assert abs(slope(counts, [3 * c**1.5 for c in counts]) - 1.5) < 1e-12


def test_the_last_step_shows_a_series_that_turns_steeper():
    """Linear up to 16, then quadratic: the fit over all four sizes hides it, the last step not."""
    counts = [1.0, 4.0, 16.0, 64.0]
    fitted, last = slopes(counts, [1.0, 4.0, 16.0, 16.0 * 4.0**2])
    assert abs(last - 2.0) < 1e-12 and fitted < 1.5
