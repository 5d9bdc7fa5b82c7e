"""Colours that vary over a surface, read per face: an Image Texture through the UVs, a Color
Attribute, as base colour or emission. Each face's colour is checked against the image's (or the
attribute's) mean over that face, computed here from the function the image holds."""

import bpy
import numpy as np

from tests.addon.blender_scenes import corner_colours, light_object

E = 2.0  # the sun's irradiance


def uv_grid(name: str, cuts: int = 4):
    bpy.ops.mesh.primitive_grid_add(x_subdivisions=cuts, y_subdivisions=cuts, size=2.0, calc_uvs=True)
    obj = bpy.context.active_object
    obj.name = name
    return obj


def linear_image(size: int = 64):
    """A float image holding (0.8 u, 0.8 (1 - v), 0.4) at each pixel's centre (u, v)."""
    image = bpy.data.images.new("ramp", size, size, float_buffer=True)
    centres = (np.arange(size) + 0.5) / size
    u, v = np.meshgrid(centres, centres)  # row 0 at v = 0, as Blender stores pixels
    pixels = np.stack([0.8 * u, 0.8 * (1 - v), np.full_like(u, 0.4), np.ones_like(u)], axis=2)
    image.pixels.foreach_set(pixels.astype(np.float32).ravel())
    return image


def textured_material(name: str, image=None, attribute: str | None = None, emission_strength: float | None = None):
    material = bpy.data.materials.new(name)
    material.use_nodes = True
    nodes, links = material.node_tree.nodes, material.node_tree.links
    if image is not None:
        source = nodes.new("ShaderNodeTexImage")
        source.image = image
    else:
        source = nodes.new("ShaderNodeVertexColor")
        source.layer_name = attribute
    if emission_strength is None:
        shader = nodes["Principled BSDF"]
        shader.inputs["Specular IOR Level"].default_value = 0.0
        links.new(source.outputs["Color"], shader.inputs["Base Color"])
    else:
        nodes.remove(nodes["Principled BSDF"])
        shader = nodes.new("ShaderNodeEmission")
        shader.inputs["Strength"].default_value = emission_strength
        links.new(source.outputs["Color"], shader.inputs["Color"])
        links.new(shader.outputs[0], nodes["Material Output"].inputs["Surface"])
    return material


def face_uv_centres(obj) -> np.ndarray:
    """(L, 2) the mean UV of each loop's face, for every loop."""
    mesh = obj.data
    uv = np.empty(len(mesh.loops) * 2, dtype=np.float32)
    mesh.uv_layers.active.uv.foreach_get("vector", uv)
    uv = uv.reshape(-1, 2)
    loop_face = np.empty(len(mesh.loops), dtype=np.int64)
    for face in mesh.polygons:
        loop_face[face.loop_start:face.loop_start + face.loop_total] = face.index
    centres = np.array([uv[loop_face == f].mean(axis=0) for f in range(len(mesh.polygons))])
    return centres[loop_face]


def test_an_image_texture_is_read_over_each_face():
    """A linear image's mean over a square face is its value at the face's centre (to half a pixel)."""
    plane = uv_grid("Plane")
    plane.data.materials.append(textured_material("Ramp", linear_image()))
    light_object("Sun", "SUN", (0, 0, 5), E)
    assert bpy.ops.radiosity.bake() == {"FINISHED"}
    _, colours = corner_colours(plane)
    centre = face_uv_centres(plane)
    reflectance = np.stack([0.8 * centre[:, 0], 0.8 * (1 - centre[:, 1]), np.full(len(centre), 0.4)], axis=1)
    assert np.ptp(reflectance[:, 0]) > 0.5  # the faces do differ
    np.testing.assert_allclose(colours[:, :3], reflectance * E / np.pi, atol=0.8 * 0.5 / 64 * E / np.pi)


def test_an_emission_texture_is_read_over_each_face():
    plane = uv_grid("Glow")
    plane.data.materials.append(textured_material("Glow", linear_image(), emission_strength=3.0))
    assert bpy.ops.radiosity.bake() == {"FINISHED"}
    _, colours = corner_colours(plane)
    centre = face_uv_centres(plane)
    emission = 3.0 * np.stack([0.8 * centre[:, 0], 0.8 * (1 - centre[:, 1]), np.full(len(centre), 0.4)], axis=1)
    np.testing.assert_allclose(colours[:, :3], emission, atol=3.0 * 0.8 * 0.5 / 64)


def test_a_color_attribute_feeding_the_base_colour_is_read_over_each_face():
    """Per face, the area mean of the attribute's linear interpolant: on a square face split in
    two equal triangles, the mean over the triangles of the mean of their three corners."""
    plane = uv_grid("Painted", cuts=3)
    mesh = plane.data
    layer = mesh.color_attributes.new("Paint", "FLOAT_COLOR", "CORNER")
    paint = np.random.default_rng(3).uniform(0.1, 0.9, (len(mesh.loops), 4)).astype(np.float32)
    layer.data.foreach_set("color", paint.ravel())
    mesh.materials.append(textured_material("Paint", attribute="Paint"))
    light_object("Sun", "SUN", (0, 0, 5), E)
    mesh.calc_loop_triangles()
    expected = np.zeros((len(mesh.polygons), 3))
    for triangle in mesh.loop_triangles:
        expected[triangle.polygon_index] += paint[list(triangle.loops), :3].mean(axis=0) / 2
    assert bpy.ops.radiosity.bake() == {"FINISHED"}
    _, colours = corner_colours(plane)
    loop_face = np.concatenate([[face.index] * face.loop_total for face in mesh.polygons])
    np.testing.assert_allclose(colours[:, :3], expected[loop_face] * E / np.pi, rtol=1e-5)
