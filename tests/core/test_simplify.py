"""Flat regions merged into panels (core.mesh.panels, bake(merge_flat=True)): the panels tile each
region exactly, every input corner is found on them, and bakes keep their exact answers."""

from __future__ import annotations

import numpy as np
import pytest

from core import Scene, bake
from core.transport.analytic import point_to_triangle
from core.mesh.discretize import discretize
from core.util.geometry import areas_and_normals, barycentric_grid
from core.mesh.panels import _collapses, panels
from tests.core.scenes import box, grid, merge, quad, uniform

# The unit cube's faces as (corner, u, v), facing inwards (u x v), in box()'s order.
INWARD_FACES = (([0, 0, 0], [1, 0, 0], [0, 1, 0]), ([0, 0, 1], [0, 1, 0], [1, 0, 0]),
                ([0, 0, 0], [0, 1, 0], [0, 0, 1]), ([1, 0, 0], [0, 0, 1], [0, 1, 0]),
                ([0, 0, 0], [0, 0, 1], [1, 0, 0]), ([0, 1, 0], [1, 0, 0], [0, 0, 1]))


def l_shaped_floor_and_wall(cells: int = 12) -> Scene:
    """A floor split cells x cells with one quarter left out (an L: one reflex corner), and a
    wall split the same way standing on its edge; two materials."""
    vertices, triangles = grid([0, 0, 0], [1, 0, 0], [0, 1, 0], cells)
    centres = vertices[triangles].mean(axis=1)
    triangles = triangles[~((centres[:, 0] > 0.5) & (centres[:, 1] > 0.5))]
    wall = grid([0, 0, 0], [0, 0, 1], [0, 1, 0], cells)  # x = 0, faces +x
    vertices, triangles = merge((vertices, triangles), wall)
    count = len(triangles)
    on_wall = np.arange(count) >= count - 2 * cells**2
    reflectance = np.where(on_wall[:, None], [0.6, 0.2, 0.2], [0.5, 0.5, 0.5])
    return Scene(vertices, triangles, reflectance, np.zeros((count, 3)), material=on_wall.astype(int))


def test_panels_tile_each_flat_region_and_hold_every_input_corner():
    scene = l_shaped_floor_and_wall()
    size = 0.3
    result = panels(scene, size)
    merged = result.scene
    assert len(merged.triangles) < len(scene.triangles) / 4
    input_corners = scene.vertices[scene.triangles]
    panel_corners = merged.vertices[merged.triangles]
    input_areas, input_normals = areas_and_normals(input_corners)
    panel_areas, panel_normals = areas_and_normals(panel_corners)
    for material in (0, 1):  # each region keeps its area, its plane's orientation
        assert panel_areas[merged.material == material].sum() == pytest.approx(
            input_areas[scene.material == material].sum(), rel=1e-12)
        np.testing.assert_allclose(panel_normals[merged.material == material],
                                   np.broadcast_to(input_normals[scene.material == material][0],
                                                   panel_normals[merged.material == material].shape), atol=1e-12)
    edges = np.linalg.norm(panel_corners - panel_corners[:, [1, 2, 0]], axis=2)
    assert edges.max() <= size + 1e-12
    # every panel vertex is an input vertex; the L's reflex corner stays one
    distance = np.linalg.norm(merged.vertices[:, None] - scene.vertices[None], axis=2).min(axis=1)
    assert distance.max() <= 1e-12
    assert np.linalg.norm(merged.vertices - [0.5, 0.5, 0.0], axis=1).min() <= 1e-12
    # each input corner: in a panel of its own material, at the position its weights give
    weights = result.corner_weights
    assert (weights >= 0).all() and np.allclose(weights.sum(axis=2), 1.0, atol=1e-12)
    found = np.einsum("tkc,tkcx->tkx", weights, panel_corners[result.corner_panel])
    np.testing.assert_allclose(found, input_corners, atol=1e-12)
    assert (merged.material[result.corner_panel] == scene.material[:, None]).all()
    # and values at the panel corners come back exactly where the input corners are panel corners
    values = panel_corners[..., :1] * 0 + panel_corners.sum(axis=2, keepdims=True)  # x + y + z, linear
    np.testing.assert_allclose(result.to_corners(values)[..., 0], input_corners.sum(axis=2), atol=1e-12)


