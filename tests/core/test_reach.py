"""Shots evaluated only inside the box their source's rays reach (core/transport/reach.py), against
the same shots evaluated at every receiver: the same pairs alike, none across a wall, and what a
thin opening the rays miss loses, against its bound."""

import dataclasses
import math

import numpy as np
import pytest

from core import BakeSession, Scene, bake
from core.mesh.discretize import discretised
from core.transport import formfactors, reach
from core.transport.formfactors import FormFactorEngine
from tests.core.scenes import box, merge, quad

LIGHT = 10.0
# The share of a source's power its box may lose through a thin opening all its rays missed: a
# few rays' worth (measured here: 0.58 % for a ceiling patch over the light panel, seeing the
# walls' tops through the 2 cm between them; of the panel's, 0.13 % and 0.22 % behind the slits).
LEAK = 4 / reach.REACH_RAYS


def room(offset: float, slit: tuple[float, float] | None = None):
    """A closed unit cube at x = offset, facing in, with a light panel under its ceiling when
    ``slit`` is None; with a slit (z from, z to) across its wall at x = offset + 1 (faces -x)."""
    o = offset
    parts = [quad([o, 0, 0], [1, 0, 0], [0, 1, 0]), quad([o, 0, 1], [0, 1, 0], [1, 0, 0]),
             quad([o, 0, 0], [0, 1, 0], [0, 0, 1]), quad([o, 0, 0], [0, 0, 1], [1, 0, 0]),
             quad([o, 1, 0], [1, 0, 0], [0, 0, 1])]
    if slit is None:
        parts.append(quad([o + 1, 0, 0], [0, 0, 1], [0, 1, 0]))
    else:
        low, high = slit
        parts += [quad([o + 1, 0, 0], [0, 0, low], [0, 1, 0]), quad([o + 1, 0, high], [0, 0, 1 - high], [0, 1, 0])]
    return merge(*parts)


def two_rooms(slit: tuple[float, float] | None = None) -> Scene:
    """Two unit rooms side by side (the second at x = 1, sharing the plane of the first's far
    wall, its own wall there facing +x), a light panel under the first's ceiling. With ``slit``
    both walls at x = 1 are cut across at those heights: the light reaches the second room
    through it alone."""
    first = room(0.0, slit)
    second_parts = [quad([1, 0, 0], [1, 0, 0], [0, 1, 0]), quad([1, 0, 1], [0, 1, 0], [1, 0, 0]),
                    quad([2, 0, 0], [0, 0, 1], [0, 1, 0]), quad([1, 0, 0], [0, 0, 1], [1, 0, 0]),
                    quad([1, 1, 0], [1, 0, 0], [0, 0, 1])]
    if slit is None:
        second_parts.append(quad([1, 0, 0], [0, 1, 0], [0, 0, 1]))
    else:
        low, high = slit
        second_parts += [quad([1, 0, 0], [0, 1, 0], [0, 0, low]), quad([1, 0, high], [0, 1, 0], [0, 0, 1 - high])]
    light = quad([0.35, 0.35, 0.98], [0, 0.3, 0], [0.3, 0, 0])  # faces -z
    vertices, triangles = merge(first, *second_parts, light)
    emission = np.zeros((len(triangles), 3))
    emission[-2:] = LIGHT
    reflectance = np.full((len(triangles), 3), 0.5)
    reflectance[-2:] = 0.0
    return Scene(vertices, triangles, reflectance, emission)


