"""Re-baking after colour changes (the session kept between bakes), Live, and light groups.

The independent truth each time is a fresh bake, in a new session, of the scene as it is then:
a re-solve solves the same system on the same patches with the same rays, so the two agree to
rounding, except that a new reflectance renumbers the near field's interpolation nodes, which then
draw other stratified rays (1e-5 of the largest colour measured in tests/core/test_session.py):
RESOLVED of the largest colour. Light groups add up to the whole bake because radiosity is linear
in its sources; each re-solve stops at the default tolerance of 1e-3 of its own light, so the sum
is held to a few of those (GROUPS_ADD_UP).
"""

import bpy
import numpy as np
import pytest

from tests.addon.blender_scenes import (
    corner_colours, diffuse_material, emission_material, grid_object, light_object, world_colour,
)

RESOLVED = 1e-4
GROUPS_ADD_UP = 5e-3


@pytest.fixture
def room():
    """A floor lit by a sun, a point light, a glowing panel and the sky."""
    floor = grid_object("Floor", material=diffuse_material("Floor", (0.6, 0.5, 0.4)))
    grid_object("Panel", 1.0, 2, location=(0, 0, 1.0), material=emission_material("Glow", (1, 0.9, 0.8), 5.0),
                facing_down=True)
    light_object("Sun", "SUN", (0, 0, 5), 2.0, rotation=(0.3, 0, 0))
    light_object("Lamp", "POINT", (1, 1, 0.5), 50.0)
    world_colour((0.2, 0.3, 0.5), 1.0)
    bpy.context.scene.radiosity.patch_size = 0.5
    bpy.context.scene.radiosity.preset = "CUSTOM"
    return floor


def bake_with_session(addon, keep=True):
    """Bake as the panel's button does in the user interface: with the session kept."""
    baking = addon.radiosity_addon.baking
    bpy.context.view_layer.update()
    prepared = baking.prepare(bpy.context.scene, keep=keep)
    baked = baking.run_straight(prepared, echo=False)
    baked.result.stats["summary"] = baking.finish(prepared, baked).summary
    return baked.result


def fresh_colours(addon, obj, name="Radiosity"):
    """The colours of a bake of the scene as it is, in a new session (then restores nothing: the
    attribute holds the fresh bake's colours)."""
    addon.radiosity_addon.sessions.forget()
    bake_with_session(addon, keep=False)
    return corner_colours(obj, name)[1]


def assert_close(actual, expected, tolerance=RESOLVED):
    np.testing.assert_allclose(actual, expected, rtol=0, atol=tolerance * np.abs(expected).max())


def test_a_bake_after_colour_changes_re_solves_as_a_fresh_bake_would(addon, room):
    assert not bake_with_session(addon).stats["resolved"]
    set_base_colour(bpy.data.materials["Floor"], (0.2, 0.5, 0.8))
    bpy.data.lights["Sun"].energy = 5.0
    bpy.data.lights["Lamp"].color = (1.0, 0.2, 0.2)
    bpy.data.worlds["sky"].node_tree.nodes["Background"].inputs["Strength"].default_value = 2.0
    result = bake_with_session(addon)
    assert result.stats["resolved"] and "discretise" not in result.stats["seconds"]
    assert result.stats["summary"].startswith("Re-solved radiosity into 'Radiosity' on 2 object(s)")
    again = corner_colours(room)[1]
    assert_close(again, fresh_colours(addon, room))


def set_base_colour(material, colour) -> None:
    for node in material.node_tree.nodes:
        if "Base Color" in node.inputs:
            node.inputs["Base Color"].default_value = (*colour, 1.0)
        elif "Color" in node.inputs:
            node.inputs["Color"].default_value = (*colour, 1.0)


def test_moving_an_object_or_a_light_bakes_afresh(addon, room):
    bake_with_session(addon)
    session = addon.radiosity_addon.sessions.kept(bpy.context.scene.name)
    bpy.data.objects["Lamp"].location.x += 0.5
    bpy.context.view_layer.update()
    prepared = addon.radiosity_addon.baking.prepare(bpy.context.scene, keep=True)
    assert prepared.session is session and "light 1 moved" in session.change(prepared.extraction.scene)
    assert not bake_with_session(addon).stats["resolved"]
    bpy.data.objects["Panel"].location.z = 1.2
    assert not bake_with_session(addon).stats["resolved"]


def test_live_follows_colours_and_pauses_on_geometry(addon, room):
    live = addon.radiosity_addon.live
    settings = bpy.context.scene.radiosity
    bake_with_session(addon)
    settings.live = True
    for colour, energy in (((0.1, 0.7, 0.2), 10.0), ((0.9, 0.9, 0.1), 1.0)):
        set_base_colour(bpy.data.materials["Floor"], colour)
        bpy.data.lights["Lamp"].energy = energy
        bpy.context.view_layer.update()  # Blender calls the depsgraph handler
        live.tick()  # and, a moment later, the timer
        assert settings.live_status.startswith("Live: re-solved"), settings.live_status
        live_colours = corner_colours(room)[1]
        expected = fresh_colours(addon, room)
        assert_close(live_colours, expected)
        bake_with_session(addon)  # the kept session again (fresh_colours dropped it)
    before = corner_colours(room)[1]
    bpy.data.objects["Lamp"].location.x += 0.5
    bpy.data.lights["Lamp"].energy = 20.0
    bpy.context.view_layer.update()
    live.tick()
    assert settings.live_status.startswith("Live paused: light 1 moved"), settings.live_status
    np.testing.assert_array_equal(corner_colours(room)[1], before)
    settings.live = False
    assert settings.live_status == ""


def test_freeing_the_kept_bake_makes_the_next_bake_start_afresh(addon, room):
    sessions = addon.radiosity_addon.sessions
    bake_with_session(addon)
    assert sessions.kept(bpy.context.scene.name).kept_bytes > 0
    bpy.context.scene.radiosity.live = True
    assert bpy.ops.radiosity.forget() == {"FINISHED"}
    assert sessions.kept(bpy.context.scene.name) is None and not bpy.context.scene.radiosity.live
    assert not bake_with_session(addon).stats["resolved"]


def test_each_light_group_gets_its_light_and_together_they_make_the_whole(addon, room):
    scene = bpy.context.scene
    for name in ("Sun",):
        bpy.data.objects[name].lightgroup = "day"
    bpy.data.worlds["sky"].lightgroup = "day"
    for name in ("Lamp", "Panel"):
        bpy.data.objects[name].lightgroup = "night"
    scene.radiosity.light_groups = True
    result = bake_with_session(addon, keep=False)
    whole, day, night = (corner_colours(room, name)[1] for name in ("Radiosity", "Radiosity day", "Radiosity night"))
    assert "Radiosity' and 2 light group(s) on 2 object(s)" in result.stats["summary"]
    assert np.abs(day).max() > 0.05 * np.abs(whole).max() and np.abs(night).max() > 0.05 * np.abs(whole).max()
    assert_close(day[:, :3] + night[:, :3], whole[:, :3], GROUPS_ADD_UP)
    # night alone: the same scene with the day's sources dark, baked afresh
    scene.radiosity.light_groups = False
    bpy.data.lights["Sun"].energy = 0.0
    bpy.data.worlds["sky"].node_tree.nodes["Background"].inputs["Strength"].default_value = 0.0
    assert_close(night, fresh_colours(addon, room))
    assert result.stats["lights"] == 2