def test_a_mesh_with_nothing_to_merge_has_no_panels():
    vertices, triangles = box()
    assert panels(uniform(vertices, triangles, 0.5, 0.0), 0.25) is None


def test_a_block_on_a_merged_floor_cuts_its_patches_and_darkens_only_its_footprint():
    """A closed block standing on a fine floor under an emitter: the floor merges into panels
    across the block's footprint, but its patches are cut along the contact lines (none
    straddles them), the floor's vertices strictly inside the footprint bake to exactly 0 (they
    see only the inside of the block) and those outside it do not."""
    floor = grid([0, 0, 0], [1, 0, 0], [0, 1, 0], 10)
    block_vertices, block_triangles = box(0.33)
    low = np.array([0.31, 0.26, 0.0])  # no grid vertex on its outline
    block = (block_vertices + low, block_triangles[:, ::-1])  # outward-facing cube
    light = quad([0.25, 0.25, 1.0], [0, 0.5, 0], [0.5, 0, 0])
    vertices, triangles = merge(floor, block, light)
    count = len(triangles)
    emitting = np.arange(count) >= count - 2
    scene = Scene(vertices, triangles, np.full((count, 3), 0.5), np.where(emitting[:, None], 5.0, 0.0) * np.ones(3))
    merged = panels(scene, 0.4)
    assert len(merged.scene.triangles) < len(triangles) / 2
    mesh = discretize(scene, 0.4, panels=merged)
    on_floor = np.abs(mesh.patch_corners[..., 2]).max(axis=1) < 1e-12
    corners = mesh.patch_corners[on_floor][..., :2]
    centre_inside = ((corners.mean(axis=1) > low[:2]) & (corners.mean(axis=1) < low[:2] + 0.33)).all(axis=1)
    corner_inside = ((corners > low[:2] - 1e-9) & (corners < low[:2] + 0.33 + 1e-9)).all(axis=2)
    corner_strictly_inside = ((corners > low[:2] + 1e-9) & (corners < low[:2] + 0.33 - 1e-9)).all(axis=2)
    assert centre_inside.any() and corner_inside[centre_inside].all()  # under the block: wholly
    assert not corner_strictly_inside[~centre_inside].any()  # outside: wholly
    colours = bake(scene, patch_size=0.4, ambient=False).corner_colors  # the ambient term would light all
    floor_count = len(floor[1])
    points = vertices[triangles[:floor_count]]
    inside = ((points[..., :2] > low[:2] + 1e-9) & (points[..., :2] < low[:2] + 0.33 - 1e-9)).all(axis=2)
    assert inside.sum() >= 4 and (~inside).sum() > 100
    assert (colours[:floor_count][inside] == 0).all()
    assert (colours[:floor_count][~inside] > 0.01).all()


@pytest.mark.parametrize("levels", [0, 1])
def test_a_finely_split_furnace_stays_exact_when_merged(levels):
    """Closed cube, each face 8 x 8 quads, rho = 0.8, E = 1: B = E / (1 - rho) = 5. The panels
    differ in size, so the ambient term of the light left unshot is no longer exact at every
    point (it is with congruent patches): the solve runs to 1e-7 of the light unshot, which can
    move a colour by at most 1e-7 / (1 - rho) = 5e-7 of it. (The hemicube is not exact in a
    furnace of fine triangles, merged or not: its aliasing.)"""
    faces = [grid(c, u, v, 8) for c, u, v in INWARD_FACES]
    scene = uniform(*merge(*faces), 0.8, 1.0)
    # every face emits, and emitters merge up to a quarter of the patch size: 0.5
    result = bake(scene, merge_flat=True, patch_size=2.0, refinement_levels=levels, tolerance=1e-7)
    assert result.stats["panels"] < len(scene.triangles) / 4
    np.testing.assert_allclose(result.corner_colors, 5.0, rtol=1e-6)


