"""Monte Carlo transport of the light not shot (core/montecarlo.py), against exact answers: the
furnace (X = E / (1 - rho)), the form factor of a square by the contour integral, the sides of a
two-sided card; and bake(monte_carlo_rays=...) against the converged bake of the same scene."""

import dataclasses
from types import SimpleNamespace

import numpy as np
import pytest

from core import Scene, bake
from core.mesh.discretize import discretize
from core.solve import gather as final_gather
from core.solve import montecarlo
from core.solve.montecarlo import MIN_HITS, cosine_directions, pools, read_pools, trace, trace_paths, uniform_points
from core.rays.visibility import Visibility
from core.transport.receivers import receiving_points
from tests.core.scenes import box, grid, lit_room, merge, quad, uniform


def rays_of(mesh) -> Visibility:
    front = mesh.front_patch_count
    return Visibility(mesh.patch_corners[:front], two_sided=mesh.back_of_front >= 0)


def test_cosine_directions_are_unit_and_cosine_distributed():
    """Malley's method: E[cos theta] = 2/3 and E[cos^2 theta] = 1/2 for the density cos / pi; a
    million samples put the means within 1e-3 (their standard deviation is 2.4e-4 and 2.2e-4).
    Unit to 1e-7: the angle's cosine and sine are taken in float32 (rounding 6e-8)."""
    normals = np.tile(np.array([[0.3, -0.5, 0.8]]) / np.linalg.norm([0.3, -0.5, 0.8]), (1_000_000, 1))
    directions = cosine_directions(normals, np.random.default_rng(1).random((len(normals), 2)))
    cosine = (directions * normals).sum(axis=1)
    np.testing.assert_allclose(np.linalg.norm(directions, axis=1), 1.0, rtol=0, atol=1e-7)
    assert cosine.min() >= 0
    assert abs(cosine.mean() - 2 / 3) < 1e-3 and abs((cosine**2).mean() - 0.5) < 1e-3


def test_cosine_directions_of_many_points_per_normal_are_those_of_each_point_alone():
    """Points (n, K, 2) about n normals: each normal's frame built once gives the directions its
    K points get one by one (n K, 2) about the normal repeated, to rounding. Not to the bit: the
    frame is applied by matrix products, whose sums of three products BLAS may round in another
    order (or fused) for (K, 3) than for (1, 3) rows, a few units in the last place of 1 (bit for
    bit on the machines this ran on until 2026-12-07, then 2.2e-16 apart on one whose OpenBLAS,
    NumPy 1.26.4's, chose other kernels)."""
    rng = np.random.default_rng(3)
    normals = rng.normal(size=(50, 3))
    normals /= np.linalg.norm(normals, axis=1)[:, None]
    uv = rng.random((50, 16, 2))
    np.testing.assert_allclose(cosine_directions(normals, uv).reshape(-1, 3),
                               cosine_directions(np.repeat(normals, 16, axis=0), uv.reshape(-1, 2)),
                               rtol=0, atol=4 * np.finfo(float).eps)


def test_uniform_points_lie_in_the_triangle_with_its_centroid_as_their_mean():
    corners = np.array([[[0.0, 0, 0], [2, 0, 0], [0, 1, 0]]] * 200_000)
    points = uniform_points(corners, np.random.default_rng(2).random((len(corners), 2)))
    assert (points[:, 0] >= 0).all() and (points[:, 1] >= 0).all() and (points[:, 0] / 2 + points[:, 1] <= 1).all()
    # the mean of 2e5 uniform points: standard deviation under 2e-3 per axis here
    np.testing.assert_allclose(points.mean(axis=0), [2 / 3, 1 / 3, 0], atol=1e-2)


