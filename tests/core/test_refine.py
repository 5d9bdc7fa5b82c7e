"""Adaptive subdivision (core/refine.py), resuming a solve on refined patches, and where partly
buried patches receive (core/receivers.py)."""

import importlib

import numpy as np
import pytest

from core import Scene, bake
from core.transport import receivers
from core.mesh import refine
from core.mesh.discretize import discretize
from core.transport.formfactors import FormFactorEngine
from core.util.geometry import barycentric_grid, tangent_frames
from core.transport.receivers import receiving_points
from tests.core.scenes import box, lit_room, merge, quad


def test_split_keeps_area_orientation_and_backs():
    """Children tile their parent exactly (areas sum to it, same normal), backs are split with
    their fronts and stay mirror images, and every patch knows where it came from."""
    scene = lit_room()
    two_sided = Scene(scene.vertices, scene.triangles, scene.reflectance, scene.emission,
                      two_sided=np.ones(len(scene.triangles), dtype=bool))
    mesh = discretize(two_sided, two_sided.extent / 4)
    chosen = np.arange(0, mesh.front_patch_count, 3)
    refined, origin = refine.split(mesh, chosen)
    assert refined.front_patch_count == mesh.front_patch_count + 3 * len(chosen)
    assert refined.patch_count == mesh.patch_count + 6 * len(chosen)
    np.testing.assert_allclose(np.bincount(origin, weights=refined.patch_areas, minlength=mesh.patch_count),
                               mesh.patch_areas, rtol=1e-12)
    np.testing.assert_array_equal(refined.patch_normals, mesh.patch_normals[origin])
    recomputed = np.cross(refined.patch_corners[:, 1] - refined.patch_corners[:, 0],
                          refined.patch_corners[:, 2] - refined.patch_corners[:, 0])
    assert ((recomputed * refined.patch_normals).sum(axis=1) > 0).all()
    fronts = np.flatnonzero(refined.back_of_front >= 0)
    np.testing.assert_array_equal(refined.patch_corners[refined.back_of_front[fronts]],
                                  refined.patch_corners[fronts][:, ::-1])
    assert (np.diff(refined.patch_triangle[: refined.front_patch_count]) >= 0).all()


def test_jumps_compare_neighbours_on_the_same_surface_only():
    """Two coplanar triangles sharing an edge see each other's radiosity; a perpendicular
    wall touching them does not count, however different its radiosity."""
    floor = quad([0, 0, 0], [1, 0, 0], [0, 1, 0])
    wall = quad([0, 0, 0], [0, 1, 0], [0, 0, 1])
    vertices, triangles = merge(floor, wall)
    scene = Scene(vertices, triangles, np.full((4, 3), 0.5), np.zeros((4, 3)))
    mesh = discretize(scene)
    radiosity = np.array([[1.0], [1.25], [9.0], [9.0]])
    np.testing.assert_allclose(refine.radiosity_jumps(mesh, radiosity, np.radians(30)), [0.25, 0.25, 0.0, 0.0])


def open_room() -> Scene:
    """lit_room without its floating plate: nothing occludes, so ray-cast form factors are the
    exact contour integrals whatever the patches' sample points."""
    scene = lit_room()
    keep = np.r_[0:8, 12:14]
    return Scene(scene.vertices, scene.triangles[keep], scene.reflectance[keep], scene.emission[keep])


