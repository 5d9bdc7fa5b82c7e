"""core.scene.textures: per-triangle means of an image over UV footprints, and per-face means."""

import numpy as np

from core.scene.textures import face_means, image_triangle_means


def gradient(width: int = 256, height: int = 128) -> np.ndarray:
    """(H, W, 2): the first channel u and the second v at each pixel's centre, row 0 at v = 0."""
    u = (np.arange(width) + 0.5) / width
    v = (np.arange(height) + 0.5) / height
    return np.stack(np.broadcast_arrays(u[None, :], v[:, None]), axis=2)


def test_a_linear_image_averages_to_its_value_at_the_centroid():
    """A linear function's mean over a triangle is its value at the centroid; the nearest-pixel
    reading is off by at most half a pixel."""
    rng = np.random.default_rng(5)
    uv = rng.random((200, 3, 2)) * 0.9 + 0.05
    means = image_triangle_means(gradient(), uv)
    assert np.allclose(means, uv.mean(axis=1), atol=0.5 / 128)


def test_the_image_repeats_beyond_the_unit_square():
    uv = np.array([[[0.1, 0.2], [0.3, 0.2], [0.1, 0.4]]])
    shifted = uv + [2.0, -1.0]
    assert np.array_equal(image_triangle_means(gradient(), uv), image_triangle_means(gradient(), shifted))


def test_a_half_black_image_averages_to_the_share_of_the_triangle_on_white():
    """A triangle across the border of a black left half and a white right half: its mean is the
    share of its area right of u = 1/2 (here a right triangle with legs along u and v: 1/4)."""
    image = np.zeros((64, 64, 1))
    image[:, 32:] = 1.0
    uv = np.array([[[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]]]) * 0.999
    assert np.allclose(image_triangle_means(image, uv), 0.25, atol=1 / 64)


def test_face_means_weigh_triangles_by_area():
    values = np.array([[1.0], [3.0], [10.0]])
    areas = np.array([1.0, 3.0, 2.0])
    face = np.array([7, 7, 2])
    assert np.allclose(face_means(values, areas, face), [[2.5], [2.5], [10.0]])