def columns(scene: Scene, culled: bool, monkeypatch) -> tuple[np.ndarray, FormFactorEngine, np.ndarray, list]:
    """The shooting columns (P + N, k) of the light's patches and of every 7th patch, with or
    without reach boxes, the engine, the sources, and the pairs evaluated (receiving points
    moved a hair off their surfaces, sources)."""
    mesh, _ = discretised(scene, 0.1, math.radians(30), True)
    monkeypatch.setattr(formfactors, "REACH_RECEIVERS", 0 if culled else 1 << 62)
    monkeypatch.setattr(formfactors, "REACH_SHARE", 1.0)  # every box searched, however large
    engine = FormFactorEngine(mesh, "raycast", 64, 16, 0, probing=True)
    evaluated, evaluate = [], engine.raycaster.form_factors

    def recorded(points, normals, receivers, sources, *rest, **options):
        evaluated.append((points[receivers] + 1e-3 * normals[receivers], sources))
        return evaluate(points, normals, receivers, sources, *rest, **options)

    monkeypatch.setattr(engine.raycaster, "form_factors", recorded)
    sources = np.union1d(np.flatnonzero(mesh.patch_emission.any(axis=1)), np.arange(0, mesh.patch_count, 7))
    size = mesh.patch_count + mesh.node_count
    result = np.stack([dense(column, size) for start in range(0, len(sources), 16)
                       for column in engine.shooting_columns(sources[start:start + 16])[0]], axis=1)
    return result, engine, sources, evaluated


def dense(column, size: int) -> np.ndarray:
    """A shooting column's (size,) values, from its values or its nonzero ones' indices and values."""
    if not isinstance(column, tuple):
        return column
    values = np.zeros(size)
    values[column[0]] = column[1]
    return values


def lost_shares(full: np.ndarray, culled: np.ndarray, engine: FormFactorEngine, sources: np.ndarray,
                patches: np.ndarray) -> np.ndarray:
    """(k,) the share of each source's power that lands on ``patches`` in the full columns and not
    in the culled ones: sum_r A_r (F - F')[r, q] / A_q (reciprocity)."""
    areas = engine.mesh.patch_areas
    return areas[patches] @ (full - culled)[patches] / areas[sources]


def panel_shots(scene: Scene, monkeypatch):
    """The light panel's patches' full and culled columns (P + N, k) (``columns``), the engine, those
    patches, the second room's patches, and the share of each one's power that lands there."""
    full, engine, sources, _ = columns(scene, False, monkeypatch)
    culled, _, _, _ = columns(scene, True, monkeypatch)
    mesh = engine.mesh
    lights = np.flatnonzero(mesh.patch_emission[sources].any(axis=1))
    second = np.flatnonzero(mesh.patch_centroids[:, 0] > 1)
    reached = mesh.patch_areas[second] @ full[second][:, lights] / mesh.patch_areas[sources[lights]]
    return full[:, lights], culled[:, lights], engine, sources[lights], second, reached


def test_a_shot_in_a_closed_room_skips_the_next_room_and_loses_little(monkeypatch):
    """Two closed rooms: no shot reaches the other room (but through the seams of its walls, to
    rounding); the culled shots evaluate a tenth of the pairs across the wall that the full ones
    do (receivers facing the source from behind it; the boxes reach a little past the wall);
    every pair is evaluated as it is at every receiver, or not at all; and what a source loses (a
    ceiling patch over the light panel sees the walls' tops only through the 2 cm between them, at
    grazing angles) is at most LEAK of its power."""
    scene = two_rooms()
    full, full_engine, sources, full_pairs = columns(scene, False, monkeypatch)
    culled, _, _, culled_pairs = columns(scene, True, monkeypatch)
    points, normals = full_engine._shot_receivers
    mesh = full_engine.mesh
    in_second = (points + 1e-3 * normals)[:, 0] > 1  # a wall at x = 1 is in the room it faces
    source_in_second = (mesh.patch_centroids + 1e-3 * mesh.patch_normals)[:, 0] > 1
    for j, source in enumerate(sources):
        other = in_second != source_in_second[source]
        assert culled[other, j].sum() <= 1e-6 and full[other, j].sum() <= 1e-6  # rays through the seams: 5e-9

    def across(pairs) -> int:
        return sum(int(((points[:, 0] > 1) != source_in_second[pair_sources]).sum()) for points, pair_sources in pairs)

    # (those left: the boxes reach a ray's spread past where the rays land, here across the wall)
    assert across(full_pairs) > 1000 and across(culled_pairs) <= 0.1 * across(full_pairs)
    assert ((np.abs(culled - full) <= 1e-12) | (culled == 0)).all()  # each pair evaluated alike, or not at all
    lost = lost_shares(full, culled, full_engine, sources, np.arange(full_engine.mesh.patch_count))
    assert lost.max() <= LEAK, lost.max()


