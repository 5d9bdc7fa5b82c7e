"""Small Blender scenes built in code for the add-on tests, and readers of baked colours."""

from __future__ import annotations

import bpy
import numpy as np


def grid_object(name: str, size: float = 4.0, cells: int = 8, location=(0.0, 0.0, 0.0), material=None,
                facing_down: bool = False):
    """A flat size x size grid of cells x cells quads in the XY plane, centred at ``location``,
    facing +Z (or -Z)."""
    step = size / cells
    coords = [(-size / 2 + i * step, -size / 2 + j * step, 0.0) for j in range(cells + 1) for i in range(cells + 1)]
    faces = []
    for j in range(cells):
        for i in range(cells):
            a = j * (cells + 1) + i
            quad = (a, a + 1, a + cells + 2, a + cells + 1)
            faces.append(quad[::-1] if facing_down else quad)
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata(coords, [], faces)
    obj = bpy.data.objects.new(name, mesh)
    obj.location = location
    bpy.context.scene.collection.objects.link(obj)
    if material is not None:
        mesh.materials.append(material)
    return obj


def diffuse_material(name: str, colour, principled: bool = False):
    """A purely diffuse material: Diffuse BSDF, or Principled with no specular."""
    material = bpy.data.materials.new(name)
    material.use_nodes = True
    nodes = material.node_tree.nodes
    output = nodes["Material Output"]
    if principled:
        shader = nodes["Principled BSDF"]
        shader.inputs["Base Color"].default_value = (*colour, 1.0)
        shader.inputs["Specular IOR Level"].default_value = 0.0
        shader.inputs["Roughness"].default_value = 1.0
    else:
        nodes.remove(nodes["Principled BSDF"])
        shader = nodes.new("ShaderNodeBsdfDiffuse")
        shader.inputs["Color"].default_value = (*colour, 1.0)
    material.node_tree.links.new(shader.outputs[0], output.inputs["Surface"])
    return material


def emission_material(name: str, colour, strength: float):
    material = bpy.data.materials.new(name)
    material.use_nodes = True
    nodes = material.node_tree.nodes
    nodes.remove(nodes["Principled BSDF"])
    shader = nodes.new("ShaderNodeEmission")
    shader.inputs["Color"].default_value = (*colour, 1.0)
    shader.inputs["Strength"].default_value = strength
    material.node_tree.links.new(shader.outputs[0], nodes["Material Output"].inputs["Surface"])
    return material


def light_object(name: str, kind: str, location, energy: float, rotation=(0.0, 0.0, 0.0), colour=(1, 1, 1), **data):
    light = bpy.data.lights.new(name, kind)
    light.energy = energy
    light.color = colour
    for key, value in data.items():
        setattr(light, key, value)
    obj = bpy.data.objects.new(name, light)
    obj.location = location
    obj.rotation_euler = rotation
    bpy.context.scene.collection.objects.link(obj)
    return obj


def world_colour(colour, strength: float) -> None:
    world = bpy.data.worlds.new("sky")
    bpy.context.scene.world = world
    world.use_nodes = True
    background = world.node_tree.nodes["Background"]
    background.inputs["Color"].default_value = (*colour, 1.0)
    background.inputs["Strength"].default_value = strength


def corner_colours(obj, name: str = "Radiosity") -> tuple[np.ndarray, np.ndarray]:
    """World positions (L, 3) of each corner's vertex and the baked colours (L, 4) there."""
    mesh = obj.data
    layer = mesh.color_attributes[name]
    assert layer.domain == "CORNER" and layer.data_type == "FLOAT_COLOR"
    colours = np.empty(len(mesh.loops) * 4, dtype=np.float32)
    layer.data.foreach_get("color", colours)
    vertex = np.empty(len(mesh.loops), dtype=np.int32)
    mesh.loops.foreach_get("vertex_index", vertex)
    positions = np.empty(len(mesh.vertices) * 3, dtype=np.float32)
    mesh.vertices.foreach_get("co", positions)
    matrix = np.array(obj.matrix_world)
    world = positions.reshape(-1, 3).astype(np.float64) @ matrix[:3, :3].T + matrix[:3, 3]
    return world[vertex], colours.reshape(-1, 4).astype(np.float64)


def bake_in_background() -> set:
    """Run the operator as a script or a farm would."""
    bpy.context.view_layer.update()
    return bpy.ops.radiosity.bake()
