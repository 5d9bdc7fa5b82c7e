"""spatial.overlapping_boxes and spatial.points_in_boxes against every pair tested directly."""

import numpy as np
import pytest

from core.util import spatial
from core.util.spatial import ranks, runs


def random_boxes(rng: np.random.Generator, count: int) -> tuple[np.ndarray, np.ndarray]:
    """Boxes in the unit cube: most small, a few spanning much of it (listed in many cells, or
    tested against everything), some flat (zero extent along an axis, as a floor's triangles)."""
    low = rng.random((count, 3))
    size = rng.random((count, 3)) * np.where(rng.random((count, 1)) < 0.05, 0.8, 0.05)
    size[rng.random(count) < 0.2, rng.integers(0, 3)] = 0.0
    return low, low + size


@pytest.mark.parametrize("grid", [True, False])
def test_overlapping_boxes_finds_exactly_the_touching_pairs(monkeypatch, grid):
    """The grid (forced by lowering EVERY_PAIR) and the direct test give the same pairs as the
    brute-force comparison of every pair, each once, sorted."""
    if grid:
        monkeypatch.setattr(spatial, "EVERY_PAIR", 0)
    rng = np.random.default_rng(7)
    low_a, high_a = random_boxes(rng, 400)
    low_b, high_b = random_boxes(rng, 300)
    # and boxes that only touch: the first 50 of b start along x exactly where those of a end
    low_b[:50], high_b[:50] = low_a[:50].copy(), high_a[:50].copy()
    low_b[:50, 0], high_b[:50, 0] = high_a[:50, 0], high_a[:50, 0] + 0.01
    first, second = spatial.overlapping_boxes(low_a, high_a, low_b, high_b)
    touching = ((low_a[:, None] <= high_b[None]) & (low_b[None] <= high_a[:, None])).all(axis=2)
    expected_first, expected_second = np.nonzero(touching)
    assert len(expected_first) > 300  # the case is not trivial (595 pairs)
    np.testing.assert_array_equal(first, expected_first)
    np.testing.assert_array_equal(second, expected_second)


@pytest.mark.parametrize("grid, blocks", [(True, None), (True, 7), (False, None), (False, 7)])
def test_boxes_against_themselves_and_a_filter_give_exactly_the_touching_pairs_it_keeps(monkeypatch, grid, blocks):
    """One set against itself (each pair of different sizes found once and turned round) gives
    every pair both ways and each box with itself, as brute force does; ``keep``, which need not be
    symmetric, drops exactly the pairs it rejects, each way on its own. So it does when the work is
    cut into ``blocks`` of a few candidates and queries (the grid's: each pair made in one cell only;
    the direct test's: a row of boxes at a time)."""
    if grid:
        monkeypatch.setattr(spatial, "EVERY_PAIR", 0)
    if blocks:
        monkeypatch.setattr(spatial, "PAIRS_PER_BLOCK", blocks)
        monkeypatch.setattr(spatial, "LISTINGS_PER_BLOCK", blocks)
    low, high = random_boxes(np.random.default_rng(8), 500)
    touching = ((low[:, None] <= high[None]) & (low[None] <= high[:, None])).all(axis=2)
    first, second = spatial.overlapping_boxes(low, high, low, high)
    np.testing.assert_array_equal(np.stack([first, second]), np.stack(np.nonzero(touching)))
    sizes = (high - low).max(axis=1)
    first, second = spatial.overlapping_boxes(low, high, low, high, lambda i, j: sizes[i] < 2 * sizes[j])
    np.testing.assert_array_equal(np.stack([first, second]),
                                  np.stack(np.nonzero(touching & (sizes[:, None] < 2 * sizes[None]))))
    assert len(first) > 1000 and (sizes[first] > sizes[second]).any()  # both ways of pairs of different sizes


