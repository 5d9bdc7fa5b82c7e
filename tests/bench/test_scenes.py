"""The emitting quad bench/scenes.py adds to Sponza as its sky, on a scene of one triangle."""

import numpy as np
import pytest

from bench.scenes import with_emitter_quad
from core import Scene

CORNERS = np.array([[0.0, 1.0, 0.0], [1.0, 1.0, 0.0], [1.0, 1.0, 1.0], [0.0, 1.0, 1.0]])


def floor() -> Scene:
    return Scene(np.array([[0.0, 0, 0], [1, 0, 0], [0, 0, 1]]), np.array([[0, 2, 1]]), np.full((1, 3), 0.5),
                 np.zeros((1, 3)))


def test_the_quad_is_two_black_one_sided_emitters_of_their_own_material():
    scene = with_emitter_quad(floor(), CORNERS, 5.0, facing=(0.0, -1.0, 0.0))
    assert len(scene.triangles) == 3
    assert scene.emission[1:].tolist() == [[5.0] * 3] * 2 and not scene.reflectance[1:].any()
    assert not scene.two_sided[1:].any()
    assert scene.material[1] == scene.material[2] != scene.material[0]


def test_a_quad_facing_the_other_way_is_refused():
    with pytest.raises(ValueError, match="do not face"):
        with_emitter_quad(floor(), CORNERS, 5.0, facing=(0.0, 1.0, 0.0))
