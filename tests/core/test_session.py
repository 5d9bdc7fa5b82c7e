"""BakeSession: a re-solve after only colours changed gives what a fresh bake gives, and anything
else is baked afresh.

The independent truths: a fresh ``bake`` of the changed scene (with no refinement levels it solves
the same linear system on the same patches with the same rays, so the two agree to rounding, far
below the tolerance of 1e-9 used here; with refinement levels the fresh bake may split other patches,
and with Monte Carlo after reflectances changed the re-solve reads the first bake's particles'
paths with the new colours, another sample of the same answer: then they agree within the bake's
own error estimate), the converged bake without Monte Carlo, and the linearity of the radiosity
equation in its sources: B = (I - rho F)^-1 (E + rho D) is the sum of the answers for each source
alone.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from core import BakeCancelled, BakeSession, Environment, PointLight, Scene, SunLight, bake
from core.util.progress import stop_abandoned

from scenes import box, grid, lit_room, merge, uniform
from test_nodes import face_normals, tent

ROUNDING = 1e-9  # of the largest colour: same system, same rays, same patches
# A new reflectance renumbers the near field's interpolation nodes (they are keyed by their
# surface's colours), so each draws other stratified rays to gather its light than in a fresh
# bake: measured 1.1e-5 of the largest colour with 4 rays per form factor.
NEW_SAMPLES = 1e-4


def recoloured(scene: Scene, **changes) -> Scene:
    """``scene`` with other colours or lights, its materials kept (they would follow the colours)."""
    return dataclasses.replace(scene, material=scene.material, **changes)


def lit_by_everything() -> Scene:
    """lit_room with a point light, a sun through its open top, a sky and an environment image."""
    scene = lit_room()
    environment = Environment(np.linspace(0.1, 1.0, 8 * 16 * 3).reshape(8, 16, 3))
    lights = (PointLight([0.5, 0.5, 0.8], [20.0, 15.0, 10.0], radius=0.05),
              SunLight([0.3, 0.2, -1.0], [2.0, 2.0, 1.5], angle=0.05))
    return recoloured(scene, lights=lights, sky=[0.2, 0.3, 0.5], environment=environment)


def assert_same_colours(actual, expected, tolerance=ROUNDING):
    largest = np.abs(expected.corner_colors).max()
    np.testing.assert_allclose(actual.corner_colors, expected.corner_colors, rtol=0, atol=tolerance * largest)


KNOBS = dict(patch_size=0.2, rays_per_form_factor=4, tolerance=1e-6)


@pytest.mark.parametrize("solver", ["progressive", "jacobi"])
def test_a_resolve_of_new_colours_equals_a_fresh_bake(solver):
    scene = lit_by_everything()
    knobs = KNOBS
    session = BakeSession(solver=solver, **knobs)
    first = session.bake(scene)
    assert not first.stats["resolved"]
    reflectance = scene.reflectance.copy()
    reflectance[2:4] = [0.1, 0.2, 0.7]  # the red wall turns blue
    environment = Environment(scene.environment.radiance * 3.0)  # the world's strength tripled
    changed = recoloured(scene, reflectance=reflectance, emission=scene.emission * [0.2, 1.0, 2.0],
                         lights=(dataclasses.replace(scene.lights[0], power=np.array([5.0, 30.0, 5.0])),
                                 dataclasses.replace(scene.lights[1], strength=np.array([0.5, 1.0, 4.0]))),
                         sky=[1.0, 0.5, 0.1], environment=environment)
    assert session.change(changed) is None
    again = session.bake(changed)
    assert again.stats["resolved"]
    assert "discretise" not in again.stats["seconds"] and "direct_light" not in again.stats["seconds"]
    fresh = bake(changed, solver=solver, **knobs)
    assert np.abs(fresh.corner_colors - first.corner_colors).max() > 0.1 * np.abs(first.corner_colors).max()
    assert_same_colours(again, fresh, NEW_SAMPLES)
    unchanged_reflectance = recoloured(changed, reflectance=scene.reflectance)
    assert_same_colours(session.bake(unchanged_reflectance), bake(unchanged_reflectance, solver=solver, **knobs))
    assert_same_colours(session.bake(scene), first)  # and back


def test_monte_carlo_re_solves_read_the_kept_paths_unless_surfaces_grow_brighter():
    """Monte Carlo's particles' paths are kept (their final gather's rays too) and read again with
    the new colours where that is unbiased and about as precise (``ParticlePaths.reusable``). In a
    closed grey box of reflectance 0.8 lit from its ceiling the particles carry most of the light.
    The ceiling turns warmer and brighter: every light is scaled per channel and the paths are
    those a fresh bake traces, their power scaled: the same colours to rounding. Coloured walls,
    each channel as dark as the grey or darker: the paths read with the new reflectances. Against
    the converged bake of the same patches (no Monte Carlo), the re-solves' error over three seeds
    is at most 1.25 times the fresh bakes' (the second moment of the power leaving the patches
    is at most REUSE_MOMENT = 1.25 times that of fresh particles: their noise sqrt(1.25) = 1.12
    times, plus the spread of three seeds; measured 0.90 times, each seed 0.83 to 0.94; reading
    the paths with each patch's mean reflectance instead gives 3.2 times) and within the estimate.
    A wall brighter than the grey: traced again, as a fresh bake traces. (With 1,024 rays the
    final gather is not made again: REGATHER_MAX_RAYS.)"""
    scene = uniform(*box(), 0.8, 0.0)
    emission = np.zeros_like(scene.emission)
    emission[:2] = [5.0, 4.0, 3.0]
    scene = recoloured(scene, emission=emission)
    knobs = KNOBS | {"monte_carlo_rays": 1024}
    coloured = scene.reflectance.copy()
    coloured[2:6] = [0.3, 0.5, 0.7]
    coloured[6:] = [0.7, 0.6, 0.5]
    changed = recoloured(scene, reflectance=coloured, emission=scene.emission * [0.2, 1.0, 2.0])
    converged = bake(changed, **KNOBS)
    errors = []
    for seed in range(3):
        session = BakeSession(**knobs, seed=seed)
        assert session.bake(scene).stats["monte_carlo"]["traced"]
        warmer = recoloured(scene, emission=scene.emission * [3.0, 1.0, 0.2])
        again = session.bake(warmer)
        assert again.stats["resolved"] and not again.stats["monte_carlo"]["traced"]
        assert_same_colours(again, bake(warmer, **knobs, seed=seed))
        again, fresh = session.bake(changed), bake(changed, **knobs, seed=seed)
        assert again.stats["resolved"] and not again.stats["monte_carlo"]["traced"]
        errors.append([relative_rms(again, converged), relative_rms(fresh, converged)])
        assert errors[-1][0] <= again.stats["error_estimate"]["total"]
    mean_error = np.mean(errors, axis=0)
    assert mean_error[0] <= 1.25 * mean_error[1]
    brighter = scene.reflectance.copy()
    brighter[6:8] = 0.9
    brighter = recoloured(scene, reflectance=brighter)
    again = session.bake(brighter)
    assert again.stats["resolved"] and again.stats["monte_carlo"]["traced"]
    assert again.stats["monte_carlo"]["regathered_nodes"] == 0
    assert_same_colours(again, bake(brighter, **knobs, seed=seed), NEW_SAMPLES)


def test_a_monte_carlo_resolve_of_every_source_is_within_the_estimate_of_a_fresh_bake():
    """Every kind of source changed at once (an emitter, a point light, a sun, the sky, the
    environment) and the walls darker, Monte Carlo carrying what the emitter's shots and the
    direct light left: the kept paths are read (nothing is traced; the second moment of the power
    leaving is 0.96 to 1.10 times a fresh trace's) and the re-solve is within the fresh bake's
    estimate of it; back to the first colours, it is the first bake to rounding (the same paths
    read with the same colours). (With ``max_shots`` other patches than the emitters shoot, each
    bake its own, and a patch shot to nothing in the first is lit in the next: traced again.)"""
    scene = lit_by_everything()
    knobs = KNOBS | {"monte_carlo_rays": 16}
    session = BakeSession(**knobs)
    first = session.bake(scene)
    assert first.stats["monte_carlo"]["traced"]
    reflectance = scene.reflectance.copy()
    reflectance[2:4] = [0.1, 0.1, 0.55]  # the red wall turns blue, no brighter than its red
    changed = recoloured(scene, reflectance=reflectance * 0.9, emission=scene.emission * [0.2, 1.0, 2.0],
                         lights=(dataclasses.replace(scene.lights[0], power=np.array([5.0, 30.0, 5.0])),
                                 dataclasses.replace(scene.lights[1], strength=np.array([0.5, 1.0, 4.0]))),
                         sky=[1.0, 0.5, 0.1], environment=Environment(scene.environment.radiance * 3.0))
    again, fresh = session.bake(changed), bake(changed, **knobs)
    assert again.stats["resolved"] and not again.stats["monte_carlo"]["traced"]
    assert relative_rms(again, first) > 0.1
    assert relative_rms(again, fresh) <= fresh.stats["error_estimate"]["total"]
    assert_same_colours(session.bake(scene), first)


def test_a_monte_carlo_resolve_reads_again_the_gather_of_nodes_that_gather_together():
    """A tent shaded flat on the lit room's floor: the nodes of its ridge gather together
    (``gather.node_pools``). A re-solve of new colours reads their kept rays with them (nothing
    is traced) within the fresh bake's estimate of it, and back to the first colours it is the
    first bake to rounding."""
    room = lit_room()
    roof = tent(20.0)
    placed = roof.vertices * 0.3 + [0.6, 0.1, 0.1]  # on the floor, clear of it
    vertices, triangles = merge((room.vertices, room.triangles), (placed, roof.triangles))
    reflectance = np.vstack([room.reflectance, np.full((len(roof.triangles), 3), 0.7)])
    emission = np.vstack([room.emission, np.zeros((len(roof.triangles), 3))])
    flat = Scene(vertices, triangles, reflectance, emission)
    scene = dataclasses.replace(flat, corner_normals=face_normals(flat))
    knobs = KNOBS | {"monte_carlo_rays": 16}
    session = BakeSession(**knobs)
    first = session.bake(scene)
    assert first.stats["monte_carlo"]["pooled_nodes"] >= 4
    changed = recoloured(scene, reflectance=scene.reflectance * 0.8, emission=scene.emission * [1.0, 0.5, 2.0])
    again, fresh = session.bake(changed), bake(changed, **knobs)
    assert again.stats["resolved"] and not again.stats["monte_carlo"]["traced"]
    assert relative_rms(again, fresh) <= fresh.stats["error_estimate"]["total"]
    assert_same_colours(session.bake(scene), first)


def relative_rms(result, truth) -> float:
    """The RMS of the corner colours' difference over that of ``truth``'s colours."""
    return float(np.sqrt(((result.corner_colors - truth.corner_colors) ** 2).mean()
                         / (truth.corner_colors ** 2).mean()))


def test_the_light_of_each_source_alone_adds_up_to_all_of_it():
    """Light groups: the bake is linear in the sources, so the re-solves with one source at a time
    add up to the bake with all of them (emitters, the point light, the sun, the sky and the
    environment, each alone)."""
    scene = lit_by_everything()
    session = BakeSession(**KNOBS)
    whole = session.bake(scene)
    dark = dict(emission=np.zeros_like(scene.emission), sky=np.zeros(3), environment=None,
                lights=tuple(dataclasses.replace(light, **{"strength" if isinstance(light, SunLight) else "power":
                                                           np.zeros(3)}) for light in scene.lights))
    alone = [dict(dark, emission=scene.emission), dict(dark, sky=scene.sky),
             dict(dark, environment=scene.environment)]
    alone += [dict(dark, lights=tuple(scene.lights[i] if i == k else dark["lights"][i] for i in range(2)))
              for k in range(2)]
    parts = [session.bake(recoloured(scene, **changes)) for changes in alone]
    assert all(part.stats["resolved"] for part in parts)
    assert all(np.abs(part.corner_colors).max() > 1e-3 * np.abs(whole.corner_colors).max() for part in parts)
    total = sum(part.corner_colors for part in parts)
    # each re-solve stops at its own tolerance (1e-6 of its light): the sum to a few of them
    np.testing.assert_allclose(total, whole.corner_colors, rtol=0, atol=1e-5 * np.abs(whole.corner_colors).max())


def test_with_refinement_levels_a_resolve_is_within_the_estimate_of_a_fresh_bake():
    scene = lit_room()
    knobs = dict(KNOBS, refinement_levels=1, tolerance=1e-4)
    session = BakeSession(**knobs)
    session.bake(scene)
    changed = recoloured(scene, emission=scene.emission * [1.0, 0.5, 0.2])
    again, fresh = session.bake(changed), bake(changed, **knobs)
    assert again.stats["resolved"]
    assert relative_rms(again, fresh) <= fresh.stats["error_estimate"]["total"]


def moved_vertex(scene):
    vertices = scene.vertices.copy()
    vertices[0] += [0.01, 0, 0]
    return recoloured(scene, vertices=vertices)


def new_emitter(scene):
    emission = scene.emission.copy()
    emission[0] = [1.0, 1.0, 1.0]
    return recoloured(scene, emission=emission)


@pytest.mark.parametrize("change, reason", [
    (moved_vertex, "vertices"),
    (new_emitter, "did not emit"),
    (lambda s: recoloured(s, lights=(dataclasses.replace(s.lights[0], position=np.array([0.4, 0.5, 0.8])),
                                     s.lights[1])), "light 0 moved"),
    (lambda s: recoloured(s, lights=(dataclasses.replace(s.lights[0], soft_falloff=True), s.lights[1])),
     "light 0 moved or changed its shape, shadows, falloff"),
    (lambda s: recoloured(s, lights=(s.lights[0], dataclasses.replace(s.lights[1], casts_shadow=False))),
     "light 1 moved or changed its shape, shadows"),
    (lambda s: recoloured(s, lights=s.lights[:1]), "added or removed"),
    (lambda s: recoloured(s, environment=Environment(s.environment.radiance[::-1].copy())), "environment"),
    (lambda s: recoloured(s, two_sided=np.ones(len(s.triangles), bool)), "two sided"),
])
def test_anything_but_colours_is_baked_afresh(change, reason):
    scene = lit_by_everything()
    session = BakeSession(**KNOBS)
    session.bake(scene)
    changed = change(scene)
    assert reason in session.change(changed)
    result = session.bake(changed)
    assert not result.stats["resolved"]
    assert_same_colours(result, bake(changed, **KNOBS))
    assert session.change(changed) is None  # the new bake is the one kept


def test_a_bake_cancelled_even_at_its_last_report_keeps_nothing():
    """A cancel heard at the last report ("done"), when the bake's own thread has nothing left to
    stop at: the session keeps nothing, and a re-solve after a cancelled one keeps its first
    bake."""
    scene = lit_room()
    session = BakeSession(**KNOBS)
    stop_at_done = lambda fraction, message: message != "done"  # noqa: E731
    with pytest.raises(BakeCancelled):
        session.bake(scene, stop_at_done)
    stop_abandoned()  # the bake's thread has finished
    assert session.change(scene) == "nothing was baked yet"
    session.bake(scene)
    with pytest.raises(BakeCancelled):
        session.bake(recoloured(scene, reflectance=0.9 * scene.reflectance), stop_at_done)
    stop_abandoned()
    assert session.bake(scene).stats["resolved"]


def test_a_sky_that_was_black_is_baked_afresh():
    session = BakeSession(**KNOBS)
    session.bake(lit_room())
    assert "sky was black" in session.change(recoloured(lit_room(), sky=[1.0, 1.0, 1.0]))


def test_colours_that_split_a_merged_flat_region_bake_afresh():
    """A floor of 16 x 16 small squares is merged into panels of half its size; a new colour on
    one of its triangles (same material) would need the panels cut again."""
    vertices, triangles = grid([0, 0, 0], [1, 0, 0], [0, 1, 0], 16)
    count = len(triangles)
    scene = Scene(vertices, triangles, np.full((count, 3), 0.5), np.zeros((count, 3)),
                  material=np.zeros(count, np.int64), sky=[1.0, 1.0, 1.0])
    session = BakeSession(**dict(KNOBS, patch_size=0.5))
    first = session.bake(scene)
    assert first.stats["panels"] < count
    assert session.change(recoloured(scene, reflectance=np.full((count, 3), 0.3))) is None
    reflectance = np.full((count, 3), 0.5)
    reflectance[5] = 0.2
    assert "inside a flat region" in session.change(recoloured(scene, reflectance=reflectance))


def test_the_sharp_light_is_kept_point_by_point_and_measured_only_where_new():
    """``ArrivingLight.sharp`` with ``kept``: asked at a second set of points that shares some
    with the first (in another order), it measures the form factors to the emitters and the
    lights' shadows only at the new points, and gives at every point what a light without
    ``kept`` measures afresh (the truth), to the bit; read coarsely, points are kept apart from
    the same points read finely; emitters that change clear what was kept."""
    from core.mesh.discretize import discretize
    from core.transport.arriving import ArrivingLight
    from core.transport.direct import DirectLighting
    from core.transport.formfactors import FormFactorEngine

    scene = dataclasses.replace(lit_room(), lights=(PointLight((0.3, 0.6, 0.8), (1.0, 0.9, 0.8)),))
    mesh = discretize(scene, 0.25)
    engine = FormFactorEngine(mesh, "raycast", 64, 4, 0)
    direct = DirectLighting(scene.lights, scene.sky, engine.visibility, 4, 0, None)
    kept, asked = {}, []
    measure = engine.emitter_form_factors
    engine.emitter_form_factors = lambda points, normals, finely=True: (asked.append(len(points)),
                                                                        measure(points, normals, finely))[1]
    light = ArrivingLight(engine, direct, 3, kept=kept)
    afresh = ArrivingLight(engine, direct, 3)
    points, normals = mesh.node_points, mesh.node_normals
    first, second = np.arange(0, len(points), 2), np.arange(len(points) - 1, -1, -3)
    np.testing.assert_array_equal(light.sharp(points[first], normals[first]),
                                  afresh.sharp(points[first], normals[first]))
    new = np.setdiff1d(second, first)
    asked.clear()
    np.testing.assert_array_equal(light.sharp(points[second], normals[second]),
                                  afresh.sharp(points[second], normals[second]))
    assert asked[0] == len(new) and len(new) < len(second)
    assert len(kept["points"]) == len(np.union1d(first, second))
    # read coarsely, points across the edge of the plate's shadow on the floor (where the two
    # readings differ) are measured again and kept apart
    across = np.stack([np.linspace(0.05, 0.95, 19), np.full(19, 0.45), np.zeros(19)], axis=1)
    up = np.tile([0.0, 0.0, 1.0], (19, 1))
    finely = light.sharp(across, up)
    asked.clear()
    coarsely = light.sharp(across, up, finely=False)
    np.testing.assert_array_equal(coarsely, afresh.sharp(across, up, finely=False))
    assert asked[0] == 19 and len(kept["coarse"]["points"]) == 19 and (coarsely != finely).any()
    np.testing.assert_array_equal(light.sharp(across, up), finely)
    brighter = dataclasses.replace(mesh, patch_emission=np.where(mesh.patch_emission.any(axis=1, keepdims=True),
                                                                 mesh.patch_emission, 0.5))
    light.engine.mesh = brighter
    asked.clear()
    light.sharp(points[first], normals[first])
    assert asked[0] == len(first) and len(kept["points"]) == len(first) and "coarse" not in kept