@pytest.mark.parametrize("width", [0.004, 0.2])
def test_what_a_slit_between_two_rooms_lets_through(monkeypatch, width):
    """The light reaches the second room through a slit across the wall between them. Through a
    slit the rays pass (0.2 high) most of that light is still shot (receivers there seen only
    between the rays, outside the box of all they hit, are not); one much narrower than their
    spacing (0.004) may be missed. Either way the light the second room's patches lose is at
    most LEAK of the panel's power."""
    full, culled, engine, panels, second, reached = panel_shots(two_rooms((0.5 - width / 2, 0.5 + width / 2)),
                                                                monkeypatch)
    lost = lost_shares(full, culled, engine, panels, second)
    assert reached.min() > 0  # the slit lets light through
    assert lost.max() <= LEAK, lost.max()
    if width > 0.1:
        assert (lost <= 0.1 * reached).all(), (lost / reached).max()


def test_a_source_whose_rays_meet_a_see_through_wall_is_shot_everywhere(monkeypatch):
    """The two rooms with the wall between them see-through (opacity 0.5, glass): the light
    panel's rays meet it, so its box is unbounded and its culled shot is its full one, the light
    it sends into the second room included (a box would end at the glass, as at an opaque wall)."""
    scene = two_rooms()
    on_shared_wall = (np.abs(scene.vertices[scene.triangles][..., 0] - 1) < 1e-12).all(axis=1)
    scene = dataclasses.replace(scene, opacity=np.where(on_shared_wall, 0.5, 1.0))
    full, culled, _, _, _, reached = panel_shots(scene, monkeypatch)
    assert reached.min() > 0.01  # through the glass
    np.testing.assert_array_equal(culled, full)


def test_a_resolve_with_an_emitter_turned_off_equals_a_fresh_bake(monkeypatch):
    """With reach boxes on, a re-solve in which one of two emitting surfaces goes dark (the
    emitters are fewer than when their boxes were found: it raised IndexError when the boxes were
    kept for the first bake's emitters) gives a fresh bake's colours."""
    monkeypatch.setattr(formfactors, "REACH_RECEIVERS", 0)
    scene = two_rooms()
    emission = scene.emission.copy()
    emission[12:14] = 2.0  # the second room's floor glows too
    both = dataclasses.replace(scene, emission=emission, material=scene.material)
    session = BakeSession(patch_size=0.25, rays_per_form_factor=4, tolerance=1e-6)
    session.bake(both)
    emission = emission.copy()
    emission[-2:] = 0.0  # the first room's panel goes dark
    one = dataclasses.replace(both, emission=emission, material=both.material)
    again = session.bake(one)
    assert again.stats["resolved"]
    fresh = bake(one, patch_size=0.25, rays_per_form_factor=4, tolerance=1e-6)
    # the new emission renumbers the near field's interpolation nodes, which then draw other rays
    # (tests/core/test_session.py, NEW_SAMPLES): 9.8e-5 of the largest colour, with boxes or without
    np.testing.assert_allclose(again.corner_colors, fresh.corner_colors, rtol=0,
                               atol=2e-4 * np.abs(fresh.corner_colors).max())


def test_a_box_that_may_hold_most_receivers_is_not_searched():
    """``_few_inside``: a box around one room of two may hold at most REACH_SHARE of the
    receivers and is searched; one around both rooms, or an unbounded one (a source whose rays
    met a surface that lets light through), is not: the shot takes every receiver."""
    mesh, _ = discretised(two_rooms(), 0.1, math.radians(30), True)
    engine = FormFactorEngine(mesh, "raycast", 64, 16, 0, probing=True)
    points = engine._shot_receivers[0]
    first_room = points[:, 0] < 0.9
    assert 0.2 < first_room.mean() <= formfactors.REACH_SHARE
    low = np.array([[-0.1, -0.1, -0.1], [-0.1, -0.1, -0.1], [-np.inf] * 3])
    high = np.array([[0.9, 1.1, 1.1], [2.1, 1.1, 1.1], [np.inf] * 3])
    np.testing.assert_array_equal(engine._few_inside(low, high), [True, False, False])


