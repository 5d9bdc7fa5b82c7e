"""The scene as a render sees it: ``read_as_rendered`` hands a function the depsgraph Blender
evaluates for a render (render visibility of objects and collections, render modifier levels,
render instancing), which Python cannot build directly.

Blender makes that depsgraph only for a render engine, so this module registers a small engine
for the length of one call (it never shows in the engine menu) and renders one still with it: the
scene's engine, compositing, sequencer and resolution are set for that call and restored after
it, a camera is lent when the scene has none (Blender renders nothing without one), and the
Render Result image is removed again if the call made it. Nothing is written to disk.
"""

from __future__ import annotations

from typing import Callable, TypeVar

import bpy

Result = TypeVar("Result")


class RADIOSITY_RE_scene_reader(bpy.types.RenderEngine):
    """Runs the pending reader on the render depsgraph of the wanted view layer."""

    bl_idname = "RADIOSITY_SCENE_READER"
    bl_label = "Radiosity scene reader"
    bl_use_postprocess = False
    bl_use_preview = False

    pending: dict = {}

    def render(self, depsgraph):
        pending = type(self).pending
        if not pending or depsgraph.view_layer.name != pending["view_layer"]:
            return
        try:
            pending["result"] = pending["read"](depsgraph)
        except BaseException as error:  # Blender prints and swallows what a render raises
            pending["error"] = error


# Render settings set for the reading render: (owner path, attribute, value during it).
_READING_SETTINGS = (
    ("render", "engine", RADIOSITY_RE_scene_reader.bl_idname),
    ("render", "use_compositing", False),
    ("render", "use_sequencer", False),
    ("render", "resolution_x", 64),
    ("render", "resolution_y", 64),
    ("render", "resolution_percentage", 100),
    ("render", "use_border", False),
)


def read_as_rendered(scene, view_layer, read: Callable[[object], Result]) -> Result:
    """``read(depsgraph)`` on the render depsgraph of ``scene``'s ``view_layer``; re-raises what
    ``read`` raised; ValueError when the view layer is not rendered."""
    if not view_layer.use:
        raise ValueError(f"view layer '{view_layer.name}' is disabled for rendering (Use for Rendering): "
                         "enable it, or bake from a view layer that renders")
    had_result = any(image.type == "RENDER_RESULT" for image in bpy.data.images)
    saved = [(getattr(scene, owner), name, getattr(getattr(scene, owner), name))
             for owner, name, _ in _READING_SETTINGS]
    camera = None
    pending = RADIOSITY_RE_scene_reader.pending
    pending.update(view_layer=view_layer.name, read=read)
    registered_here = not RADIOSITY_RE_scene_reader.is_registered
    if registered_here:
        bpy.utils.register_class(RADIOSITY_RE_scene_reader)
    try:
        for owner, name, value in _READING_SETTINGS:
            setattr(getattr(scene, owner), name, value)
        if scene.camera is None:
            camera = bpy.data.objects.new("radiosity reading camera", bpy.data.cameras.new("radiosity reading camera"))
            scene.collection.objects.link(camera)
            scene.camera = camera
        bpy.ops.render.render(scene=scene.name)
        if "error" in pending:
            raise pending["error"]
        if "result" not in pending:
            raise RuntimeError(f"Blender did not render view layer '{view_layer.name}' of scene '{scene.name}'")
        return pending["result"]
    finally:
        pending.clear()
        for owner, name, value in saved:
            setattr(owner, name, value)
        if registered_here:
            bpy.utils.unregister_class(RADIOSITY_RE_scene_reader)
        if camera is not None:
            data = camera.data
            bpy.data.objects.remove(camera)
            bpy.data.cameras.remove(data)
        if not had_result:
            for image in [image for image in bpy.data.images if image.type == "RENDER_RESULT"]:
                bpy.data.images.remove(image)