@pytest.mark.parametrize("solver", ["progressive", "jacobi"])
def test_a_resumed_solve_matches_a_fresh_solve_of_the_refined_patches(solver, monkeypatch):
    """Refining then resuming must reach the answer of solving the refined patches from scratch:
    with exact form factors (no occluder) only the stopping points (tolerance 1e-7) and rays
    grazing the room's inner edges differ: the parents' level-0 shots sampled visibility at
    other points than their children's (measured 0.2 % at worst, on a dark corner, with every
    ray cast; with probe rays first, a grazing probe's verdict stands for its whole source:
    0.6 %).
    (The hemicube's form factors from a parent are not the sum of its children's, so there a
    resumed solve differs from a fresh one by the hemicube's aliasing.)"""
    scene, method = open_room(), "raycast"
    resumed = bake(scene, method, solver, refinement_levels=1, tolerance=1e-7, probe_rays=False)
    assert resumed.stats["refinements"] and resumed.stats["refinements"][0]["split"] > 0
    # the fresh solve: discretise straight to the resumed bake's final patches
    bake_module = importlib.import_module("core.bake")
    levels = {}
    original_split = refine.split

    def remember(mesh, chosen):
        levels["refined"] = original_split(mesh, chosen)
        return levels["refined"]

    monkeypatch.setattr(refine, "split", remember)
    bake(scene, method, solver, refinement_levels=1, tolerance=1e-7, probe_rays=False)
    refined_mesh = levels["refined"][0]
    monkeypatch.setattr(bake_module, "discretised", lambda *_args, **_kwargs: (refined_mesh, None))
    fresh = bake(scene, method, solver, refinement_levels=0, tolerance=1e-7, probe_rays=False)
    np.testing.assert_allclose(resumed.corner_colors, fresh.corner_colors, rtol=5e-3)


def test_a_patch_under_a_block_receives_where_it_can_be_seen():
    """A closed box standing on a floor covers part of some floor patches (the floor not cut
    along the box's footprint, as happens when the box floats a hair above it): exactly those
    whose test points (the centroids of their strata, ``receivers.SAMPLE_DIVISIONS`` per side) are
    partly under the box receive at one of their test points outside the box's footprint; every
    other patch at its centroid."""
    floor = quad([-1, -1, 0], [2, 0, 0], [0, 2, 0])
    vertices, triangles = box(0.5)  # [0, 0.5]^3 facing inwards: flip it to face out
    block = (vertices + [0.2, 0.2, 0.0], triangles[:, ::-1])
    vertices, triangles = merge(floor, block)
    count = len(triangles)
    scene = Scene(vertices, triangles, np.full((count, 3), 0.5), np.zeros((count, 3)))
    mesh = discretize(scene, 0.3, cut_contacts=False)
    points = receiving_points(mesh, FormFactorEngine(mesh).visibility)
    on_floor = np.flatnonzero(mesh.patch_triangle < 2)
    inside = lambda p: (p[..., 0] > 0.2) & (p[..., 0] < 0.7) & (p[..., 1] > 0.2) & (p[..., 1] < 0.7)
    weights, cells = barycentric_grid(receivers.SAMPLE_DIVISIONS)
    tests = np.einsum("sb,pbx->psx", weights[cells].mean(axis=1), mesh.patch_corners)
    under = inside(tests)
    partly = np.zeros(mesh.patch_count, dtype=bool)
    partly[on_floor] = under[on_floor].any(axis=1) & ~under[on_floor].all(axis=1)
    assert partly.sum() >= 4
    np.testing.assert_array_equal(points[~partly], mesh.patch_centroids[~partly])
    for patch in np.flatnonzero(partly):
        chosen = np.flatnonzero(np.abs(tests[patch] - points[patch]).max(axis=1) <= 1e-12)
        assert len(chosen) == 1 and not under[patch, chosen[0]]