def grid_of_rooms() -> Scene:
    """Four closed unit cubes (``tests.core.scenes.box``) 1.5 apart in a 2 x 2 grid, a light panel
    under each one's ceiling: any slab along an axis through one room holds a row of two."""
    parts = []
    for dx in (0.0, 1.5):
        for dy in (0.0, 1.5):
            for vertices, triangles in (box(1.0), quad([0.35, 0.35, 0.98], [0, 0.3, 0], [0.3, 0, 0])):
                parts.append((vertices + [dx, dy, 0.0], triangles))
    vertices, triangles = merge(*parts)
    lights = np.zeros(len(triangles), dtype=bool)
    lights[12::14], lights[13::14] = True, True  # each room's last two triangles: its panel
    emission = np.where(lights[:, None], LIGHT, 0.0) * np.ones(3)
    return Scene(vertices, triangles, np.where(lights[:, None], 0.0, 0.5) * np.ones(3), emission)


def test_a_box_is_searched_by_the_receivers_inside_it_not_in_its_slab(monkeypatch):
    """``_few_inside`` against the receivers counted in each box one by one: in a 2 x 2 grid of
    rooms the slab of a room's box holds half the receivers along every axis, more than the
    REACH_SHARE set here, the box itself a quarter, and it is searched; a box around two rooms
    or four is not."""
    monkeypatch.setattr(formfactors, "REACH_SHARE", 0.4)
    mesh, _ = discretised(grid_of_rooms(), 0.25, math.radians(30), True)
    engine = FormFactorEngine(mesh, "raycast", 64, 16, 0, probing=True)
    points = engine._shot_receivers[0]
    low = np.array([[-0.1] * 3, [1.4, -0.1, -0.1], [-0.1, -0.1, -0.1], [-0.1, -0.1, -0.1]])
    high = np.array([[1.1] * 3, [2.6, 1.1, 1.1], [2.6, 1.1, 1.1], [2.6, 2.6, 1.1]])
    inside = np.array([((points >= a) & (points <= b)).all(axis=1).mean() for a, b in zip(low, high)])
    np.testing.assert_allclose(inside, [0.25, 0.25, 0.5, 1.0])
    np.testing.assert_array_equal(engine._few_inside(low, high), [True, True, False, False])
    first, last = engine._slabs(low[:1], high[:1])
    assert (last - first).min() > formfactors.REACH_SHARE * len(points)  # what the slab alone would say


@pytest.mark.parametrize("boxes_from", ["shots", "matrix"])
def test_rows_skip_the_patches_whose_light_does_not_reach_them(monkeypatch, boxes_from):
    """Once every patch's reach box is known (every patch has shot, or Jacobi's matrix made them
    first), rows from the receivers of the two rooms to every patch evaluate the pairs across the
    wall a tenth as often as without the boxes; each pair alike or not at all, and what a row
    loses is within LEAK of its whole."""
    mesh, _ = discretised(two_rooms(), 0.2, math.radians(30), True)
    monkeypatch.setattr(formfactors, "REACH_SHARE", 1.0)
    rows, across = [], []
    for culled in (False, True):
        monkeypatch.setattr(formfactors, "REACH_RECEIVERS", 0 if culled else 1 << 62)
        engine = FormFactorEngine(mesh, "raycast", 64, 4, 0, probing=True)
        patches = np.arange(mesh.patch_count)
        if boxes_from == "shots":
            for start in range(0, len(patches), 16):
                engine.shooting_columns(patches[start:start + 16])
        points, normals = engine._shot_receivers
        evaluated, evaluate = [], engine.raycaster.form_factors

        def recorded(points, normals, receivers, sources, *rest, evaluated=evaluated, evaluate=evaluate):
            evaluated.append(((points[receivers] + 1e-3 * normals[receivers])[:, 0] > 1)
                             != ((mesh.patch_centroids + 1e-3 * mesh.patch_normals)[sources, 0] > 1))
            return evaluate(points, normals, receivers, sources, *rest)

        monkeypatch.setattr(engine.raycaster, "form_factors", recorded)
        if boxes_from == "shots":
            rows.append(engine.gather_rows(points, normals, patches))
        else:
            rows.append(engine.patch_rows(patches))
        across.append(int(np.concatenate(evaluated).sum()))
    full, culled = rows
    assert across[0] > 1000 and across[1] <= 0.1 * across[0], across
    assert ((np.abs(culled - full) <= 1e-12) | (culled == 0)).all()
    assert ((full - culled).sum(axis=1) <= LEAK * np.maximum(full.sum(axis=1), 1e-12)).all()


