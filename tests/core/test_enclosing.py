"""Walls with the whole scene in front of them (``geometry.enclosing``): no ray between two
points of the scene's surfaces can meet them, so occlusion between surface points is traced
without them (``Visibility.occluded_between_unit``), and a bake makes no patches of their back
faces, which face no surface (``discretize``'s ``hidden_backs``). Both change nothing but time."""

from __future__ import annotations

import numpy as np
import pytest

from core import Scene, bake, geometry
from core.discretize import discretize
from core.geometry import areas_and_normals, enclosing, triangle_corners
from core.visibility import RAY_EPSILON, Visibility
from tests.core.scenes import box, lit_room, merge


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


def test_enclosing_is_not_searched_beyond_its_budget(monkeypatch):
    vertices, triangles, _ = room_with_block()
    monkeypatch.setattr(geometry, "ENCLOSING_PAIRS", 100)  # 24 triangles x 16 vertices is more
    assert not enclosing(triangle_corners(vertices, triangles), 1e-9).any()


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


def test_the_back_faces_of_walls_are_not_patches_and_change_nothing():
    """A two-sided room around a two-sided block: only the block's faces get backs (its inside
    faces surfaces), and the bake is the bake with one-sided walls, to the bit."""
    vertices, triangles, walls = room_with_block()
    count = len(triangles)
    reflectance = np.full((count, 3), 0.6)
    emission = np.zeros((count, 3))
    emission[2:4] = 5.0  # the ceiling
    two_sided = Scene(vertices, triangles, reflectance, emission, two_sided=np.ones(count, bool))
    walls_one_sided = Scene(vertices, triangles, reflectance, emission, two_sided=np.arange(count) >= walls)
    mesh = discretize(two_sided, 0.2, hidden_backs=False)
    backs = mesh.patch_triangle[mesh.front_patch_count:]
    assert len(backs) and (backs >= walls).all()
    assert np.isin(np.arange(walls, count), backs).all()
    every = discretize(two_sided, 0.2)  # as asked by default: every two-sided triangle has its back
    assert every.patch_count == 2 * every.front_patch_count == 2 * mesh.front_patch_count
    np.testing.assert_array_equal(bake(two_sided, patch_size=0.2).corner_colors,
                                  bake(walls_one_sided, patch_size=0.2).corner_colors)


@pytest.mark.parametrize("method", ["raycast", "hemicube"])
def test_a_bake_is_the_same_with_and_without_the_walls_traced(monkeypatch, method):
    """The lit room (one-sided: no back faces to drop) with its floor and walls enclosing, and
    with none found: the same colours up to rays grazing an edge a wall shares with another
    face, which either scene may decide (measured 1.6e-7 of the largest colour on the OBJ Cornell
    box)."""
    scene = lit_room()
    assert Visibility(triangle_corners(scene.vertices, scene.triangles)).enclosing.sum() == 8
    fast = bake(scene, method, patch_size=0.25).corner_colors
    monkeypatch.setattr(geometry, "ENCLOSING_PAIRS", 0)
    assert not Visibility(triangle_corners(scene.vertices, scene.triangles)).enclosing.any()
    slow = bake(scene, method, patch_size=0.25).corner_colors
    np.testing.assert_allclose(fast, slow, rtol=0, atol=1e-6 * np.abs(slow).max())
