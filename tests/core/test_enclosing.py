"""Walls with the whole scene in front of them (``geometry.enclosing``): no ray between two
points of the scene's surfaces can meet them, so occlusion between surface points is traced
without them (``Visibility.occluded_between_unit``), and a bake makes no patches of their back
faces, which face no surface (``discretize``'s ``hidden_backs``). Converged, both change nothing
but time; a node stepped off a smooth corner's faces is lifted back in front of them, so the
rays' starts are there."""

from __future__ import annotations

import numpy as np
import pytest

from core import Scene, bake
from core.util import geometry
import core.mesh.discretize as discretize_module
from core.mesh.discretize import discretize
from core.util.geometry import areas_and_normals, enclosing, triangle_corners
from core.rays.visibility import RAY_EPSILON, Visibility
from tests.core.scenes import box, lit_room, merge, quad



def room_with_block() -> tuple[np.ndarray, np.ndarray, int]:
    """A closed unit room facing inwards around a closed block facing outwards (a box turned
    inside out, so its faces see the room), lying on the floor; and the room's triangle count."""
    room_vertices, room_triangles = box(1.0)
    block_vertices, block_triangles = box(0.3)
    block_vertices = block_vertices + [0.35, 0.35, 0.0]
    vertices, triangles = merge((room_vertices, room_triangles), (block_vertices, block_triangles[:, ::-1]))
    return vertices, triangles, len(room_triangles)


def surface_points(corners: np.ndarray, count: int, rng) -> tuple[np.ndarray, np.ndarray]:
    """Uniform points (count, 3) on triangles (T, 3, 3), and their triangles' unit normals."""
    areas, normals = areas_and_normals(corners)
    chosen = rng.choice(len(corners), count, p=areas / areas.sum())
    u, v = rng.random(count), rng.random(count)
    flip = u + v > 1
    u[flip], v[flip] = 1 - u[flip], 1 - v[flip]
    a, b, c = corners[chosen, 0], corners[chosen, 1], corners[chosen, 2]
    return a + u[:, None] * (b - a) + v[:, None] * (c - a), normals[chosen]


def test_the_walls_of_a_room_enclose_and_the_block_inside_does_not():
    vertices, triangles, walls = room_with_block()
    corners = triangle_corners(vertices, triangles)
    found = enclosing(corners, 1e-9)
    assert found[:walls].all() and not found[walls:].any()
    # turned outwards, the room has the scene behind its walls; a degenerate triangle has no plane
    assert not enclosing(corners[:walls, ::-1], 1e-9).any()
    sliver = np.array([[[0.2, 0.2, 0.0], [0.4, 0.4, 0.0], [0.6, 0.6, 0.0]]])
    assert not enclosing(np.concatenate([corners, sliver]), 1e-9)[-1]


@pytest.mark.parametrize("budget", [100, 300])
def test_enclosing_is_not_searched_beyond_its_budget(monkeypatch, budget):
    """24 triangles: 24^2 / 2 = 288 pairs by the first estimate (over 100), 24 x 16 vertices =
    384 by the count (over 300)."""
    vertices, triangles, _ = room_with_block()
    monkeypatch.setattr(geometry, "ENCLOSING_PAIRS", budget)
    assert not enclosing(triangle_corners(vertices, triangles), 1e-9).any()
    monkeypatch.setattr(geometry, "ENCLOSING_PAIRS", 384)
    assert enclosing(triangle_corners(vertices, triangles), 1e-9).any()


def test_rays_between_surface_points_are_blocked_alike_without_the_walls():
    """Rays as ``raycast`` casts them: from a point lifted RAY_EPSILON off its surface to a point
    of a surface seen from its front, stopped RAY_EPSILON short of that surface's plane. The
    block blocks 12 % of them; every answer is the same without the walls."""
    vertices, triangles, walls = room_with_block()
    corners = triangle_corners(vertices, triangles)
    visibility = Visibility(corners)
    assert visibility.enclosing[:walls].all() and not visibility.enclosing[walls:].any()
    rng = np.random.default_rng(3)
    starts, start_normals = surface_points(corners, 40_000, rng)
    ends, end_normals = surface_points(corners, 40_000, rng)
    offset = ends - starts
    facing = (np.einsum("nx,nx->n", offset, start_normals) > 0) & (np.einsum("nx,nx->n", offset, end_normals) < 0)
    origin = visibility.to_unit(starts[facing]) + RAY_EPSILON * start_normals[facing]
    direction = visibility.to_unit(ends[facing]) - origin
    across = -np.einsum("nx,nx->n", direction, end_normals[facing])
    reach = 1 - RAY_EPSILON / across
    every = visibility.occluded_unit(origin, direction, reach)
    assert 0.05 < every.mean() < 0.95, every.mean()
    np.testing.assert_array_equal(visibility.occluded_between_unit(origin, direction, reach), every)


