"""An HDRI world (Environment Texture into the Background) lights the scene by direction: an image
bright above its horizon and black below gives a plane facing up rho x radiance x strength (it
sees all of that half-sky) and, turned upside down by a Mapping's rotation, nothing."""

import math

import bpy
import numpy as np
import pytest

from tests.addon.blender_scenes import corner_colours, diffuse_material, grid_object

RHO, RADIANCE, STRENGTH = 0.5, 2.0, 1.5


def half_sky_world(turn_x: float | None = None) -> None:
    image = bpy.data.images.new("half sky", 64, 32, float_buffer=True)
    pixels = np.zeros((32, 64, 4), dtype=np.float32)
    pixels[16:, :, :3] = RADIANCE  # rows from the bottom: the upper half is above the horizon
    pixels[..., 3] = 1.0
    image.pixels.foreach_set(pixels.ravel())
    world = bpy.data.worlds.new("sky")
    bpy.context.scene.world = world
    world.use_nodes = True
    nodes, links = world.node_tree.nodes, world.node_tree.links
    texture = nodes.new("ShaderNodeTexEnvironment")
    texture.image = image
    background = nodes["Background"]
    background.inputs["Strength"].default_value = STRENGTH
    links.new(texture.outputs["Color"], background.inputs["Color"])
    if turn_x is not None:
        mapping = nodes.new("ShaderNodeMapping")
        mapping.inputs["Rotation"].default_value = (turn_x, 0.0, 0.0)
        coordinates = nodes.new("ShaderNodeTexCoord")
        links.new(coordinates.outputs["Generated"], mapping.inputs["Vector"])
        links.new(mapping.outputs["Vector"], texture.inputs["Vector"])


@pytest.mark.parametrize("turn_x, seen", [(None, 1.0), (math.pi, 0.0)])
def test_a_plane_facing_up_sees_the_half_sky_above_it(turn_x, seen):
    floor = grid_object("Floor", 2.0, 2, material=diffuse_material("Grey", (RHO, RHO, RHO)))
    half_sky_world(turn_x)
    settings = bpy.context.scene.radiosity
    settings.two_sided = False  # the floor's underside would see the other half
    assert bpy.ops.radiosity.bake() == {"FINISHED"}
    _, colours = corner_colours(floor)
    np.testing.assert_allclose(colours[:, :3], seen * RHO * RADIANCE * STRENGTH, atol=0.01 * RHO * RADIANCE * STRENGTH)
