"""What each object plays in the bake (Object Properties > Radiosity Bake: receives, reflects,
emits), Selected Only, and the note on instances. Each switch is checked against the scene it
stands for: an object that does not reflect lights the others as a black one does, one that does
not emit as one whose emission is zero, and one that does not receive changes nobody's colours."""

import bpy
import numpy as np

from tests.addon.blender_scenes import corner_colours, diffuse_material, emission_material, grid_object, light_object


def room():
    """A floor under a tilted grey panel lit by a sun, and a small emissive tile."""
    floor = grid_object("Floor", 2.0, 4, material=diffuse_material("Grey", (0.5, 0.5, 0.5)))
    panel = grid_object("Panel", 1.0, 2, location=(0.5, 0, 0.6), material=diffuse_material("Red", (0.8, 0.2, 0.1)),
                        facing_down=True)
    panel.rotation_euler = (0.0, 0.6, 0.0)
    tile = grid_object("Tile", 0.4, 1, location=(-0.6, 0, 0.8), material=emission_material("Glow", (1, 1, 1), 3.0),
                       facing_down=True)
    light_object("Sun", "SUN", (0, 0, 5), 2.0, rotation=(0.3, 0.0, 0.0))
    return floor, panel, tile


def baked_floor(floor) -> np.ndarray:
    assert bpy.ops.radiosity.bake() == {"FINISHED"}
    return corner_colours(floor)[1][:, :3].copy()


def test_an_object_that_does_not_reflect_lights_the_others_as_a_black_one():
    floor, panel, _ = room()
    panel.radiosity.reflects = False
    without = baked_floor(floor)
    panel.radiosity.reflects = True
    panel.data.materials[0] = diffuse_material("Black", (0.0, 0.0, 0.0))
    black = baked_floor(floor)
    panel.data.materials[0] = bpy.data.materials["Red"]
    red = baked_floor(floor)
    assert np.allclose(without, black, rtol=1e-6, atol=1e-9)
    assert np.abs(red - black).max() > 0.01  # the red panel does light the floor


def test_an_object_that_does_not_emit_lights_the_others_as_a_dark_one():
    floor, _, tile = room()
    tile.radiosity.emits = False
    without = baked_floor(floor)
    tile.radiosity.emits = True
    bpy.data.materials["Glow"].node_tree.nodes["Emission"].inputs["Strength"].default_value = 0.0
    dark = baked_floor(floor)
    assert np.allclose(without, dark, rtol=1e-6, atol=1e-9)


def test_an_object_that_does_not_receive_gets_no_colours_and_changes_no_others():
    floor, panel, _ = room()
    receiving = baked_floor(floor)
    for obj in (floor, panel):
        obj.data.color_attributes.remove(obj.data.color_attributes["Radiosity"])
    panel.radiosity.receives = False
    assert np.array_equal(baked_floor(floor), receiving)
    assert "Radiosity" not in panel.data.color_attributes


def test_selected_only_writes_on_the_selected_objects_lit_by_all():
    floor, panel, tile = room()
    everything = baked_floor(floor)
    for obj in (floor, panel, tile):
        obj.data.color_attributes.remove(obj.data.color_attributes["Radiosity"])
        obj.select_set(obj is floor)
    bpy.context.scene.radiosity.selected_only = True
    assert np.array_equal(baked_floor(floor), everything)
    assert [obj.name for obj in (floor, panel, tile) if "Radiosity" in obj.data.color_attributes] == ["Floor"]


def test_selected_only_with_nothing_selected_is_refused():
    room()
    bpy.context.scene.radiosity.selected_only = True
    for obj in bpy.context.scene.objects:
        obj.select_set(False)
    try:
        bpy.ops.radiosity.bake()
    except RuntimeError as error:
        assert "no object is selected" in str(error)
    else:
        raise AssertionError("the bake ran with Selected Only and nothing selected")


def test_collection_instances_light_and_shade_but_get_a_note_not_colours(addon):
    floor, panel, _ = room()
    alone = baked_floor(floor)
    collection = bpy.data.collections.new("Props")
    for owner in list(panel.users_collection):
        owner.objects.unlink(panel)
    collection.objects.link(panel)
    bpy.context.scene.collection.children.link(collection)
    bpy.context.view_layer.layer_collection.children["Props"].exclude = True  # only its instance renders
    instancer = bpy.data.objects.new("Props here", None)
    instancer.instance_type, instancer.instance_collection = "COLLECTION", collection
    bpy.context.scene.collection.objects.link(instancer)
    notes = addon.radiosity_addon.baking.prepare(bpy.context.scene).extraction.notes
    assert any(note.startswith("'Props here': its 1 mesh instance(s) light and shade") for note in notes), notes
    panel.data.color_attributes.remove(panel.data.color_attributes["Radiosity"])
    assert np.allclose(baked_floor(floor), alone, rtol=1e-6, atol=1e-9)  # the instance lights as the panel did
    assert "Radiosity" not in panel.data.color_attributes


