"""Scene validation: every bad input is refused with a message naming the problem and the first
offending index; zero-area triangles are allowed and take colour from their neighbours."""

import numpy as np
import pytest

from core import Scene, bake
from tests.core.scenes import box, quad, merge


def good():
    vertices, triangles = box()
    count = len(triangles)
    return dict(vertices=vertices, triangles=triangles, reflectance=np.full((count, 3), 0.5),
                emission=np.zeros((count, 3)))


def with_change(name, change):
    arguments = good()
    arguments[name] = change(np.array(arguments[name]))
    return arguments


def set_at(index, value):
    def change(array):
        array[index] = value
        return array
    return change


@pytest.mark.parametrize(
    "name, change, message",
    [
        ("vertices", lambda a: a[:, :2], r"vertices must have shape \(n, 3\)"),
        ("vertices", set_at((5, 1), np.nan), r"vertices\[5\] is not finite"),
        ("vertices", set_at((2, 0), np.inf), r"vertices\[2\] is not finite"),
        ("vertices", lambda a: a.astype(str), "vertices must be a numeric array"),
        ("triangles", lambda a: a.astype(float), "triangles must be an integer array"),
        ("triangles", lambda a: a[:, :2], r"triangles must have shape \(T, 3\)"),
        ("triangles", set_at((7, 2), 24),
         r"triangles\[7\] = \[\d+, \d+, 24\] indexes outside vertices \(there are 24\)"),
        ("triangles", set_at((3, 0), -1), r"triangles\[3\] = \[-1, \d+, \d+\] indexes outside"),
        ("triangles", lambda a: a[:0], "the scene has no triangles"),
        ("reflectance", set_at((4, 1), 1.0), r"reflectance\[4\] = \[0.5, 1.0, 0.5\] is >= 1"),
        ("reflectance", set_at((6, 2), -0.1), r"reflectance\[6\] .* is negative"),
        ("reflectance", set_at((1, 0), np.nan), r"reflectance\[1\] is not finite"),
        ("reflectance", lambda a: a[:-1], r"reflectance must have one row per triangle \(12\), got 11"),
        ("emission", set_at((9, 0), -1.0), r"emission\[9\] .* is negative"),
        ("emission", set_at((2, 2), np.inf), r"emission\[2\] is not finite"),
        ("emission", lambda a: a[:, :1], r"emission must have shape \(n, 3\)"),
    ],
)
def test_bad_input_is_refused_with_the_first_offending_index(name, change, message):
    with pytest.raises(ValueError, match=message):
        Scene(**with_change(name, change))


def test_optional_arrays_are_checked():
    with pytest.raises(ValueError, match=r"material must be an integer array of shape \(12,\)"):
        Scene(**good(), material=np.zeros(11, dtype=int))
    with pytest.raises(ValueError, match=r"two_sided must be a bool array of shape \(12,\)"):
        Scene(**good(), two_sided=np.zeros(12, dtype=int))


def test_a_scene_is_immutable_and_holds_float64_copies():
    arguments = good()
    scene = Scene(**arguments)
    arguments["vertices"][0, 0] = 99.0
    assert scene.vertices[0, 0] == 0.0 and scene.vertices.dtype == np.float64
    with pytest.raises(ValueError):
        scene.vertices[0, 0] = 1.0


def test_a_scene_of_zero_area_triangles_only_is_refused():
    vertices = np.array([[0, 0, 0], [1, 0, 0], [2, 0, 0]], dtype=float)
    scene = Scene(vertices, np.array([[0, 1, 2]]), np.full((1, 3), 0.5), np.ones((1, 3)))
    with pytest.raises(ValueError, match="every triangle of the scene has zero area"):
        bake(scene)


def test_zero_area_triangles_take_colour_from_their_neighbours():
    """A floor lit by an emitter above, plus zero-area triangles: one along a floor edge (three
    collinear floor vertices), one collapsed to a floor vertex, and one floating alone. None may
    shoot or produce NaN; those touching the floor show the floor's colour at the shared vertex."""
    floor = quad([0, 0, 0], [1, 0, 0], [0, 1, 0])  # faces +z
    light = quad([0, 0, 1], [0, 1, 0], [1, 0, 0])  # faces -z
    vertices, triangles = merge(floor, light)
    extra_vertices = np.array([[0.5, 0, 0], [3, 3, 3]])
    vertices = np.concatenate([vertices, extra_vertices])
    degenerate = np.array([[0, 8, 1], [0, 0, 1], [9, 9, 9]])  # floor vertex 0 = (0,0,0), 1 = (1,0,0)
    triangles = np.concatenate([triangles, degenerate])
    count = len(triangles)
    reflectance = np.full((count, 3), 0.5)
    emission = np.zeros((count, 3))
    emission[2:4] = 1.0
    emission[6] = 0.25  # the lonely degenerate triangle: no neighbour, it keeps its own emission
    result = bake(Scene(vertices, triangles, reflectance, emission), patch_size=10.0)
    assert np.isfinite(result.corner_colors).all() and np.isfinite(result.triangle_radiosity).all()
    floor_corner_0 = result.corner_colors[0, 0]
    np.testing.assert_allclose(result.corner_colors[4, 0], floor_corner_0)
    np.testing.assert_allclose(result.corner_colors[5, 0], floor_corner_0)
    np.testing.assert_allclose(result.corner_colors[6], 0.25)
    assert result.stats["patches"] == 4  # zero-area triangles make no patch