def test_burial_probes_agree_with_casting_every_ring_ray():
    """The buried test casts the ring of probes only where the ray along the normal met a back:
    the same verdict, point by point, as casting all seven probes everywhere (the definition, cast
    here by brute force), on a floor under a closed block standing on it (not cut along its
    footprint), a one-sided open box (no bottom) hovering over it, and a two-sided card."""
    floor = quad([-1, -1, 0], [2, 0, 0], [0, 2, 0])
    vertices, triangles = box(0.5)
    block = (vertices + [0.2, 0.2, 0.0], triangles[:, ::-1])
    open_vertices, open_triangles = box(0.4)
    keep = ~(open_vertices[open_triangles][:, :, 2] == 0).all(axis=1)  # drop the bottom
    open_box = (open_vertices + [-0.8, -0.8, 0.05], open_triangles[keep][:, ::-1])
    card = quad([0.0, -0.9, 0.0], [0.5, 0, 0], [0, 0, 0.5])
    vertices, triangles = merge(floor, block, open_box, card)
    count = len(triangles)
    two_sided = np.zeros(count, dtype=bool)
    two_sided[-2:] = True
    scene = Scene(vertices, triangles, np.full((count, 3), 0.5), np.zeros((count, 3)), two_sided=two_sided)
    mesh = discretize(scene, 0.3, cut_contacts=False)
    visibility = FormFactorEngine(mesh).visibility
    weights, cells = barycentric_grid(receivers.SAMPLE_DIVISIONS)
    points = np.einsum("sb,pbx->psx", weights[cells].mean(axis=1), mesh.patch_corners)
    normals = mesh.patch_normals
    tangent, bitangent = tangent_frames(normals)
    angles = 2 * np.pi * np.arange(receivers.RING) / receivers.RING
    ring = (np.cos(receivers.PROBE_ANGLE) * normals[:, None]
            + np.sin(receivers.PROBE_ANGLE) * (np.cos(angles)[None, :, None] * tangent[:, None]
                                                + np.sin(angles)[None, :, None] * bitangent[:, None]))
    directions = np.concatenate([normals[:, None], ring], axis=1)  # (P, 7, 3)
    samples, probes = points.shape[1], directions.shape[1]
    rays = np.repeat(directions[:, None], samples, axis=1).reshape(-1, 3)
    hit = visibility.nearest(np.repeat(points.reshape(-1, 3), probes, axis=0), rays,
                             np.repeat(normals, samples * probes, axis=0))
    index = np.maximum(hit, 0)
    back = (hit >= 0) & ((rays * visibility.triangle_normals[index]).sum(axis=1) > 0) & ~visibility.two_sided[index]
    expected = back.reshape(len(points), samples, probes).all(axis=2)
    assert expected.sum() > 50 and (~expected).sum() > 50  # both verdicts occur
    np.testing.assert_array_equal(receivers.buried(points, normals, visibility), expected)


def test_where_no_ray_can_meet_a_back_no_patch_is_buried_and_no_probe_is_cast():
    """The block on the floor of the test above with every face two-sided (the block's inside is
    a surface like any other), and a one-sided room (every wall has the whole scene in front of
    it) around a two-sided card: every patch receives at its centroid, and the burial test casts
    no ray. The block one-sided on the floor casts them (one along the normal per test point)."""
    floor = quad([-1, -1, 0], [2, 0, 0], [0, 2, 0])
    vertices, triangles = box(0.5)
    on_floor = merge(floor, (vertices + [0.2, 0.2, 0.0], triangles[:, ::-1]))
    in_room = merge(box(), quad([0.2, 0.5, 0.2], [0.6, 0, 0], [0, 0, 0.6]))
    cases = {"two-sided block": (on_floor, np.ones(len(on_floor[1]), bool)),
             "one-sided room": (in_room, np.arange(len(in_room[1])) >= 12),
             "one-sided block": (on_floor, np.zeros(len(on_floor[1]), bool))}
    casts = {}
    for name, ((vertices, triangles), two_sided) in cases.items():
        count = len(triangles)
        scene = Scene(vertices, triangles, np.full((count, 3), 0.5), np.zeros((count, 3)), two_sided=two_sided)
        mesh = discretize(scene, 0.7, cut_contacts=False)
        visibility = FormFactorEngine(mesh).visibility
        before = visibility.rays_cast
        points = receiving_points(mesh, visibility)
        casts[name] = visibility.rays_cast - before
        if name != "one-sided block":
            np.testing.assert_array_equal(points, mesh.patch_centroids)
    assert casts["two-sided block"] == casts["one-sided room"] == 0
    assert casts["one-sided block"] >= receivers.SAMPLE_DIVISIONS ** 2 * mesh.front_patch_count