def test_alpha_and_a_transparent_bsdf_are_read_as_opacity(addon):
    """A Principled alpha of 0.4 stops 0.4 of the light and reflects 0.4 of its base colour; a Mix
    (factor 0.5) of a Transparent BSDF and a surface stops half and reflects half
    (tests/addon/test_transparency.py bakes the light through them)."""
    floor, panel, _ = room()
    principled = diffuse_material("Veil", (0.5, 0.5, 0.5), principled=True)
    principled.node_tree.nodes["Principled BSDF"].inputs["Alpha"].default_value = 0.4
    panel.data.materials[0] = principled
    leaves = bpy.data.materials.new("Leaves")
    leaves.use_nodes = True
    nodes, links = leaves.node_tree.nodes, leaves.node_tree.links
    nodes["Principled BSDF"].inputs["Base Color"].default_value = (0.6, 0.4, 0.2, 1.0)
    mix = nodes.new("ShaderNodeMixShader")
    links.new(nodes.new("ShaderNodeBsdfTransparent").outputs[0], mix.inputs[1])
    links.new(nodes["Principled BSDF"].outputs[0], mix.inputs[2])
    links.new(mix.outputs[0], nodes["Material Output"].inputs["Surface"])
    floor.data.materials[0] = leaves
    extraction = addon.radiosity_addon.baking.prepare(bpy.context.scene).extraction
    scene, targets = extraction.scene, {target.object_name: target for target in extraction.targets}
    veil, ground = (slice(targets[name].start, targets[name].stop) for name in (panel.name, floor.name))
    np.testing.assert_allclose(scene.opacity[veil], 0.4)
    np.testing.assert_allclose(scene.reflectance[veil], 0.4 * 0.5, rtol=1e-6)
    np.testing.assert_allclose(scene.opacity[ground], 0.5)
    np.testing.assert_allclose(scene.reflectance[ground], np.tile(0.5 * np.array([0.6, 0.4, 0.2]), (32, 1)), rtol=1e-6)
    assert not [note for note in extraction.notes if "alpha" in note.lower() or "transparent" in note.lower()]


def test_an_object_that_casts_no_shadow_lets_the_light_through():
    """Object > Visibility > Ray Visibility > Shadow off, as Cycles reads it: a roof over a floor
    under a straight-down sun no longer shades it. With the roof reflecting nothing (so that no
    light goes back and forth between it and the floor), the floor is rho E / pi, as in the open."""
    grey = diffuse_material("Grey", (0.5, 0.5, 0.5))
    floor = grid_object("Floor", 2.0, 2, material=grey)
    roof = grid_object("Roof", 4.0, 1, location=(0, 0, 1), material=grey)
    light_object("Sun", "SUN", (0, 0, 5), 2.0)
    roof.radiosity.reflects = False
    assert np.allclose(baked_floor(floor), 0, atol=1e-6)
    roof.visible_shadow = False
    assert np.allclose(baked_floor(floor), 0.5 * 2.0 / np.pi, rtol=1e-3)


def test_instances_baked_into_objects_of_their_own():
    """Advanced > Instances > Bake Into Objects: each instance of a collection becomes an object
    with a copy of the mesh, placed where the instance was, holding the light there (a tile under
    a sun, moved 3 m aside by two instancers: rho E / pi everywhere); the instancers are hidden and
    the instanced object keeps no colours."""
    tile = grid_object("Tile", 1.0, 2, material=diffuse_material("Grey", (0.5, 0.5, 0.5)))
    collection = bpy.data.collections.new("Tiles")
    for owner in list(tile.users_collection):
        owner.objects.unlink(tile)
    collection.objects.link(tile)
    bpy.context.scene.collection.children.link(collection)
    bpy.context.view_layer.layer_collection.children["Tiles"].exclude = True
    for x in (-3.0, 3.0):
        instancer = bpy.data.objects.new(f"Tiles at {x:+.0f}", None)
        instancer.instance_type, instancer.instance_collection = "COLLECTION", collection
        instancer.location = (x, 0.0, 0.0)
        bpy.context.scene.collection.objects.link(instancer)
    light_object("Sun", "SUN", (0, 0, 5), 2.0)
    bpy.context.scene.radiosity.instances = "OBJECTS"
    assert bpy.ops.radiosity.bake() == {"FINISHED"}
    for x in (-3.0, 3.0):
        copy = bpy.data.objects[f"Tiles at {x:+.0f} Tile"]
        positions, colours = corner_colours(copy)
        assert np.allclose(positions[:, 0].mean(), x) and copy.data is not tile.data
        assert np.allclose(colours[:, :3], 0.5 * 2.0 / np.pi, rtol=1e-3)
        assert bpy.data.objects[f"Tiles at {x:+.0f}"].hide_render
    assert "Radiosity" not in tile.data.color_attributes
