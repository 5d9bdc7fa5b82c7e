"""Occlusion: a blocker between two parallel plates removes what it hides, by the exact amount.

From a point at the centre of the lower plate, a centred square blocker of half-width a at half
the height c/2 hides exactly the centred square of half-width 2a on the upper plate (similar
triangles). So F(point -> upper plate) drops from B-3 over the whole plate to B-3 over the
plate minus B-3 over that square (Howell B-3 by superposition, four corner rectangles each).
"""

import numpy as np
import pytest

from core import form_factor_matrix
from tests.core.scenes import merge, quad

HEIGHT = 1.0
PLATE = 1.0  # half-width of the upper plate
BLOCKER = 0.2  # half-width of the blocker, at HEIGHT / 2


def centred_square_factor(half_width, height):
    """B-3 over four corner rectangles: a point under the centre of a square."""
    x = y = half_width / height
    sx, sy = np.sqrt(1 + x * x), np.sqrt(1 + y * y)
    return 4 * (x / sx * np.arctan(y / sx) + y / sy * np.arctan(x / sy)) / (2 * np.pi)


def scene(with_blocker):
    size = 1e-4  # a tiny receiver triangle: its centroid is the point
    receiver = (np.array([[-size, -size, 0], [size, -size, 0], [0, size, 0]]), np.array([[0, 1, 2]]))
    upper = quad([-PLATE, -PLATE, HEIGHT], [0, 2 * PLATE, 0], [2 * PLATE, 0, 0])  # faces down
    parts = [receiver, upper]
    if with_blocker:
        parts.append(quad([-BLOCKER, -BLOCKER, HEIGHT / 2], [0, 2 * BLOCKER, 0], [2 * BLOCKER, 0, 0]))  # faces down
    return merge(*parts)


@pytest.mark.parametrize("method, tolerance", [
    # stratified visibility: rays to 16 points on each source patch of side 1/8 resolve the
    # shadow's edge to about a patch's width; measured 1.5e-5 relative
    ("raycast", 1e-3),
    # the bake's default, 4 probe rays first and the other 12 only where the probes disagree:
    # a patch the shadow's edge crosses between its probes counts as wholly seen or hidden;
    # measured 0.95 % for the rest of the plate (the blocker itself, never partly hidden, 6e-9)
    ("raycast-probing", 0.015),
    # the squares' edges are quantised to pixel rows: up to half a pixel on each of 4 edges of
    # the hidden square, 51 pixels across at N = 128, so 2/51 = 4 %; measured 2.6 % for the
    # blocker and 1.1 % for the rest of the plate
    ("hemicube", 0.04),
])
def test_a_blocker_removes_exactly_what_it_hides(method, tolerance):
    method, _, probing = method.partition("-")
    knobs = dict(patch_size=0.125, hemicube_resolution=128, probe_rays=bool(probing))
    vertices, triangles = scene(with_blocker=False)
    open_view = form_factor_matrix(vertices, triangles, method, **knobs)[0, 1:3].sum()
    vertices, triangles = scene(with_blocker=True)
    matrix = form_factor_matrix(vertices, triangles, method, **knobs)
    blocked = matrix[0, 1:3].sum()
    whole = centred_square_factor(PLATE, HEIGHT)
    hidden = centred_square_factor(2 * BLOCKER, HEIGHT)
    np.testing.assert_allclose(open_view, whole, rtol=tolerance)
    np.testing.assert_allclose(blocked, whole - hidden, rtol=tolerance)
    # the blocker faces the receiver: it is seen exactly where the plate is hidden
    np.testing.assert_allclose(matrix[0, 3:].sum(), hidden, rtol=tolerance)
