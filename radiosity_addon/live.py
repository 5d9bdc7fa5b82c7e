"""Live: after a bake, the colours follow the scene's. While ``scene.radiosity.live`` is on, a
change to a material, a light's data (colour, power) or the world marks the scene, and a timer
re-solves it with the session kept from its bake (``sessions``) and rewrites its attributes, at
most every TICK seconds. Anything a re-solve cannot follow (geometry, a light moved, other
settings) pauses it, with the reason in ``live_status``, until the next bake. Live writes are
not undo steps: undoing the colour change brings the old colours back by another re-solve."""

from __future__ import annotations

import time

import bpy
from bpy.app.handlers import persistent

from . import sessions
from .baking import finish, prepare, run

TICK = 0.05  # seconds between looks at the marked scenes
# What a re-solve can follow: colours and strengths live in these data-blocks (objects are left
# out: moving one, or a light, changes the geometry; the bake's own writes change meshes).
COLOUR_DATA = (bpy.types.Material, bpy.types.Light, bpy.types.World, bpy.types.ShaderNodeTree)

_marked: set[str] = set()  # names of scenes with a change not re-solved yet
_busy = False  # a live update is running: the changes it makes itself are not marked


@persistent
def _on_depsgraph_update(scene, depsgraph) -> None:
    if _busy or not scene.radiosity.live:
        return
    if any(isinstance(update.id, COLOUR_DATA) for update in depsgraph.updates):
        _marked.add(scene.name)


def tick() -> float:
    """The timer: re-solve each marked scene (``update``); returns the next interval."""
    from .operators import RADIOSITY_OT_bake

    if RADIOSITY_OT_bake.running:
        return TICK  # the bake will bring the colours up to date
    for name in list(_marked):
        _marked.discard(name)
        scene = bpy.data.scenes.get(name)
        if scene is not None and scene.radiosity.live:
            scene.radiosity.live_status = update(scene)
    return TICK


def update(scene, view_layer=None) -> str:
    """Re-solve ``scene`` with its colours now and write its attributes, if its kept session can;
    what was done, in words."""
    global _busy
    if sessions.kept(scene.name) is None:
        return "Live: bake once, then colour changes re-solve"
    _busy = True
    try:
        start = time.perf_counter()
        if view_layer is None:  # the window's, when it shows this scene; else the scene's first
            view_layer = bpy.context.view_layer if bpy.context.scene == scene else scene.view_layers[0]
        prepared = prepare(scene, view_layer, keep=True)
        reason = prepared.session.change(prepared.extraction.scene)
        if reason is not None:
            return f"Live paused: {reason}; bake again"
        finish(prepared, run(prepared, lambda _fraction, _message: True))
        return f"Live: re-solved in {1000 * (time.perf_counter() - start):.0f} ms"
    except (ValueError, RuntimeError) as error:  # bad input, or Blender refused the reading render
        return f"Live paused: {error}"
    finally:
        _busy = False


def toggled(settings, _context) -> None:
    """``live``'s update: start watching (a first re-solve brings the colours up to date), or stop."""
    scene = settings.id_data
    if settings.live:
        _marked.add(scene.name)
    else:
        _marked.discard(scene.name)
        settings.live_status = ""


def register() -> None:
    bpy.app.handlers.depsgraph_update_post.append(_on_depsgraph_update)
    bpy.app.timers.register(tick, first_interval=TICK, persistent=True)


def unregister() -> None:
    if bpy.app.timers.is_registered(tick):
        bpy.app.timers.unregister(tick)
    if _on_depsgraph_update in bpy.app.handlers.depsgraph_update_post:
        bpy.app.handlers.depsgraph_update_post.remove(_on_depsgraph_update)
    _marked.clear()
