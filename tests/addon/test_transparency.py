"""See-through materials: a Principled alpha, a Transparent BSDF mixed in, and an Image Texture's
alpha through UVs let light through in proportion.

A sun straight down at strength S gives S / pi of lighting on a floor in the open; under a plate
that stops the share a it gives (1 - a) S / pi (closed form: there is no sky, and the plate is
black, so it reflects nothing down). Measured with Lighting Only output
at floor corners well inside the plate's shadow, to float32 storage (EXACT).
"""

import math

import bpy
import numpy as np
import pytest

from tests.addon.blender_scenes import bake_in_background, corner_colours, diffuse_material, grid_object, light_object

SUN = 2.0
EXACT = 1e-5


def plate_material(kind: str, value: float):
    """A black material that stops the share ``value`` of the light: Principled with that alpha,
    or a Mix of a Transparent BSDF and a black Diffuse BSDF by that factor."""
    material = bpy.data.materials.new(kind)
    material.use_nodes = True
    nodes, links = material.node_tree.nodes, material.node_tree.links
    output = nodes["Material Output"]
    if kind == "alpha":
        principled = nodes["Principled BSDF"]
        principled.inputs["Base Color"].default_value = (0, 0, 0, 1)
        principled.inputs["Specular IOR Level"].default_value = 0.0
        principled.inputs["Alpha"].default_value = value
        return material
    nodes.remove(nodes["Principled BSDF"])
    mix, transparent, diffuse = (nodes.new(kind) for kind in ("ShaderNodeMixShader", "ShaderNodeBsdfTransparent",
                                                              "ShaderNodeBsdfDiffuse"))
    diffuse.inputs["Color"].default_value = (0, 0, 0, 1)
    mix.inputs["Fac"].default_value = value
    links.new(transparent.outputs[0], mix.inputs[1])
    links.new(diffuse.outputs[0], mix.inputs[2])
    links.new(mix.outputs[0], output.inputs["Surface"])
    return material


def floor_under_a_plate(material):
    floor = grid_object("Floor", 4.0, 8, material=diffuse_material("Floor", (0.5, 0.5, 0.5)))
    grid_object("Plate", 2.0, 2, location=(0, 0, 1.0), material=material, facing_down=True)
    light_object("Sun", "SUN", (0, 0, 5), SUN)  # straight down
    settings = bpy.context.scene.radiosity
    settings.output, settings.preset, settings.patch_size = "LIGHTING", "CUSTOM", 0.5
    bpy.data.lights["Sun"].angle = 0.0  # sharp shadows: the plate's edge casts no penumbra inward
    return floor


def lighting_under_and_beside(floor) -> tuple[np.ndarray, np.ndarray]:
    positions, colours = corner_colours(floor)
    inner = (np.abs(positions[:, :2]) < 0.6).all(axis=1)
    outer = (np.abs(positions[:, :2]) > 1.4).any(axis=1)
    return colours[inner, 0], colours[outer, 0]


@pytest.mark.parametrize("kind, stops", [("alpha", 0.4), ("mix", 0.25), ("alpha", 1.0), ("mix", 0.0)])
def test_a_see_through_plate_passes_the_light_it_does_not_stop(kind, stops):
    floor = floor_under_a_plate(plate_material(kind, stops))
    assert bake_in_background() == {"FINISHED"}
    under, beside = lighting_under_and_beside(floor)
    assert len(under) >= 4 and len(beside) >= 4
    np.testing.assert_allclose(beside, SUN / math.pi, rtol=EXACT)
    np.testing.assert_allclose(under, (1 - stops) * SUN / math.pi, rtol=EXACT, atol=1e-7)


def test_an_alpha_texture_lets_light_through_where_it_is_clear(addon):
    """A plate of two faces (x < 0 and x > 0) whose UVs span an image clear (alpha 0) on its left
    half and solid (alpha 1) on its right: the floor under the left face is in full sun, under the
    right face in shadow."""
    image = bpy.data.images.new("leaf", 2, 1, alpha=True, float_buffer=True)
    image.pixels.foreach_set(np.array([0.1, 0.5, 0.1, 0.0, 0.1, 0.5, 0.1, 1.0], dtype=np.float32))
    material = plate_material("alpha", 1.0)
    nodes, links = material.node_tree.nodes, material.node_tree.links
    texture = nodes.new("ShaderNodeTexImage")
    texture.image, texture.interpolation = image, "Closest"
    links.new(texture.outputs["Alpha"], nodes["Principled BSDF"].inputs["Alpha"])
    floor = floor_under_a_plate(material)
    plate = bpy.data.objects["Plate"]
    bpy.context.view_layer.objects.active = plate
    plate.data.uv_layers.new(name="UVMap")
    # u = x / 2 + 1/2 over the 2 x 2 plate: faces at x < 0 read the clear pixel, at x > 0 the solid one
    vertex = np.array([loop.vertex_index for loop in plate.data.loops])
    positions = np.array([plate.data.vertices[index].co[:2] for index in vertex])
    plate.data.uv_layers["UVMap"].uv.foreach_set("vector", (positions / 2.0 + 0.5).astype(np.float32).ravel())
    assert bake_in_background() == {"FINISHED"}
    positions, colours = corner_colours(floor)
    clear = (np.abs(positions[:, 1]) < 0.6) & (positions[:, 0] > -0.9) & (positions[:, 0] < -0.1)
    solid = (np.abs(positions[:, 1]) < 0.6) & (positions[:, 0] > 0.1) & (positions[:, 0] < 0.9)
    assert clear.sum() >= 2 and solid.sum() >= 2
    np.testing.assert_allclose(colours[clear, 0], SUN / math.pi, rtol=EXACT)
    np.testing.assert_allclose(colours[solid, 0], 0.0, atol=1e-7)
    assert not any("alpha" in note.lower() for note in addon.radiosity_addon.baking.prepare(
        bpy.context.scene).extraction.notes)