def test_the_back_faces_of_walls_are_not_patches_and_change_nothing(monkeypatch):
    """A two-sided room around a two-sided block: only the block's faces get backs (its inside
    faces surfaces). Converged, the bake is the bake with every back, the walls' too: measured
    2.1e-10 of the largest colour apart at tolerance 1e-9 (the bound: the tolerance times the
    gain 1 / (1 - 0.6)), against 2.1e-4 at the default 1e-3 (the solve stops elsewhere without
    the walls' backs, and the ambient term spreads the light not yet shot over less area)."""
    vertices, triangles, walls = room_with_block()
    count = len(triangles)
    reflectance = np.full((count, 3), 0.6)
    emission = np.zeros((count, 3))
    emission[2:4] = 5.0  # the ceiling
    scene = Scene(vertices, triangles, reflectance, emission, two_sided=np.ones(count, bool))
    mesh = discretize(scene, 0.2, hidden_backs=False)
    backs = mesh.patch_triangle[mesh.front_patch_count:]
    assert len(backs) and (backs >= walls).all()
    assert np.isin(np.arange(walls, count), backs).all()
    every = discretize(scene, 0.2)  # as asked by default: every two-sided triangle has its back
    assert every.patch_count == 2 * every.front_patch_count == 2 * mesh.front_patch_count
    fewer = bake(scene, patch_size=0.2, tolerance=1e-9).corner_colors
    monkeypatch.setattr(discretize_module, "discretize",
                        lambda *args, **knobs: discretize(*args, **knobs | {"hidden_backs": True}))
    assert bake(scene, patch_size=0.2).stats["patches"] == every.patch_count
    all_backs = bake(scene, patch_size=0.2, tolerance=1e-9).corner_colors
    np.testing.assert_allclose(fewer, all_backs, rtol=0, atol=1e-9 * np.abs(all_backs).max())


def smooth_room() -> Scene:
    """The closed unit room shaded smooth (each vertex's normal the mean of its three walls'), lit
    by a small square under the ceiling: a node stepped into its faces' tangent plane would leave
    the room at the corners."""
    room_vertices, room_triangles = box(1.0)
    vertices, triangles = merge((room_vertices, room_triangles),
                                quad([0.4, 0.4, 0.98], [0, 0.2, 0], [0.2, 0, 0]))
    corners = triangle_corners(vertices, triangles)
    normals = areas_and_normals(corners)[1]
    corner_normals = np.repeat(normals[:, None, :], 3, axis=1)
    walls = len(room_triangles)
    summed = {}
    for triangle in range(walls):
        for vertex in triangles[triangle]:
            summed[vertex] = summed.get(vertex, 0) + normals[triangle]
    for triangle in range(walls):
        corner_normals[triangle] = [summed[vertex] / np.linalg.norm(summed[vertex]) for vertex in triangles[triangle]]
    emission = np.zeros((len(triangles), 3))
    emission[walls:] = 20.0
    return Scene(vertices, triangles, np.full((len(triangles), 3), 0.6), emission, corner_normals=corner_normals)


def test_a_smooth_rooms_corner_nodes_stay_inside():
    """Each node lies on or in front of every face around it (before its rays' lift)."""
    scene = smooth_room()
    mesh = discretize(scene, 0.25)
    corners = triangle_corners(scene.vertices, scene.triangles)
    normals = areas_and_normals(corners)[1]
    node = mesh.corner_node.ravel()
    height = np.einsum("cx,cx->c", np.repeat(normals, 3, axis=0), mesh.node_points[node] - corners.reshape(-1, 3))
    assert height.min() >= -1e-12, height.min()
    assert (mesh.node_points >= -1e-12).all() and (mesh.node_points <= 1 + 1e-12).all()


@pytest.mark.parametrize("method", ["raycast", "hemicube"])
@pytest.mark.parametrize("room", [lit_room, smooth_room])
def test_a_bake_is_the_same_with_and_without_the_walls_traced(monkeypatch, method, room):
    """One-sided rooms (no back faces to drop), flat and shaded smooth, with their walls
    enclosing and with none found: the same colours (measured equal here; up to rays grazing an
    edge a wall shares with another face, which either scene may decide: 1.6e-7 of the largest
    colour on the OBJ Cornell box)."""
    scene = room()
    assert Visibility(triangle_corners(scene.vertices, scene.triangles)).enclosing.sum() >= 8
    fast = bake(scene, method, patch_size=0.25).corner_colors
    monkeypatch.setattr(geometry, "ENCLOSING_PAIRS", 0)
    assert not Visibility(triangle_corners(scene.vertices, scene.triangles)).enclosing.any()
    slow = bake(scene, method, patch_size=0.25).corner_colors
    assert (slow >= 0).all()
    np.testing.assert_allclose(fast, slow, rtol=0, atol=1e-6 * np.abs(slow).max())
