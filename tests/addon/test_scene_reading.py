"""The bake reads the scene as a Cycles render does: what renders lights, shades and gets colours,
whatever the viewport shows; what does not render takes no part. A grey floor under a sun of
irradiance 2 W/m^2 has radiosity rho E / pi = 0.5 x 2 / pi unshaded, and none under a roof that
covers it (the roof's lit top sends its light up, away from the floor)."""

import bpy
import numpy as np
import pytest

from tests.addon.blender_scenes import corner_colours, diffuse_material, grid_object, light_object

LIT = 0.5 * 2.0 / np.pi


def floor_under_roof():
    grey = diffuse_material("Grey", (0.5, 0.5, 0.5))
    floor = grid_object("Floor", 2.0, 2, material=grey)
    roof = grid_object("Roof", 4.0, 1, location=(0, 0, 1), material=grey)
    light_object("Sun", "SUN", (0, 0, 5), 2.0)
    return floor, roof


def bake() -> None:
    assert bpy.ops.radiosity.bake() == {"FINISHED"}


def floor_radiosity(floor) -> np.ndarray:
    return corner_colours(floor)[1][:, :3]


def move_to_new_collection(obj, name: str):
    collection = bpy.data.collections.new(name)
    bpy.context.scene.collection.children.link(collection)
    for owner in list(obj.users_collection):
        owner.objects.unlink(obj)
    collection.objects.link(obj)
    return collection


def test_the_roof_shades_the_floor():
    floor, roof = floor_under_roof()
    bake()
    assert np.allclose(floor_radiosity(floor), 0, atol=1e-6)
    assert "Radiosity" in roof.data.color_attributes


@pytest.mark.parametrize("hide", ["object", "collection", "excluded collection"])
def test_what_does_not_render_neither_shades_nor_gets_colours(hide):
    floor, roof = floor_under_roof()
    if hide == "object":
        roof.hide_render = True
    else:
        collection = move_to_new_collection(roof, "Hidden")
        if hide == "collection":
            collection.hide_render = True
        else:
            bpy.context.view_layer.layer_collection.children[collection.name].exclude = True
    bake()
    assert np.allclose(floor_radiosity(floor), LIT, rtol=1e-3)
    assert "Radiosity" not in roof.data.color_attributes


@pytest.mark.parametrize("hide", ["object", "eye", "collection"])
def test_what_renders_but_is_hidden_in_the_viewport_shades_and_gets_colours(hide):
    floor, roof = floor_under_roof()
    if hide == "object":
        roof.hide_viewport = True
    elif hide == "eye":
        roof.hide_set(True)
    else:
        move_to_new_collection(roof, "Hidden").hide_viewport = True
    bake()
    assert np.allclose(floor_radiosity(floor), 0, atol=1e-6)
    assert "Radiosity" in roof.data.color_attributes


def test_a_light_that_does_not_render_does_not_light():
    floor = grid_object("Floor", 2.0, 2, material=diffuse_material("Grey", (0.5, 0.5, 0.5)))
    light_object("Sun", "SUN", (0, 0, 5), 2.0)
    light_object("Off", "SUN", (0, 0, 5), 7.0).hide_render = True
    bake()
    assert np.allclose(floor_radiosity(floor), LIT, rtol=1e-3)


def test_reading_the_render_changes_nothing_in_the_file():
    """The render settings the reading render sets are restored; no camera, image or engine is
    left behind; the scene's own camera stays."""
    floor_under_roof()
    scene = bpy.context.scene
    render = scene.render
    render.engine, render.resolution_x, render.resolution_percentage = "CYCLES", 1234, 37
    render.use_compositing, render.use_border = True, True
    before = (render.engine, render.resolution_x, render.resolution_y, render.resolution_percentage,
              render.use_compositing, render.use_sequencer, render.use_border)
    counts = (len(bpy.data.objects), len(bpy.data.cameras), len(bpy.data.images))
    bake()
    assert (render.engine, render.resolution_x, render.resolution_y, render.resolution_percentage,
            render.use_compositing, render.use_sequencer, render.use_border) == before
    assert (len(bpy.data.objects), len(bpy.data.cameras), len(bpy.data.images)) == counts
    assert scene.camera is None
    assert "RADIOSITY_SCENE_READER" not in render.bl_rna.properties["engine"].enum_items.keys()


def test_a_view_layer_that_does_not_render_is_refused():
    floor_under_roof()
    bpy.context.view_layer.use = False
    with pytest.raises(RuntimeError, match="disabled for rendering"):
        bpy.ops.radiosity.bake()


def test_a_mesh_linked_from_a_library_is_refused_by_name(tmp_path):
    """Colours written to linked data are not saved with the file: the bake says so, naming the
    object, and writes nothing."""
    grid_object("Prop", 1.0, 1)
    library = str(tmp_path / "props.blend")
    bpy.ops.wm.save_as_mainfile(filepath=library)
    bpy.ops.wm.read_homefile(use_factory_startup=True, use_empty=True)
    floor = grid_object("Floor", 2.0, 2, material=diffuse_material("Grey", (0.5, 0.5, 0.5)))
    light_object("Sun", "SUN", (0, 0, 5), 2.0)
    with bpy.data.libraries.load(library, link=True) as (source, linked):
        linked.objects = ["Prop"]
    bpy.context.scene.collection.objects.link(linked.objects[0])
    with pytest.raises(RuntimeError, match=r"object 'Prop' has its mesh linked from .*props\.blend"):
        bpy.ops.radiosity.bake()
    assert "Radiosity" not in floor.data.color_attributes


@pytest.mark.parametrize("angle, contact_share", [(0.0, 1.0), (0.00918, 0.5)])
def test_a_wall_standing_on_the_floor_s_edge_under_the_sun(angle, contact_share):
    """The sun straight down beside a vertical wall standing on the floor's edge: a sun of no size
    leaves the whole floor in its light, rho E / pi at least; one of Blender's default angle
    (0.526 degrees) hides the half of its disc leaning towards the wall from the floor's corners
    on the contact line (in the middle of the wall: half its light there, as in Cycles)."""
    floor = grid_object("Floor", 2.0, 2, material=diffuse_material("Grey", (0.5, 0.5, 0.5)))
    light_object("Sun", "SUN", (0, 0, 5), 2.0, angle=angle)
    bpy.ops.mesh.primitive_plane_add(size=2.0, location=(1.0, 0.0, 1.0), rotation=(0.0, -np.pi / 2, 0.0))
    bpy.context.active_object.radiosity.reflects = False  # only the sun's light on the floor
    bpy.context.scene.radiosity.separate_direct = True
    assert bpy.ops.radiosity.bake() == {"FINISHED"}
    positions, direct = corner_colours(floor, "Radiosity Direct")
    middle = np.isclose(positions[:, 0], 1.0) & np.isclose(positions[:, 1], 0.0)
    lit = 0.5 * 2.0 / np.pi
    np.testing.assert_allclose(direct[middle, :3], contact_share * lit, rtol=0.02)
    np.testing.assert_allclose(direct[positions[:, 0] < 0.5, :3], lit, rtol=1e-3)