def test_a_twisted_wall_merges_and_its_vertices_stay_in_the_room():
    """The furnace again, with one wall split 16 x 16 and bulging inwards by up to 2.5e-4 at
    its centre (its outline stays, so the room stays closed): neighbouring cells differ by less
    than contacts.PARALLEL, as on the Cornell box's twisted left wall, so the wall merges into
    flat panels within 1 % of their size of its vertices. The vertices are evaluated on the
    panels: behind them, the panels would hide the room and B = E = 1 there. B = E / (1 - rho)
    = 5 holds to 5e-3: no longer exactly, since a bulging wall hides part of the room from some
    points at grazing angles, which the nodes sample with two sets of 9 rays a patch, all cast,
    and more where they disagree (``raycast.joined_shares``): over seeds 0 to 2, 3.4e-3, 2.2e-4 and
    1.9e-3 at worst (the first 9 alone 6.9e-3 at seed 0). With 4 probes a patch that all agreed,
    as the nodes read before, 2.2e-4 at every seed: the probes missed that occlusion, which in a
    furnace the bulge's own light makes up."""
    faces = [grid(c, u, v, 4) for c, u, v in INWARD_FACES if c != [1, 0, 0]]  # all but x = 1
    twisted_vertices, twisted_triangles = grid([1, 0, 0], [0, 0, 1], [0, 1, 0], 16)
    y, z = twisted_vertices[:, 1], twisted_vertices[:, 2]
    twisted_vertices[:, 0] -= 0.004 * y * (1 - y) * z * (1 - z)
    scene = uniform(*merge(*faces, (twisted_vertices, twisted_triangles)), 0.8, 1.0)
    merged = panels(scene, 2.0)
    twisted = merged.scene.triangles[merged.panel_source >= len(scene.triangles) - len(twisted_triangles)]
    assert len(twisted) < len(twisted_triangles) / 4
    result = bake(scene, merge_flat=True, patch_size=2.0, tolerance=1e-7)
    np.testing.assert_allclose(result.corner_colors, 5.0, rtol=5e-3)


@pytest.mark.parametrize("method", ["raycast", "hemicube"])
def test_merged_receiver_still_gets_the_exact_light_at_every_vertex(method):
    """A grey 16 x 16 grid under a parallel emitting unit square 1 above: one bounce,
    B = rho E F(vertex -> emitter) at every vertex (exact point-to-polygon form factor). The
    receiver merges into a few panels; its vertices are still evaluated one by one. Tolerance:
    the core evaluates a vertex 1e-3 of the way into its faces (about 1e-4 here); both methods
    integrate an unoccluded emitter patch exactly at a vertex (measured 6e-5, and 1e-15)."""
    receiver = grid([0, 0, 0], [1, 0, 0], [0, 1, 0], 16)
    emitter = quad([0, 0, 1], [0, 1, 0], [1, 0, 0])
    vertices, triangles = merge(receiver, emitter)
    lit = np.arange(len(triangles)) < len(receiver[1])
    rho = 0.5
    scene = Scene(vertices, triangles, np.where(lit[:, None], rho, 0.0) * np.ones(3),
                  np.where(lit[:, None], 0.0, 1.0) * np.ones(3))
    result = bake(scene, method, merge_flat=True, patch_size=0.5)
    assert result.stats["panels"] < len(triangles) / 8
    corners = vertices[triangles[lit]].reshape(-1, 3)
    up = np.tile([0.0, 0.0, 1.0], (len(corners), 1))
    emitter_corners = emitter[0][emitter[1]]
    factors = sum(point_to_triangle(corners, up, np.broadcast_to(t, (len(corners), 3, 3))) for t in emitter_corners)
    truth = rho * factors
    np.testing.assert_allclose(result.corner_colors[lit].reshape(-1, 3)[:, 0], truth, rtol=2e-3)


