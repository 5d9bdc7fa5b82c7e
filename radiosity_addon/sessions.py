"""The bake sessions kept between bakes while Blender runs, one per scene: baking again after
only colours changed (materials, lights' colour and power, the world's colour and strength)
re-solves with the first bake's geometry work (``core.BakeSession``) instead of starting over.
They are dropped when another file is opened, when the settings change, and on request."""

from __future__ import annotations

import bpy
from bpy.app.handlers import persistent

from ..core import BakeSession

_kept: dict[str, tuple[dict, BakeSession]] = {}  # scene name: (the knobs it bakes with, session)


def session_for(scene_name: str, knobs: dict) -> BakeSession:
    """The session kept for ``scene_name`` if it bakes with ``knobs``, else a new one, kept."""
    entry = _kept.get(scene_name)
    if entry is None or entry[0] != knobs:
        entry = _kept[scene_name] = (dict(knobs), BakeSession(**knobs))
    return entry[1]


def kept(scene_name: str) -> BakeSession | None:
    """The session kept for ``scene_name``, if any."""
    entry = _kept.get(scene_name)
    return None if entry is None else entry[1]


def forget(scene_name: str | None = None) -> None:
    """Drop the session of ``scene_name`` (None: all of them) and the memory it holds."""
    if scene_name is None:
        _kept.clear()
    else:
        _kept.pop(scene_name, None)


@persistent
def _forget_all(*_args) -> None:
    forget()


def register() -> None:
    bpy.app.handlers.load_pre.append(_forget_all)


def unregister() -> None:
    if _forget_all in bpy.app.handlers.load_pre:
        bpy.app.handlers.load_pre.remove(_forget_all)
    forget()
