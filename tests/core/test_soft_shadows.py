"""Soft shadows: a sun of angular diameter a and a point light of radius r behind the straight
edge of a roof. Right below the edge half the sun's disc (or the light's disc) is hidden, so a
floor point there gets half the light (the disc is symmetric about the edge's line); outside the
penumbra (h tan(a / 2) from the edge for the sun, by similar triangles for the sphere) it gets all
of it or none. The light arriving from an unblocked light is unchanged by its size."""

import math

import numpy as np
import pytest

from core import PointLight, SunLight
from core.rays.visibility import Visibility
from core.transport.direct import DirectLighting
from tests.core.scenes import quad

H = 1.0  # the roof's height; it covers x < 0 (and faces down)
ROOF = np.array(quad([-50, -50, H], [0, 100, 0], [50, 0, 0])[0])[[[0, 1, 2], [0, 2, 3]]]


def direct(light, rays: int = 256) -> DirectLighting:
    return DirectLighting([light], np.zeros(3), Visibility(ROOF), rays, seed=1)


def at_floor(lighting: DirectLighting, xs) -> np.ndarray:
    points = np.stack([np.asarray(xs, float), np.zeros(len(xs)), np.zeros(len(xs))], axis=1)
    return lighting.at_points(points, np.tile([0.0, 0.0, 1.0], (len(xs), 1)), lambda _f: None)[:, 0]


def test_the_sun_s_penumbra():
    angle = math.radians(10)
    lit = 2.0 / math.pi  # G of a floor facing a sun of strength 2 straight down
    reach = H * math.tan(angle / 2)
    g = at_floor(direct(SunLight([0, 0, -1], [2.0] * 3, angle)), [-1.5 * reach, 0.0, 1.5 * reach, 5.0])
    np.testing.assert_allclose(g, [0.0, lit / 2, lit, lit], atol=0.01 * lit)


def test_a_sphere_light_s_penumbra():
    radius, height = 0.2, 3.0  # the light at (0, 0, 3): the roof's edge runs right below it
    light = PointLight([0.0, 0.0, height], [100.0] * 3, radius)
    reach = radius * H / (height - H)  # the penumbra's half-width at the floor (similar triangles)
    xs = [-1.5 * reach, 0.0, 1.5 * reach]
    g = at_floor(direct(light), xs)
    unblocked = at_floor(DirectLighting([light], np.zeros(3), Visibility(ROOF + [0, 0, 100]), 256, 1), xs)
    np.testing.assert_allclose(g, unblocked * [0.0, 0.5, 1.0], atol=0.01 * unblocked.max())
    point = at_floor(DirectLighting([PointLight([0.0, 0.0, height], [100.0] * 3)], np.zeros(3),
                                    Visibility(ROOF + [0, 0, 100]), 256, 1), xs)
    np.testing.assert_allclose(unblocked, point, rtol=1e-12)  # its size changes no light, only shadows


@pytest.mark.parametrize("light", [lambda: SunLight([0, 0, -1], [1.0] * 3, -0.1),
                                   lambda: SunLight([0, 0, -1], [1.0] * 3, math.pi),
                                   lambda: PointLight([0, 0, 1], [1.0] * 3, float("nan"))])
def test_bad_sizes_are_refused(light):
    with pytest.raises(ValueError):
        light()