def test_in_one_room_the_boxes_stop_once_they_never_pay(monkeypatch):
    """In one closed room the boxes hold the room and spare nothing: after REACH_TRIALS shots the
    engine makes no more; in four rooms each spares three quarters of the receivers, and it goes
    on."""
    for scene, searching in ((grid_of_rooms(), True), (Scene(*box(1.0), np.full((12, 3), 0.5),
                                                         np.where(np.arange(12)[:, None] < 2, LIGHT, 0.0) * np.ones(3)),
                                                   False)):
        mesh, _ = discretised(scene, 0.1, math.radians(30), True)
        monkeypatch.setattr(formfactors, "REACH_RECEIVERS", 0)
        engine = FormFactorEngine(mesh, "raycast", 64, 4, 0, probing=True)
        patches = np.arange(formfactors.REACH_TRIALS + 16)
        for start in range(0, len(patches), 16):
            engine.shooting_columns(patches[start:start + 16])
        assert engine._reaching() == searching
        made = engine._reach_record[0]
        engine.shooting_columns(patches[-16:] + 16)
        assert (engine._reach_record[0] > made) == searching


def test_in_two_rooms_side_by_side_a_room_s_box_is_searched(monkeypatch):
    """Two rooms in a row: the box of a shot from the light panel reaches a little past the wall
    into the other room, so it holds more than half the receivers, and it is still searched
    (REACH_SHARE): a shot costs its room, not both."""
    monkeypatch.setattr(formfactors, "REACH_RECEIVERS", 0)
    mesh, _ = discretised(two_rooms(), 0.1, math.radians(30), True)
    engine = FormFactorEngine(mesh, "raycast", 64, 4, 0, probing=True)
    lights = np.flatnonzero(mesh.patch_emission.any(axis=1))
    low, high, searched = engine._searched(lights)
    shares = engine._shares_inside(low, high)
    assert (shares > 0.5).all() and searched.all(), shares


def test_in_the_open_a_source_gets_no_box(monkeypatch):
    """Two unit squares at a right angle, nothing around them: most of a floor patch's rays leave
    the scene, and those that meet the wall near it would box in only its foot (the rest of the
    wall is seen at grazing angles), so no patch gets a box, and with boxes on the floor's form
    factor to the wall is still Howell's C-14, 0.2000438, to the centroid rule's 3e-3
    (tests/core/test_extremes.py; with boxes from the rays that met the wall it read 0.182)."""
    monkeypatch.setattr(formfactors, "REACH_RECEIVERS", 0)
    monkeypatch.setattr(formfactors, "REACH_SHARE", 1.0)
    vertices, triangles = merge(quad([0, 0, 0], [1, 0, 0], [0, 1, 0]), quad([0, 0, 0], [0, 1, 0], [0, 0, 1]))
    matrix = formfactors.form_factor_matrix(vertices, triangles, "raycast", patch_size=1 / 16)
    assert abs(matrix[:2, 2:].sum(axis=1).mean() - 0.2000438) < 3e-3
    mesh, _ = discretised(Scene(vertices, triangles, np.full((4, 3), 0.5), np.zeros((4, 3))), 1 / 16,
                          math.radians(30), True)
    engine = FormFactorEngine(mesh, "raycast", 64, 4, 0)
    low, _ = engine._reach_boxes(np.arange(mesh.patch_count))
    assert not np.isfinite(low).any()