@pytest.mark.parametrize("reflectance", [0.5, 0.9])
def test_particles_in_a_furnace_give_emission_over_one_minus_reflectance(reflectance):
    """A closed box, every patch emitting E = 2 unshot: X = E / (1 - rho) exactly. The total is
    exact but for Russian roulette; each patch's estimate has the noise of its ~2,000 particle
    visits (2 % at 1 / sqrt(2,000)), so 10 % per patch is 4 standard deviations and more, the
    area-weighted mean (~1e6 visits) within 1 %."""
    mesh = discretize(uniform(*box(), reflectance, 2.0), 0.25)
    unshot = np.full((mesh.patch_count, 3), 2.0)
    future = trace(mesh, rays_of(mesh), unshot, mesh.patch_reflectance, 200_000 * round(1 / (1 - reflectance)) // 2)
    expected = 2.0 / (1 - reflectance)
    mean = mesh.patch_areas @ future / mesh.patch_areas.sum()
    np.testing.assert_allclose(mean, expected, rtol=0.01)
    np.testing.assert_allclose(future, expected, rtol=0.10)
    assert np.allclose(future[:, 0], future[:, 1]) and np.allclose(future[:, 1], future[:, 2])


def test_the_view_importance_in_a_furnace_is_what_the_reflections_add_up_to():
    """A closed box of reflectance rho read evenly, v readings per unit area: power arriving
    anywhere adds Y = rho v + rho Z to the readings, and in a closed box Z = sum_j F_qj Y_j = Y, so
    Z = rho v / (1 - rho) exactly (3 at rho = 0.5, v = 3). Over four seeds the 432 patches' estimates
    spread 3.3 % (the largest 10 %), so 15 % is 4.5 standard deviations; their mean spread 0.2 %,
    so 1 % is 5."""
    mesh = discretize(uniform(*box(), 0.5, 0.0), 0.25)
    importance = montecarlo.view_importance(mesh, rays_of(mesh), 3.0 * mesh.patch_areas, mesh.patch_reflectance,
                                            200_000)
    np.testing.assert_allclose(mesh.patch_areas @ importance / mesh.patch_areas.sum(), 3.0, rtol=0.01)
    np.testing.assert_allclose(importance, 3.0, rtol=0.15)


def test_importons_cut_short_give_the_reflections_of_that_many_bounces(monkeypatch):
    """The furnace above at rho = 0.9, the importons cut after K = 8 bounces
    (``IMPORTON_BOUNCES``): the k-th landing adds rho v rho^(k - 1), so Z = rho v (1 - rho^K) /
    (1 - rho) = 15.377 (27 uncut). Over four seeds the 432 patches spread 2 % (the largest 6.5 %),
    so 10 % is 5 standard deviations; their mean spread 0.08 %, so 0.5 % is 6."""
    monkeypatch.setattr(montecarlo, "IMPORTON_BOUNCES", 8)
    mesh = discretize(uniform(*box(), 0.9, 0.0), 0.25)
    importance = montecarlo.view_importance(mesh, rays_of(mesh), 3.0 * mesh.patch_areas, mesh.patch_reflectance,
                                            200_000)
    expected = 0.9 * 3.0 * (1 - 0.9 ** 8) / (1 - 0.9)
    np.testing.assert_allclose(mesh.patch_areas @ importance / mesh.patch_areas.sum(), expected, rtol=0.005)
    np.testing.assert_allclose(importance, expected, rtol=0.10)


def test_the_view_importance_of_a_wall_is_what_its_light_adds_to_the_readings_traced_forwards():
    """The adjoint against the forward: in a box without its ceiling, walls of reflectance 0.2 to
    0.8, the floor read (V = A there), importons give each patch's Z; particles of unit power
    leaving one wall, traced forwards, add sum_j V_j (X_j - U_j) to the readings, which must be
    the area-weighted mean of Z over that wall. Both estimates from 200,000 paths: their ratio's
    spread is 0.5 % (five seeds), so 3 % is 6 standard deviations."""
    vertices, triangles = box()
    triangles = np.delete(triangles, [2, 3], axis=0)  # no ceiling: the sky
    reflectance = np.repeat([[0.8], [0.2], [0.4], [0.6], [0.5]], 2, axis=0) * np.ones(3)
    mesh = discretize(Scene(vertices, triangles, reflectance, np.zeros((10, 3))), 0.25)
    floor = mesh.patch_triangle < 2
    importance = montecarlo.view_importance(mesh, rays_of(mesh), np.where(floor, mesh.patch_areas, 0.0),
                                            mesh.patch_reflectance, 200_000)
    for wall in (1, 2, 3, 4):
        on_wall = (mesh.patch_triangle // 2) == wall
        area = mesh.patch_areas[on_wall].sum()
        unshot = np.where(on_wall, 1 / area, 0.0)[:, None] * np.ones(3)
        added = trace(mesh, rays_of(mesh), unshot, mesh.patch_reflectance, 200_000) - unshot
        readings = np.where(floor, mesh.patch_areas, 0.0) @ added[:, 0]
        np.testing.assert_allclose(mesh.patch_areas[on_wall] @ importance[on_wall] / area, readings, rtol=0.03)


def test_light_outside_a_closed_room_sends_only_the_power_share_of_its_particles_and_adds_no_bias():
    """A closed two-sided box read from inside only, its outside ten times as bright as its inside
    (unshot 20 against 2, reflectance 0.5): by power the inside would send 1/11 of the particles.
    No importon leaves the box, so the outside's importance is 0 and it sends POWER_SHARE of its
    power's share, the inside the rest: 1/22 + 1/2 of the particles (within one: systematic
    sampling). What arrives inside stays exact: X = 2 / (1 - 0.5) = 4 (the mean within 1 %, as in
    the furnace)."""
    vertices, triangles = box()
    scene = dataclasses.replace(uniform(vertices, triangles, 0.5, 0.0), two_sided=np.ones(len(triangles), bool))
    mesh = discretize(scene, 0.25)
    fronts = mesh.front_patch_count
    inside = np.arange(mesh.patch_count) < fronts
    viewed = np.where(inside, mesh.patch_areas, 0.0)
    importance = montecarlo.view_importance(mesh, rays_of(mesh), viewed, mesh.patch_reflectance, 100_000)
    assert (importance[~inside] == 0).all() and (importance[inside] > 0).all()
    unshot = np.where(inside, 2.0, 20.0)[:, None] * np.ones(3)
    particles = 200_000
    paths = trace_paths(mesh, rays_of(mesh), unshot, mesh.patch_reflectance, particles, importance=importance)
    sent_inside = (paths.sources < fronts).sum()
    assert abs(sent_inside - particles * (montecarlo.POWER_SHARE / 11 + 1 - montecarlo.POWER_SHARE)) <= 1
    future = paths.future(mesh, unshot, mesh.patch_reflectance)
    np.testing.assert_allclose(mesh.patch_areas[inside] @ future[inside] / mesh.patch_areas[inside].sum(), 4.0,
                               rtol=0.01)


def test_no_particle_leaves_a_patch_where_a_solid_passes_through_it_on_the_side_away_from_its_light():
    """A closed two-sided cube (reflectance 0.99) pushed halfway through a lit floor of two
    triangles, not cut along it: each floor patch straddles the cube, its receiving point (its
    centroid) outside. No light can reach the cube's inside, and no path can land there; but
    particles leaving the floor from uniform points start inside the cube too (4 % of the floor),
    and bounce there between its walls and the floor: 64 to 66 % of all landings over four seeds,
    most particles leaving for the sky at once. Given where the patches received their light, none
    leaves from a point the cube's walls part from it: no landing inside (about 700 outside)."""
    floor = quad([-1, -1, 0], [2, 0, 0], [0, 2, 0])
    cube_vertices, cube_triangles = box(0.4)
    vertices, triangles = merge(floor, (cube_vertices + [0.3, 0.3, -0.2], cube_triangles))
    scene = Scene(vertices, triangles, np.repeat([[0.5] * 3, [0.99] * 3], [2, 12], axis=0), np.zeros((14, 3)),
                  two_sided=np.ones(14, bool))
    mesh = discretize(scene, None, cut_contacts=False)
    lit = np.flatnonzero(mesh.patch_triangle[: mesh.front_patch_count] < 2)
    inside = np.flatnonzero(mesh.patch_triangle[: mesh.front_patch_count] >= 2)  # the cube faces inwards
    assert len(lit) == 2 and len(inside) == 12
    unshot = np.zeros((mesh.patch_count, 3))
    unshot[lit] = 1.0
    visibility = rays_of(mesh)
    receiving = receiving_points(mesh, visibility)
    np.testing.assert_allclose(receiving[lit, :2], [[1 / 3, -1 / 3], [-1 / 3, 1 / 3]])
    leaking = trace_paths(mesh, visibility, unshot, mesh.patch_reflectance, 20_000)
    assert np.isin(leaking.landings, inside).mean() > 0.5  # without: most landings are inside the cube
    paths = trace_paths(mesh, visibility, unshot, mesh.patch_reflectance, 20_000, receiving=receiving)
    assert len(paths.landings) > 100 and not np.isin(paths.landings, inside).any()  # the rest leave to the sky


def test_light_scaled_per_channel_reads_the_same_paths_with_their_power_scaled():
    """A light's colour or strength changed scales the unshot light by k per channel. The particles
    are chosen by each channel's share of the power, not its size, so the paths of U are those of
    U k, and reading them again gives trace(U k) = trace(U) k to rounding, even for channels 1e6
    apart (by the power summed over channels, the dim channel would be sampled by other particles)."""
    scene = lit_room()
    mesh = discretize(scene, 0.25)
    rng = np.random.default_rng(4)
    unshot = rng.random((mesh.patch_count, 3)) * (rng.random((mesh.patch_count, 1)) < 0.3)
    scale = np.array([1e-3, 1.0, 1e3])
    paths = trace_paths(mesh, rays_of(mesh), unshot, mesh.patch_reflectance, 20_000)
    before = paths.future(mesh, unshot, mesh.patch_reflectance)
    after = trace(mesh, rays_of(mesh), unshot * scale, mesh.patch_reflectance, 20_000)
    np.testing.assert_allclose(after, before * scale, rtol=1e-12, atol=0)
    assert paths.reusable(mesh, unshot * scale, mesh.patch_reflectance)
    np.testing.assert_allclose(paths.future(mesh, unshot * scale, mesh.patch_reflectance), after, rtol=1e-12, atol=0)


@pytest.fixture(scope="module")
def furnace_paths():
    """A closed box of reflectance 0.9 emitting 2 unshot everywhere, and 1,000,000 particles'
    paths traced in it."""
    mesh = discretize(uniform(*box(), 0.9, 2.0), 0.25)
    traced = np.full((mesh.patch_count, 3), 2.0)
    return mesh, traced, trace_paths(mesh, rays_of(mesh), traced, mesh.patch_reflectance, 1_000_000)


@pytest.mark.parametrize("reflectance", [[0.5, 0.5, 0.5], [0.3, 0.6, 0.85]])
def test_paths_traced_in_a_brighter_furnace_read_a_darker_one_exactly(furnace_paths, reflectance):
    """The paths of a furnace of reflectance 0.9 read with lower reflectances, grey or other in
    each channel (the weight of a particle that goes on multiplied by rho_c / 0.9): unbiased, so
    each channel's X = E / (1 - rho_c) as in the furnace above: the area-weighted mean within 1 %,
    each patch within 10 % (the noise grows with the bounces a channel keeps: 6.7 at 0.85)."""
    mesh, traced, paths = furnace_paths
    darker = np.tile(reflectance, (mesh.patch_count, 1))
    assert paths.reusable(mesh, traced, darker)
    future = paths.future(mesh, traced, darker)
    expected = 2.0 / (1 - np.array(reflectance))
    np.testing.assert_allclose(mesh.patch_areas @ future / mesh.patch_areas.sum(), expected, rtol=0.01)
    np.testing.assert_allclose(future, np.broadcast_to(expected, future.shape), rtol=0.10)


def test_paths_read_with_light_on_half_the_furnace_keep_its_total(furnace_paths):
    """Emission on the half of the furnace's patches left of its middle, reflectance 0.5: each of their particles
    carries its new share over its old chance, twice its power (the others carry none), so the
    total X = E / (1 - rho) holds, within 1 % as above. ``reusable`` refuses it all the same: the
    second moment of the power leaving, sum a^2 / p, is A / A_half = 2 times a fresh trace's, over
    REUSE_MOMENT = 1.25."""
    mesh, traced, paths = furnace_paths
    areas = mesh.patch_areas
    half = traced * (mesh.patch_centroids[:, :1] < 0.5)
    assert 0.45 < areas @ half[:, 0] / (areas @ traced[:, 0]) < 0.55
    grey = np.full_like(traced, 0.5)
    assert not paths.reusable(mesh, half, grey)
    np.testing.assert_allclose(areas @ paths.future(mesh, half, grey) / areas.sum(),
                               areas @ half / areas.sum() / (1 - 0.5), rtol=0.01)


def test_paths_read_again_weigh_each_landing_by_its_own_chain(monkeypatch):
    """``future`` against a walk back from every landing to its particle (what ``came_from``
    links), with the weights of the module docstring: power A_q U_q / (n p_q), times
    rho_j / (opacity_j s_j) at each patch it went on from, over opacity_j where it stops. In a
    room with a see-through block (opacity 0.6, two-sided), other colours per channel than those
    traced (some unshot light negative), blocks of 64 particles, so that the links cross blocks
    and bounces: equal to rounding."""
    monkeypatch.setattr(montecarlo, "PARTICLES_PER_BLOCK", 64)
    scene = lit_room()
    block = np.zeros(len(scene.triangles), dtype=bool)
    block[8:12] = True
    scene = dataclasses.replace(scene, two_sided=block, opacity=np.where(block, 0.6, 1.0),
                                reflectance=np.where(block[:, None], 0.5, scene.reflectance))
    mesh = discretize(scene, 0.25)
    front = mesh.front_patch_count
    visibility = Visibility(mesh.patch_corners[:front], two_sided=mesh.back_of_front >= 0,
                            owners=mesh.patch_triangle[:front], casting=mesh.front_casts, opacity=mesh.front_opacity)
    rng = np.random.default_rng(6)
    traced = rng.random((mesh.patch_count, 3))
    paths = trace_paths(mesh, visibility, traced, mesh.patch_reflectance, 3_000)
    assert len(paths.bounce_starts) > 4 and len(paths.sources) > 20 * 64
    unshot = traced * rng.uniform(-0.5, 2.0, traced.shape)
    reflectance = mesh.patch_reflectance * rng.uniform(0.2, 1.0, traced.shape)
    going_on = (paths.stops * paths.survival)[:, None]
    onward = np.divide(reflectance, going_on, out=np.zeros_like(reflectance), where=going_on > 0)
    landing = np.arange(len(paths.landings))
    depth = np.searchsorted(paths.bounce_starts, landing, side="right") - 1
    factor = np.ones((len(landing), 3))
    while (depth > 0).any():
        walking = np.flatnonzero(depth > 0)
        parent = paths.came_from[landing[walking]]
        factor[walking] *= onward[paths.landings[parent]]
        landing[walking], depth[walking] = parent, depth[walking] - 1
    source = paths.sources[paths.came_from[landing]]
    power = mesh.patch_areas[source, None] * unshot[source] / (paths.sampling[source, None] * len(paths.sources))
    brought = power * factor / paths.stops[paths.landings, None]
    arrived = np.stack([np.bincount(paths.landings, brought[:, c], minlength=mesh.patch_count) for c in range(3)], 1)
    expected = unshot + reflectance * read_pools(mesh, arrived, paths.pool)
    np.testing.assert_allclose(paths.future(mesh, unshot, reflectance), expected, rtol=1e-12, atol=1e-12)


def test_paths_are_traced_again_for_brighter_surfaces_and_light_they_never_carried():
    """Reading paths is unbiased only where a particle could go on (s_j > 0 where rho_j > 0) and
    could leave (p_q > 0 where U_q > 0); brighter surfaces would make particles' weights grow, and
    light moved to where few particles left would be sampled poorly: ``reusable`` refuses all three.
    Paths traced for a quarter of the patches lit and the rest at 1 %: that rest holds 3 % of the
    particles; lit evenly, it holds 3 / 4 of the power, and the second moment of the power
    leaving is 19 times a fresh trace's."""
    mesh = discretize(uniform(*box(), 0.5, 2.0), 0.25)
    quarter = np.zeros((mesh.patch_count, 3))
    quarter[: mesh.patch_count // 4] = 1.0
    dim_rest = np.maximum(quarter, 0.01)
    paths = trace_paths(mesh, rays_of(mesh), dim_rest, mesh.patch_reflectance, 10_000)
    assert paths.reusable(mesh, dim_rest * [1.0, 2.0, 3.0], mesh.patch_reflectance * 0.5)
    assert not paths.reusable(mesh, dim_rest, mesh.patch_reflectance * 1.1)
    assert not paths.reusable(mesh, np.ones_like(dim_rest), mesh.patch_reflectance)
    assert not trace_paths(mesh, rays_of(mesh), quarter, mesh.patch_reflectance, 10_000).reusable(
        mesh, dim_rest, mesh.patch_reflectance)


def gridded_box(cells: int = 8) -> Scene:
    """A closed unit box of reflectance 0.8, each face split in cells x cells squares (642 nodes),
    a strip of its ceiling emitting."""
    faces = [grid([0, 0, 0], [1, 0, 0], [0, 1, 0], cells), grid([0, 0, 1], [0, 1, 0], [1, 0, 0], cells),
             grid([0, 0, 0], [0, 1, 0], [0, 0, 1], cells), grid([1, 0, 0], [0, 0, 1], [0, 1, 0], cells),
             grid([0, 0, 0], [0, 0, 1], [1, 0, 0], cells), grid([0, 1, 0], [1, 0, 0], [0, 0, 1], cells)]
    vertices, triangles = merge(*faces)
    emission = np.zeros((len(triangles), 3))
    per_face = len(triangles) // 6
    emission[per_face:per_face + per_face // 4] = [5.0, 4.0, 3.0]
    return Scene(vertices, triangles, np.full((len(triangles), 3), 0.8), emission)


def test_gathering_the_noisy_nodes_again_lowers_the_noise_and_adds_no_bias(monkeypatch):
    """Four seeds of Monte Carlo with 16 gather rays in a closed box of reflectance 0.8, against
    the same bake with 1,024 rays (4,096 gives the same numbers to 0.02 %: converged; the bake shot
    to convergence reads the patches next to a node otherwise, by the near field, 2.3 % from it).
    Gathering again with 49 rays more the nodes holding 90 % of the predicted variance lowers the
    error: from 2.27 to 1.74 % over seeds 0 to 3 (0.77 of it; 0.78 and 0.80 over seeds 4 to 7 and 8
    to 11; were the error all noise at those nodes, 0.57). The mean of the four is off by 0.65 to
    0.71 of a single bake's error without it (pure noise gives 1 / sqrt(4): the 16-ray bakes share
    a bias against the 1,024-ray one, their pools blurring more) and gathering again must not take
    it farther (over the three groups of seeds it brings it nearer: 1.31 to 1.44 % of the light
    against 1.45 to 1.60 %). The first bound leaves 0.05 above the worst group."""
    scene = gridded_box()
    knobs = dict(patch_size=0.2, rays_per_form_factor=4, tolerance=1e-6)
    converged = bake(scene, **knobs, monte_carlo_rays=1024).corner_colors
    scale = np.sqrt((converged ** 2).mean())
    errors, means = {}, {}
    for share in (0.0, final_gather.REGATHER_SHARE):
        monkeypatch.setattr(final_gather, "REGATHER_SHARE", share)
        colours = [bake(scene, **knobs, monte_carlo_rays=16, seed=seed).corner_colors for seed in range(4)]
        errors[share] = np.mean([np.sqrt(((c - converged) ** 2).mean()) / scale for c in colours])
        means[share] = np.sqrt(((np.mean(colours, axis=0) - converged) ** 2).mean()) / scale
    assert errors[final_gather.REGATHER_SHARE] <= 0.85 * errors[0.0]
    assert means[final_gather.REGATHER_SHARE] <= means[0.0]


def emitting_patches(scene) -> int:
    return int(discretize(scene, scene.extent / 8).patch_emission.any(axis=1).sum())


@pytest.mark.parametrize("rays", [256, 1024])
def test_the_remainder_by_monte_carlo_converges_to_the_shot_answer_and_its_estimate_bounds_the_error(
        rays, monkeypatch):
    """lit_room (an open room, a floating plate, coloured walls): after the light's own shots the
    rest goes by Monte Carlo. Against the same bake shot to convergence (tolerance 1e-6), the
    error is within the bake's own estimate, and four times more rays halve it (within noise:
    at most 0.7 times), the final gather made once (REGATHER_SHARE 0: its second pass gives some
    bakes 4 times the rays at their noisiest nodes and not others)."""
    monkeypatch.setattr(final_gather, "REGATHER_SHARE", 0.0)
    scene = lit_room()
    converged = bake(scene, tolerance=1e-6)
    errors = {}
    for count in (rays // 4, rays):
        result = bake(scene, monte_carlo_rays=count)
        quiet = ~scene.emission.any(axis=1)
        difference = result.corner_colors[quiet] - converged.corner_colors[quiet]
        errors[count] = np.sqrt((difference**2).mean()) / np.abs(converged.corner_colors[quiet]).mean()
        assert result.stats["error_estimate"]["total"] >= errors[count], (count, result.stats["error_estimate"])
        assert result.stats["shots"] == emitting_patches(scene)  # the light's patches, then Monte Carlo
        assert result.stats["monte_carlo"]["gather_rays"] == count
    assert errors[rays] <= 0.7 * errors[rays // 4], errors


@pytest.mark.parametrize("factor", [1e-4, 1e4])
def test_the_remainder_is_the_same_at_another_scale_up_to_a_sliver_of_its_noise(factor):
    """Particles and gather rays are traced in the unit space of ``visibility`` from the same
    random numbers, so a scaled scene repeats the bake but for the rare path that float32
    rounding sends to the other side of an edge: measured 3e-4 of the largest colour at 1e-4
    and 1e4 against an estimated noise of 4.4 %; a tenth of the estimate in RMS still fails any
    scale-dependent offset, which would move every value."""
    reference = bake(lit_room(), monte_carlo_rays=64)
    other = bake(Scene(lit_room().vertices * factor, lit_room().triangles, lit_room().reflectance,
                       lit_room().emission), monte_carlo_rays=64)
    difference = np.sqrt(((other.corner_colors - reference.corner_colors) ** 2).mean())
    assert difference <= 0.1 * reference.stats["error_estimate"]["unshot"] * np.abs(reference.corner_colors).mean()


def test_with_the_hemicube_the_nodes_gather_the_traced_patches_and_the_estimate_stays_the_unshot_bound():
    """The hemicube's nodes gather patch radiosity by hemicube, so the remainder reaches them
    through the traced patches: within 2 % of the converged hemicube bake (measured 0.6 % at 256
    rays), and the solver's part of the estimate is still the (larger) bound on the light the
    shots left, not the final gather's noise."""
    scene = lit_room()
    quiet = ~scene.emission.any(axis=1)
    converged = bake(scene, "hemicube", tolerance=1e-6)
    result = bake(scene, "hemicube", monte_carlo_rays=256)
    difference = result.corner_colors[quiet] - converged.corner_colors[quiet]
    error = np.sqrt((difference**2).mean()) / np.abs(converged.corner_colors[quiet]).mean()
    assert error <= 0.02
    assert result.stats["error_estimate"]["unshot"] >= result.stats["unshot_fraction"]


@pytest.mark.parametrize("rays", [2, 15, -4])
def test_monte_carlo_rays_must_be_a_perfect_square(rays):
    with pytest.raises(ValueError, match="perfect square"):
        bake(lit_room(), monte_carlo_rays=rays)


def test_after_refinement_the_new_patches_count_only_the_light_already_shot():
    """With Monte Carlo, refining after the emitters' shots leaves most of the light unshot. The
    new patches must start from what was shot (B - U), or that unshot light reaches them twice, now
    and by Monte Carlo: 6.8 % off the converged refined bake that way on lit_room, 0.8 % right
    (the two refine slightly different patches, 1,256 and 1,325, and 256 rays leave ~0.9 % of
    noise: 3 % separates the two)."""
    scene = lit_room()
    quiet = ~scene.emission.any(axis=1)
    converged = bake(scene, tolerance=1e-6, refinement_levels=1)
    result = bake(scene, monte_carlo_rays=256, refinement_levels=1)
    difference = result.corner_colors[quiet] - converged.corner_colors[quiet]
    assert np.sqrt((difference**2).mean()) <= 0.03 * np.abs(converged.corner_colors[quiet]).mean()


def patches(centroids, normals, areas, fronts: int | None = None) -> SimpleNamespace:
    """What ``pools`` and ``read_pools`` read of a Discretization: the first ``fronts`` patches
    (None: all) front sides, the rest the backs of two-sided triangles."""
    return SimpleNamespace(patch_centroids=np.asarray(centroids, float),
                           patch_normals=np.asarray(normals, float), patch_areas=np.asarray(areas, float),
                           front_patch_count=len(areas) if fronts is None else fronts)


def pooled(mesh, arrived: np.ndarray, hits: np.ndarray) -> np.ndarray:
    """(P, C) the power ``arrived`` per unit area read over the pools of ``hits``."""
    return read_pools(mesh, arrived, pools(mesh, hits))


def test_pools_keep_the_power_that_arrived_and_a_patch_with_enough_hits_reads_its_own():
    """Pooling only moves power between patches of a pool: the total power (sum of W / A times A)
    is what arrived, per channel; a patch that MIN_HITS particles reached is read alone, W / A."""
    rng = np.random.default_rng(3)
    normals = np.eye(3)[rng.integers(0, 3, 500)] * rng.choice([-1, 1], (500, 1))
    mesh = patches(rng.random((500, 3)), normals, rng.random(500) ** 4 * 0.01)
    hits = rng.poisson(30 * mesh.patch_areas / mesh.patch_areas.mean()).astype(float)
    arrived = hits[:, None] * rng.random((500, 2))
    density = pooled(mesh, arrived, hits)
    assert np.allclose((density * mesh.patch_areas[:, None]).sum(axis=0), arrived.sum(axis=0), rtol=1e-12)
    alone = hits >= MIN_HITS
    assert 0 < alone.sum() < 500
    assert np.allclose(density[alone], arrived[alone] / mesh.patch_areas[alone, None], rtol=1e-12)


def test_pools_of_tiny_patches_in_an_even_light_read_it_within_a_pools_noise():
    """400 patches of a plane, each reached by a Poisson number of particles of unit power at a
    density of 1 per patch: alone, W / A is off by 100 % RMS (a Poisson count of mean 1); pooled
    to MIN_HITS hits, by about 1 / sqrt(MIN_HITS), and by no more than 1.5 times that."""
    side = np.arange(20) / 20
    x, y = np.meshgrid(side, side)
    mesh = patches(np.stack([x.ravel(), y.ravel(), np.zeros(400)], axis=1), np.tile([0.0, 0.0, 1.0], (400, 1)),
                   np.full(400, 1 / 400))
    hits = np.random.default_rng(5).poisson(1.0, 400).astype(float)
    true = 400.0  # expected power per unit area: 1 particle per patch of area 1 / 400
    alone = np.sqrt(((hits * 400 - true) ** 2).mean()) / true
    error = np.sqrt(((pooled(mesh, hits[:, None], hits)[:, 0] - true) ** 2).mean()) / true
    assert alone > 0.8 and error < 1.5 / np.sqrt(MIN_HITS), (alone, error)


def test_a_lit_ledge_is_not_pooled_with_faces_a_step_behind_it_in_shadow():
    """Sponza's gallery tops in miniature: a row of small faces lit by the sky (16 hits between
    them, at least MIN_HITS) and, a third of a pool cell behind, larger faces turned the same way that no particle
    reaches. The lit row's pool is the row: its power over its own area. (Pooled by area over
    the cell, the row read 1/11 of that; on Sponza such pools left the tops 0.5 darker than path
    tracing.)"""
    along = np.linspace(0, 0.2, 8)
    lit = np.stack([along, np.full(8, 0.1), np.zeros(8)], axis=1)
    dark = np.stack([along, np.zeros(8), np.full(8, 0.02)], axis=1)
    mesh = patches(np.concatenate([lit, dark]), np.tile([0.0, 1.0, 0.0], (16, 1)),
                   np.concatenate([np.full(8, 0.001), np.full(8, 0.01)]))
    hits = np.concatenate([np.full(8, 2.0), np.zeros(8)])
    density = pooled(mesh, hits[:, None], hits)[:, 0]
    assert np.allclose(density[:8], 16 / 0.008, rtol=1e-12)
    assert np.allclose(density[8:], 0.0)


def test_a_thick_plate_s_lit_top_is_not_pooled_with_the_plate_s_inside():
    """The breakfast room's crockery in miniature, two-sided as Blender shades it: a plate 3 mm
    thick, its top's front patches lit (2 hits each, MIN_HITS between them) and, 3 mm below, the
    backs of its bottom's patches, turned up too but inside the plate, where no particle goes.
    The top's pool is the top: its power over its own area. (Pooled across sides, the top read
    half of it, and the room's cups, plates and cutlery 5 to 11 % dark: docs/notes/experiments.md,
    "Our bake against Cycles in an interior".)"""
    along = np.linspace(0, 0.2, 8)
    top = np.stack([along, np.zeros(8), np.full(8, 0.003)], axis=1)
    inside = np.stack([along, np.zeros(8), np.zeros(8)], axis=1)
    mesh = patches(np.concatenate([top, inside]), np.tile([0.0, 0.0, 1.0], (16, 1)), np.full(16, 0.001), fronts=8)
    hits = np.concatenate([np.full(8, 2.0), np.zeros(8)])
    density = pooled(mesh, hits[:, None], hits)[:, 0]
    assert np.allclose(density[:8], 16 / 0.008, rtol=1e-12)
    assert np.allclose(density[8:], 0.0)


def test_pools_finished_in_different_rounds_stay_apart():
    """Two far-apart groups of patches in one plane: one has MIN_HITS hits within the first cell,
    the other never has them and grows until its cell spans the scene. Each reads its own power
    over its own area (the pools were once numbered per round, so these two shared one pool)."""
    near = np.array([[0.0, 0.0, 0.0], [0.05, 0.0, 0.0], [0.0, 0.05, 0.0], [0.05, 0.05, 0.0]])
    mesh = patches(np.concatenate([near, near + [5.0, 5.0, 0.0]]), np.tile([0.0, 0.0, 1.0], (8, 1)),
                   np.full(8, 0.01))
    hits = np.array([5.0, 5, 5, 5, 1, 1, 1, 1])
    density = pooled(mesh, hits[:, None], hits)[:, 0]
    assert np.allclose(density[:4], 20 / 0.04, rtol=1e-12)
    assert np.allclose(density[4:], 4 / 0.04, rtol=1e-12)


def test_emitters_that_reflect_shoot_once_each_then_monte_carlo_carries_the_rest():
    """A closed room whose two opposite walls emit and reflect (rho 0.5, as an emissive Principled
    BSDF does): every shot lights the emitters again, so "shoot until no emitter has light left"
    would shoot until the solve converged. Each emitting patch shoots its own light once, then the
    rest goes by Monte Carlo: the shots are the emitting patches, and the colours are within the
    solver's share of the bake's own error estimate (the Monte Carlo noise; the two bakes share
    their patches) of the bake shot to convergence (measured 0.27 % against 1.0 %; 196 shots
    against 13,296)."""
    vertices, triangles = box()
    emission = np.zeros((12, 3))
    emission[4:8] = [2.0, 1.5, 1.0]  # the walls x = 0 and x = 1, facing each other
    reflectance = np.full((12, 3), 0.5)
    reflectance[8:] = [0.7, 0.6, 0.5]
    scene = Scene(vertices, triangles, reflectance, emission)
    converged = bake(scene, tolerance=1e-6)
    result = bake(scene, monte_carlo_rays=256)
    assert result.stats["shots"] == emitting_patches(scene) < converged.stats["shots"]
    colors, exact = result.corner_colors.reshape(-1, 3), converged.corner_colors.reshape(-1, 3)
    error = np.sqrt(((colors - exact) ** 2).mean()) / np.abs(exact).mean()
    assert error <= result.stats["error_estimate"]["unshot"], (error, result.stats["error_estimate"])


def test_no_light_is_negative_where_a_noisy_gather_meets_the_near_field():
    """A column standing on a lit floor, baked with a 16-ray final gather: at the contact corners
    the gather's estimate of the light from the patches next to a vertex can fall short of what
    their exact near form factors say they send, and the near field's correction (which takes that
    constant part out to put the patches' linear interpolant in) then went negative on two of these
    six seeds. Light is never negative: every corner colour is >= 0 on each seed."""
    s, h, a, b = 4.0, 2.0, 1.6, 2.4
    column = merge(quad([a, a, 0], [0, 0, h], [b - a, 0, 0]), quad([b, a, 0], [0, 0, h], [0, b - a, 0]),
                   quad([b, b, 0], [0, 0, h], [a - b, 0, 0]), quad([a, b, 0], [0, 0, h], [0, a - b, 0]),
                   quad([a, a, h], [b - a, 0, 0], [0, b - a, 0]))
    vertices, triangles = merge(grid([0, 0, 0], [s, 0, 0], [0, s, 0], 6), column,
                                quad([0.5, 0.5, 3.0], [0, 1.0, 0], [1.0, 0, 0]))
    count = len(triangles)
    reflectance, emission = np.full((count, 3), 0.7), np.zeros((count, 3))
    reflectance[-2:], emission[-2:] = 0.0, 20.0
    scene = Scene(vertices, triangles, reflectance, emission, two_sided=np.ones(count, bool))
    for seed in range(6):
        assert bake(scene, monte_carlo_rays=16, seed=seed, patch_size=0.5).corner_colors.min() >= 0, seed
