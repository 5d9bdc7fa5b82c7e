"""The three solvers against numpy.linalg.solve on the same matrix, and against each other
through bake()."""

import numpy as np
import pytest

from core import bake, form_factor_matrix
from core.solve import iterative, progressive
from tests.core.scenes import lit_room


@pytest.fixture(scope="module")
def system():
    """A coloured room's form factors (with occlusion), its reflectance and emission."""
    scene = lit_room()
    matrix = form_factor_matrix(scene.vertices, scene.triangles, "raycast", patch_size=0.2)
    return matrix, scene.reflectance, scene.emission


def exact(matrix, reflectance, emission):
    """B = (I - diag(rho) F)^-1 E, per channel."""
    return np.stack([
        np.linalg.solve(np.eye(len(matrix)) - reflectance[:, [c]] * matrix, emission[:, c]) for c in range(3)
    ], axis=1)


@pytest.mark.parametrize("solve", [iterative.jacobi, iterative.gauss_seidel])
def test_iterative_solvers_agree_with_a_direct_solve(system, solve):
    """Their stopping rule bounds the error by tolerance * max |B| (row sums of rho F < 1)."""
    matrix, reflectance, emission = system
    truth = exact(*system)
    radiosity, stats = solve(matrix, reflectance, emission, tolerance=1e-8)
    assert np.abs(radiosity - truth).max() <= 1e-8 * np.abs(truth).max()
    assert stats["error_bound"] <= 1e-8 and stats["residual"] <= 1e-8 * np.abs(truth).max()


@pytest.mark.parametrize("solve", [iterative.jacobi, iterative.gauss_seidel])
@pytest.mark.parametrize("sweeps", [0, 1, 3, 8])
@pytest.mark.parametrize("start", ["emission", "scattered"])
def test_the_patch_by_patch_bound_holds_and_is_close_to_the_error(system, solve, sweeps, start):
    """Stopped after a few sweeps, each patch's error against the direct solve is within its bound
    (``componentwise_bound``), and the bound's RMS within 1.2 times the error's (measured 1.00
    from the emission, 1.00 to 1.10 from a scattered start; the uniform bound, max |r| / (1 - q)
    everywhere, is 2.7 to 4 times the largest error). From a start scattered around the answer
    the residual changes sign from patch to patch, and |r| stands for it."""
    matrix, reflectance, emission = system
    truth = exact(*system)
    initial = None
    if start == "scattered":
        initial = truth * np.random.default_rng(sweeps).uniform(0.5, 1.5, truth.shape)
    radiosity, stats = solve(matrix, reflectance, emission, tolerance=1e-14, max_iterations=sweeps, initial=initial)
    error, bound = np.abs(truth - radiosity), stats["error_bounds"]
    assert (error <= bound + 1e-12 * np.abs(truth).max()).all()
    assert np.sqrt((bound ** 2).mean()) <= 1.2 * np.sqrt((error ** 2).mean())


def test_gauss_seidel_needs_fewer_sweeps_than_jacobi(system):
    _, jacobi_stats = iterative.jacobi(*system, tolerance=1e-8)
    _, seidel_stats = iterative.gauss_seidel(*system, tolerance=1e-8)
    assert seidel_stats["iterations"] < jacobi_stats["iterations"]


def columns_of(matrix: np.ndarray):
    """``progressive``'s ``columns`` over an explicit matrix: the columns of the sources asked
    for, each captured whole."""
    return lambda sources, _tick: (list(matrix[:, sources].T), np.ones(len(sources)))


@pytest.mark.parametrize("ambient", [False, True])
def test_progressive_refinement_agrees_with_a_direct_solve(system, ambient):
    """Shooting until the undistributed light is below 1e-9 of all the light: the remaining
    error is of that order times the mean reflectance's gain, with or without the ambient term."""
    matrix, reflectance, emission = system
    truth = exact(*system)
    areas = np.ones(len(matrix))  # the solver only uses areas to rank shooters and weigh energy
    radiosity, _, stats = progressive.progressive(columns_of(matrix), areas, reflectance, emission, tolerance=1e-9,
                                                  ambient=ambient)
    assert stats["unshot_fraction"] <= 1e-9
    np.testing.assert_allclose(radiosity, truth, rtol=1e-7, atol=1e-7 * np.abs(truth).max())


def test_progressive_refinement_shoots_passive_receivers_too(system):
    """Passive receivers (the vertices) get E + rho F B for the final B, like a gather would."""
    matrix, reflectance, emission = system
    truth = exact(*system)
    probes = matrix[:3] * 0.5  # any rows of form factors will do
    probe_reflectance, probe_emission = np.full((3, 3), 0.4), np.full((3, 3), 0.1)
    columns = np.concatenate([matrix, probes])
    _, passive, _ = progressive.progressive(columns_of(columns), np.ones(len(matrix)), reflectance, emission,
                                            probe_reflectance, probe_emission, tolerance=1e-10, ambient=False)
    np.testing.assert_allclose(passive, probe_emission + probe_reflectance * (probes @ truth), rtol=1e-7)


def test_a_system_without_a_solution_is_refused():
    matrix = np.array([[0.0, 1.0], [1.0, 0.0]]) * 1.2  # row sums over 1: light would grow forever
    with pytest.raises(ValueError, match="does not converge"):
        iterative.jacobi(matrix, np.full((2, 1), 0.9), np.ones((2, 1)))


@pytest.mark.parametrize("method", ["raycast", "hemicube"])
def test_every_solver_gives_the_same_bake(method):
    """Same discretisation and form factors, so the same answer to the solvers' tolerance; the
    progressive hemicube uses reciprocity instead (checked separately in the furnace tests)."""
    scene = lit_room()
    solver_list = ["progressive", "jacobi", "gauss_seidel"] if method == "raycast" else ["jacobi", "gauss_seidel"]
    results = [bake(scene, method, solver, tolerance=1e-6, ambient=False).corner_colors for solver in solver_list]
    for other in results[1:]:
        np.testing.assert_allclose(other, results[0], rtol=1e-4, atol=1e-5 * results[0].max())


def test_an_explicit_matrix_over_the_memory_budget_is_refused():
    with pytest.raises(ValueError, match=r"needs a [\d,]+ x [\d,]+ form-factor matrix .* over the memory budget"):
        bake(lit_room(), "raycast", "jacobi", memory_budget=1000)


def test_the_column_cache_shoots_sparse_and_dense_columns_alike():
    """Columns with at most progressive.SPARSE of their values nonzero are kept as those values,
    the others as rows of one array: a shot from any mix of them is the dense product, and the
    bytes held follow what each kind keeps."""
    rng = np.random.default_rng(3)
    size = 200
    columns = rng.random((size, 6))
    columns[:, :3] *= rng.random((size, 3)) < 0.1  # three sparse columns
    cache = progressive.ColumnCache()
    cache.most = 8
    for q in range(6):
        cache.add(q, columns[:, q], 1.0)
    sparse_bytes = 12 * int((columns[:, :3] != 0).sum())
    assert cache.nbytes == 3 * size * 8 + sparse_bytes
    shooting = rng.random((6, 3))
    for chosen in ([4, 0, 5, 2], [1, 2], [3, 5]):
        np.testing.assert_allclose(cache.shot(np.array(chosen), shooting[chosen], size),
                                   columns[:, chosen] @ shooting[chosen], rtol=1e-12, atol=0)
    cache.remove(0)
    cache.remove(4)
    assert cache.nbytes == 3 * size * 8 + sparse_bytes - 12 * int((columns[:, 0] != 0).sum())  # rows stay made
