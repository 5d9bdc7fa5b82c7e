"""The nodes' light averaged with their neighbours' (core/reconstruct/denoise.py): against a known
field with noise of a known size, and a Monte Carlo bake against its converged answer."""

from types import SimpleNamespace

import numpy as np
import pytest

from core import bake
from core.reconstruct.denoise import WARD_ERROR, denoised, neighbours
from tests.core.scenes import grid
from tests.core.test_montecarlo import gridded_box

CELLS = 40
NOISE = 0.05


def plane_nodes() -> SimpleNamespace:
    """The nodes of a unit square split in CELLS x CELLS cells of two triangles, one node per vertex."""
    vertices, triangles = grid([0, 0, 0], [1, 0, 0], [0, 1, 0], CELLS)
    return SimpleNamespace(corner_node=triangles, node_count=len(vertices), node_points=vertices,
                           node_normals=np.tile([0.0, 0.0, 1.0], (len(vertices), 1)))


def noisy(truth: np.ndarray) -> np.ndarray:
    return truth + np.random.default_rng(1).normal(0.0, NOISE, truth.shape)


def test_neighbours_are_the_nodes_that_share_a_triangle_both_ways_round():
    """Six around an inner vertex of the grid (its diagonals go one way), each pair listed twice."""
    mesh = plane_nodes()
    first, second = neighbours(mesh)
    assert np.bincount(first, minlength=mesh.node_count)[(CELLS + 1) * 5 + 5] == 6
    pairs = set(zip(first.tolist(), second.tolist()))
    assert len(pairs) == len(first) and all((j, i) in pairs for i, j in pairs)


def test_noise_over_a_smooth_field_falls_and_the_field_stays():
    """A linear field with Gaussian noise of a known standard error, the distance the nodes' rays
    went 100 cells: each node averages about seven alike (the noise's RMS falls to about 1 / sqrt(7)
    = 0.38 of itself); a linear field is its own mean over a symmetric ring, so what is left is
    noise (allowed: 0.5)."""
    mesh = plane_nodes()
    truth = (1.0 + 0.3 * mesh.node_points[:, 0])[:, None]
    error = np.full_like(truth, NOISE)
    found = denoised(mesh, noisy(truth), error, np.full(mesh.node_count, 100.0 / CELLS), 3.0)
    assert np.sqrt(((found - truth) ** 2).mean()) <= 0.5 * NOISE


def test_a_step_many_standard_errors_high_stays_sharp():
    """A step of 20 standard errors across x = 0.5 (on a vertex column): the 41 nodes beside it on
    either side keep their side's level. Averaged with their neighbours across it they would be off
    by about 1 / 7 of the step; allowed: 3 / 100 of it, four times the noise of a column's mean
    (NOISE / sqrt(41), which this draw puts at -0.010 and +0.010 before the filter)."""
    mesh = plane_nodes()
    x = mesh.node_points[:, 0]
    truth = np.where(x < 0.5 - 1e-9, 1.0, 1.0 + 20 * NOISE)[:, None]
    found = denoised(mesh, noisy(truth), np.full_like(truth, NOISE), np.full(mesh.node_count, 100.0 / CELLS), 3.0)
    for beside in (np.abs(x - (0.5 - 1 / CELLS)) < 1e-9, np.abs(x - 0.5) < 1e-9):
        assert abs((found - truth)[beside].mean()) <= 0.03 * 20 * NOISE


def test_nodes_far_apart_for_what_they_see_are_left_alone():
    """Nodes one cell apart whose rays met surfaces one cell away (Ward's error 1, above WARD_ERROR)
    are not averaged, however alike their light."""
    assert WARD_ERROR < 1
    mesh = plane_nodes()
    light = noisy(np.ones((mesh.node_count, 1)))
    assert np.array_equal(denoised(mesh, light, np.full_like(light, NOISE), np.full(mesh.node_count, 1.0 / CELLS),
                                   3.0), light)


def test_nodes_whose_normals_part_are_not_averaged_across_the_fold():
    """The square folded along x = 0.5 (the nodes from there on face +y): light 6 NOISE higher beyond
    the fold, which a standard error of 4 NOISE makes look alike. Facing one way, the column before
    the fold takes about 2 / 7 of the difference (0.086); with the normals parted (Ward's error 1)
    it keeps its own level, up to its noise (NOISE / sqrt(41) before the filter: allowed 0.02)."""
    mesh = plane_nodes()
    x = mesh.node_points[:, 0]
    beyond = x > 0.5 - 1e-9
    truth = np.where(beyond, 1.0 + 6 * NOISE, 1.0)[:, None]
    light, error, distance = noisy(truth), np.full_like(truth, 4 * NOISE), np.full(mesh.node_count, 100.0 / CELLS)
    before = np.abs(x - (0.5 - 1 / CELLS)) < 1e-9
    flat = denoised(mesh, light, error, distance, 3.0)
    assert (flat - truth)[before].mean() >= 0.05
    mesh.node_normals[beyond] = [0.0, 1.0, 0.0]
    folded = denoised(mesh, light, error, distance, 3.0)
    assert abs((folded - truth)[before].mean()) <= 0.02


def test_a_node_without_noise_is_left_as_it_is():
    """Without a standard error only equal neighbours count as alike: a field of distinct values
    comes back unchanged."""
    mesh = plane_nodes()
    light = np.random.default_rng(2).random((mesh.node_count, 3))
    assert np.array_equal(denoised(mesh, light, np.zeros_like(light), np.full(mesh.node_count, np.inf), 3.0), light)


@pytest.fixture(scope="module")
def box_bakes():
    """The gridded box's Monte Carlo bakes at 16 rays, four seeds, with and without the filter,
    and the same bake at 1,024 rays (converged: test_montecarlo.py)."""
    scene = gridded_box()
    knobs = dict(patch_size=0.2, rays_per_form_factor=4, tolerance=1e-6)
    converged = bake(scene, **knobs, monte_carlo_rays=1024, denoise=0.0).corner_colors
    return converged, {strength: [bake(scene, **knobs, monte_carlo_rays=16, seed=seed, denoise=strength).corner_colors
                                  for seed in range(4)] for strength in (0.0, 3.0)}


def test_a_denoised_monte_carlo_bake_is_nearer_its_converged_answer_and_no_more_biased(box_bakes):
    """Measured: one bake's error 1.74 % without the filter, 1.58 % with it (each of the four seeds
    lower); the four seeds' mean 1.00 and 1.03 % from the answer (their noise halved: a bias the filter
    added would stay). Allowed: 0.95 times the error, and the mean no more than 1.15 times as far."""
    converged, bakes = box_bakes
    scale = np.sqrt((converged**2).mean())

    def error(colours):
        return np.sqrt(((colours - converged) ** 2).mean()) / scale

    plain, filtered = bakes[0.0], bakes[3.0]
    assert np.mean([error(c) for c in filtered]) <= 0.95 * np.mean([error(c) for c in plain])
    assert error(np.mean(filtered, axis=0)) <= 1.15 * error(np.mean(plain, axis=0))