def test_a_zero_area_triangle_in_a_merged_grid_takes_its_neighbours_colour():
    vertices, triangles = grid([0, 0, 0], [1, 0, 0], [0, 1, 0], 8)
    sliver = [[0, 1, 2]]  # three collinear vertices along the grid's first row: zero area
    ceiling = quad([0, 0, 1], [0, 1, 0], [1, 0, 0])
    vertices, triangles = merge((vertices, np.concatenate([triangles, sliver])), ceiling)
    count = len(triangles)
    emitting = np.arange(count) >= count - 2
    scene = Scene(vertices, triangles, np.full((count, 3), 0.5), np.where(emitting[:, None], 1.0, 0.0) * np.ones(3))
    result = bake(scene, merge_flat=True, patch_size=0.5)
    assert result.stats["panels"] < count / 3
    colours = result.corner_colors
    assert np.isfinite(colours).all()
    sliver_index = count - 3
    neighbour = np.flatnonzero((triangles[:-3] == 1).any(axis=1))[0]
    at_vertex = colours[neighbour][triangles[neighbour] == 1][0]
    np.testing.assert_allclose(colours[sliver_index][1], at_vertex, rtol=1e-12)


def test_a_triangle_left_whole_keeps_its_area_mean_beside_merged_ones():
    """Triangle means (``triangle_radiosity``) with panels: a triangle nothing merged into keeps
    the area mean of its patches; here a unit square receiver (2 triangles) under a unit square
    emitter 1 above, beside a fine grid far off that merges. Truth: the area mean of
    rho E F(x -> emitter) over each triangle, by exact form factors at the centroids of a 32 x 32
    split. Tolerance 1 %: its 36 patches sample F at their centroids (measured 0.29 % off; 1.1 %
    with 9, as the square of the patch size); the mean of its corners is 31 % low (F falls
    towards the square's corners)."""
    receiver = quad([0, 0, 0], [1, 0, 0], [0, 1, 0])
    emitter = quad([0, 0, 1], [0, 1, 0], [1, 0, 0])
    far_grid = grid([3, 0, 0], [1, 0, 0], [0, 1, 0], 8)
    vertices, triangles = merge(receiver, emitter, far_grid)
    count = len(triangles)
    emitting = (np.arange(count) >= 2) & (np.arange(count) < 4)
    rho = 0.5
    scene = Scene(vertices, triangles, np.where(emitting[:, None], 0.0, rho) * np.ones(3),
                  np.where(emitting[:, None], 1.0, 0.0) * np.ones(3))
    result = bake(scene, patch_size=0.25)
    assert result.stats["panels"] < 0.6 * count  # the far grid merged: panels are in play
    weights, cells = barycentric_grid(32)
    emitter_corners = vertices[triangles[2:4]]
    for t in (0, 1):
        points = np.einsum("sb,bx->sx", weights[cells].mean(axis=1), vertices[triangles[t]])
        up = np.tile([0.0, 0.0, 1.0], (len(points), 1))
        factors = sum(point_to_triangle(points, up, np.broadcast_to(e, (len(points), 3, 3))) for e in emitter_corners)
        np.testing.assert_allclose(result.triangle_radiosity[t], rho * factors.mean(), rtol=1e-2)


def test_a_pass_of_collapses_needs_only_the_triangles_of_the_vertices_not_fixed():
    """``panels`` hands each pass of collapses only the triangles around the vertices still
    awake: on the L-shaped floor and wall, a third of the vertices fixed at random, the pass
    finds the same collapses and the same vertices without one from those triangles as from
    the whole mesh."""
    scene = l_shaped_floor_and_wall()
    triangles, positions = scene.triangles, scene.vertices
    normals = areas_and_normals(positions[triangles])[1]
    fixed = np.random.default_rng(3).random(len(positions)) < 1 / 3
    limit = np.full(len(triangles), 0.5)
    whole = _collapses(triangles, positions, normals, fixed, limit, 1e-6)
    awake = np.flatnonzero((~fixed)[triangles].any(axis=1))
    assert 0 < len(awake) < len(triangles)
    part = _collapses(triangles[awake], positions, normals[awake], fixed, limit[awake], 1e-6)
    assert len(whole[0]) > 10 and len(whole[2]) > 10  # collapses, and vertices without one
    for found, expected in zip(part, whole):
        np.testing.assert_array_equal(found, expected)
