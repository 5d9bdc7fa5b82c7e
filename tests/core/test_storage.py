"""core.reconstruct.storage: exposure and tone for 8-bit colour attributes, per-vertex means."""

import numpy as np
import pytest

from core.reconstruct.storage import SOFT_WHITE, exposed, vertex_means


def test_exposure_doubles_per_stop_and_float_storage_keeps_any_value():
    colours = np.array([[0.1, 2.0, 30.0]])
    assert np.allclose(exposed(colours, 1.0, None), [[0.2, 4.0, 60.0]])
    assert np.allclose(exposed(colours, -2.0, None), colours / 4)


def test_clip_keeps_values_below_one_and_clips_the_rest():
    assert np.allclose(exposed(np.array([[-0.5, 0.25, 3.0]]), 0.0, "CLIP"), [[0.0, 0.25, 1.0]])


def test_soft_tone_is_reinhards_extended_curve():
    """Fixed points of x (1 + x / w^2) / (1 + x): 0 -> 0, w -> 1; near 0 it is x; it rises
    strictly up to the white and differences between bright values survive (unlike clipping)."""
    x = np.linspace(0, SOFT_WHITE, 401)[:, None].repeat(3, axis=1)
    y = exposed(x, 0.0, "SOFT")
    assert y[0, 0] == 0 and y[-1, 0] == pytest.approx(1.0)
    assert y[1, 0] == pytest.approx(x[1, 0], rel=0.02)
    assert (np.diff(y[:, 0]) > 0).all()
    assert exposed(np.array([[2.0, 3.0, 9.0]]), 0.0, "SOFT")[0, 2] == 1.0


def test_unknown_tone_is_refused():
    with pytest.raises(ValueError, match="tone must be one of"):
        exposed(np.zeros((1, 3)), 0.0, "FILMIC")


def test_vertex_means_average_the_corners_at_each_vertex():
    corner_vertex = np.array([0, 1, 2, 0, 2, 3])
    values = np.array([[1.0], [2.0], [3.0], [5.0], [7.0], [4.0]])
    assert np.allclose(vertex_means(values, corner_vertex, 5), [[3.0], [2.0], [5.0], [4.0], [0.0]])