@pytest.mark.parametrize("grid", [True, False])
def test_points_in_boxes_finds_exactly_the_points_inside_and_applies_the_filter(monkeypatch, grid):
    """Points against boxes (grids of several sizes, and the direct test) give the brute-force
    pairs, each once; ``keep`` sees only pairs inside and its verdict stands."""
    if grid:
        monkeypatch.setattr(spatial, "EVERY_PAIR", 0)
        monkeypatch.setattr(spatial, "BOX_SPAN", 2)  # many boxes on coarser grids
        monkeypatch.setattr(spatial, "LISTINGS_PER_BLOCK", 50)  # many blocks
        monkeypatch.setattr(spatial, "PAIRS_PER_BLOCK", 100)
    rng = np.random.default_rng(11)
    low, high = random_boxes(rng, 300)
    points = rng.random((3000, 3))
    points[:40] = low[:40]  # on a corner of a box: inside
    points[40:60, 0] = high[40:60, 0]  # on a face's plane
    inside = ((low[None] <= points[:, None]) & (points[:, None] <= high[None])).all(axis=2)
    expected = set(zip(*np.nonzero(inside)))
    assert len(expected) > 500  # not trivial (917 pairs)
    first, second = spatial.points_in_boxes(points, low, high)
    assert len(first) == len(expected) and set(zip(first, second)) == expected
    seen = []

    def even_sum(i, j):
        seen.append(inside[i, j].all())
        return (i + j) % 2 == 0

    first, second = spatial.points_in_boxes(points, low, high, even_sum)
    assert all(seen)
    assert set(zip(first, second)) == {(i, j) for i, j in expected if (i + j) % 2 == 0}


def test_boxes_cut_to_the_front_of_a_plane_keep_every_point_in_front_and_lose_what_is_behind():
    """in_front: every point of a box on or in front of its plane (within the margin) stays in
    the cut box, for planes at any angle; a plane along an axis cuts its box at the plane, and a
    box wholly behind its plane is left empty."""
    rng = np.random.default_rng(3)
    low, high = random_boxes(rng, 300)
    origins = low + rng.random((300, 3)) * (high - low)
    normals = rng.normal(size=(300, 3))
    normals[:100] = np.eye(3)[rng.integers(0, 3, 100)] * rng.choice([-1.0, 1.0], (100, 1))  # along an axis
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    margin = np.full(300, 1e-3)
    cut_low, cut_high = spatial.in_front(low, high, origins, normals, margin)
    samples = low[:, None] + rng.random((300, 2000, 3)) * (high - low)[:, None]
    front = np.einsum("kmx,kx->km", samples - origins[:, None], normals) >= -margin[:, None]
    inside = ((cut_low[:, None] <= samples) & (samples <= cut_high[:, None])).all(axis=2)
    assert front.sum() > 200_000  # most boxes have points in front
    assert not (front & ~inside).any()
    axis = np.abs(normals[:100]).argmax(axis=1)
    rows = np.arange(100)
    bound = np.where(normals[rows, axis] > 0, cut_low[rows, axis], cut_high[rows, axis])
    np.testing.assert_allclose(bound, np.clip(origins[rows, axis] - margin[:100] * normals[rows, axis],
                                              low[rows, axis], high[rows, axis]), rtol=0, atol=1e-12)
    behind_low, behind_high = spatial.in_front(low[:1], high[:1], high[:1] + 1.0, np.array([[0.0, 0.0, 1.0]]),
                                               margin[:1])
    assert (behind_low > behind_high).any()


def test_runs_and_ranks_are_np_repeat_s():
    """``runs`` and ``ranks`` (made without np.repeat, which holds the GIL) against np.repeat,
    with empty runs first, between and last."""
    rng = np.random.default_rng(4)
    for counts in (np.array([0, 0, 3, 0, 2, 0]), np.zeros(0, dtype=np.int64), np.zeros(3, dtype=np.int64),
                   rng.integers(0, 5, 10_000)):
        np.testing.assert_array_equal(runs(counts), np.repeat(np.arange(len(counts)), counts))
        np.testing.assert_array_equal(ranks(counts), np.arange(counts.sum()) - np.repeat(np.cumsum(counts) - counts,
                                                                                         counts))
