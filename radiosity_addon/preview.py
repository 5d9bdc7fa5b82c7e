"""A picture of the baked colours: Cycles renders the scene from its camera with every surface
replaced by an emitter of its colour attribute (no lighting, so it shows exactly the bake, with
Gouraud interpolation), in the scene's own colour management. Settings are restored after."""

from __future__ import annotations

import bpy

# Samples per pixel: only anti-aliasing, as there is no lighting to sample.
SAMPLES = 16


def render_colours(scene, attribute: str, path: str) -> None:
    """Render ``scene`` showing colour attribute ``attribute`` into the PNG ``path``."""
    if scene.camera is None:
        raise ValueError("the scene has no camera to render the picture from")
    material = _attribute_emitter(attribute)
    render, view_layer = scene.render, bpy.context.view_layer
    saved = (render.engine, render.filepath, render.image_settings.file_format, scene.cycles.samples,
             scene.cycles.max_bounces, view_layer.material_override)
    try:
        render.engine = "CYCLES"
        render.filepath = path
        render.image_settings.file_format = "PNG"
        scene.cycles.samples = SAMPLES
        scene.cycles.max_bounces = 0
        view_layer.material_override = material
        bpy.ops.render.render(write_still=True, scene=scene.name)
    finally:
        (render.engine, render.filepath, render.image_settings.file_format, scene.cycles.samples,
         scene.cycles.max_bounces, view_layer.material_override) = saved
        bpy.data.materials.remove(material)


def _attribute_emitter(attribute: str):
    material = bpy.data.materials.new("radiosity preview")
    material.use_nodes = True
    nodes, links = material.node_tree.nodes, material.node_tree.links
    nodes.clear()
    source = nodes.new("ShaderNodeAttribute")
    source.attribute_name = attribute
    emission = nodes.new("ShaderNodeEmission")
    output = nodes.new("ShaderNodeOutputMaterial")
    links.new(source.outputs["Color"], emission.inputs["Color"])
    links.new(emission.outputs["Emission"], output.inputs["Surface"])
    return material
