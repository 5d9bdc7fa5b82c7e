"""Sky light by direction (core.Environment, an HDRI): a lone plane under an environment bright
above the horizon and black below sees the half-sky, whose cosine-weighted share for a surface
tilted by alpha from the horizontal is (1 + cos alpha) / 2 (the sky view factor of a tilted
plane); a uniform image lights as the uniform sky of its value."""

import dataclasses
import math

import numpy as np
import pytest

from core import Environment, Scene, bake
from tests.core.scenes import lit_room, quad

RHO, SKY = 0.5, 2.0


def tilted_plane(alpha: float, **light) -> Scene:
    """A unit square through the origin whose normal is tilted by ``alpha`` from +z towards +x."""
    normal_side = np.array([math.cos(alpha), 0.0, -math.sin(alpha)])  # an edge in the plane, across the tilt
    vertices, triangles = quad(-0.5 * normal_side - [0, 0.5, 0], normal_side, [0, 1.0, 0])
    return Scene(vertices, triangles, np.full((2, 3), RHO), np.zeros((2, 3)), **light)


def half_sky(height: int = 64, width: int = 128) -> np.ndarray:
    radiance = np.zeros((height, width, 3))
    radiance[height // 2:] = SKY  # v >= 1/2: above the horizon
    return radiance


@pytest.mark.parametrize("alpha_degrees", [0, 60, 90, 135])
def test_a_tilted_plane_sees_the_half_sky_by_its_view_factor(alpha_degrees):
    alpha = math.radians(alpha_degrees)
    scene = tilted_plane(alpha, environment=Environment(half_sky()))
    normal = np.cross(*(scene.vertices[scene.triangles[0, 1:]] - scene.vertices[scene.triangles[0, 0]]))
    assert np.isclose(normal[2] / np.linalg.norm(normal), math.cos(alpha))  # tilted as meant
    colours = bake(scene, rays_per_form_factor=64).corner_colors
    expected = RHO * SKY * (1 + math.cos(alpha)) / 2
    np.testing.assert_allclose(colours, expected, atol=0.01 * RHO * SKY)


@pytest.mark.parametrize("scene", ["plane", "room"])
def test_a_uniform_image_lights_as_the_uniform_sky(scene):
    """The same rays, read through the image or as the sky: the same colours. In the open-topped
    room most points see the sky through the opening, partly: their second looks along its outline
    (``direct.OUTLINE_LOOKS``) read the image as well."""
    image = np.full((8, 16, 3), SKY)
    if scene == "plane":
        with_image = bake(tilted_plane(0.7, environment=Environment(image))).corner_colors
        with_sky = bake(tilted_plane(0.7, sky=[SKY] * 3)).corner_colors
    else:
        room = lit_room()
        with_image = bake(dataclasses.replace(room, environment=Environment(image))).corner_colors
        with_sky = bake(dataclasses.replace(room, sky=np.full(3, SKY))).corner_colors
        assert with_sky.min() < 0.5 * with_sky.max()  # the room's shade: not all of it sees all the sky
    np.testing.assert_allclose(with_image, with_sky, rtol=1e-12)


def test_the_rotation_turns_the_sky():
    """Turned a quarter about x so that the image's up is the world's -y, the lit half-sky is the
    world's y < 0: a plane facing -y sees all of it, one facing +y none."""
    to_image = np.array([[1.0, 0, 0], [0, 0, 1.0], [0, -1.0, 0]])  # world -y -> image +z
    environment = Environment(half_sky(), to_image)
    facing = {}
    for sign in (-1, 1):
        u, v = ([1.0, 0, 0], [0, 0, 1.0]) if sign < 0 else ([0, 0, 1.0], [1.0, 0, 0])  # u x v = (0, sign, 0)
        vertices, triangles = quad([-0.5, 0, -0.5], u, v)
        scene = Scene(vertices, triangles, np.full((2, 3), RHO), np.zeros((2, 3)), environment=environment)
        facing[sign] = bake(scene, rays_per_form_factor=64).corner_colors
    np.testing.assert_allclose(facing[-1], RHO * SKY, rtol=0.01)
    np.testing.assert_allclose(facing[1], 0.0, atol=0.01 * RHO * SKY)


def test_a_bad_environment_is_refused():
    with pytest.raises(ValueError, match=r"shape \(H, W, 3\)"):
        Environment(np.zeros((4, 4)))
    with pytest.raises(ValueError, match="rotation matrix"):
        Environment(np.zeros((2, 2, 3)), np.diag([1.0, 1.0, 2.0]))
