"""Per-corner colours -> a colour attribute on each baked mesh (float or byte, per corner or per
vertex, ``Storage``).

All meshes or none: every target is checked before the first one is written. Only the attribute
of the configured name is created or replaced; other attributes are never touched.
"""

from __future__ import annotations

from dataclasses import dataclass

import bpy
import numpy as np
from mathutils import Matrix

from ..core.reconstruct.storage import exposed, vertex_means
from .extract import MeshTarget
from .rendered import read_as_rendered


class WriteError(ValueError):
    """A target cannot take the colours; nothing was written."""


def plan(targets: list[MeshTarget], attributes: list[str], copy_changed: bool) -> tuple[list[MeshTarget], list[str]]:
    """The targets to write and a note for each one left out; WriteError when an attribute
    name is taken by something that is not a colour attribute."""
    chosen, notes, owner = [], [], {}
    for target in targets:
        obj = bpy.data.objects.get(target.object_name)
        if obj is None or obj.type != "MESH":
            raise WriteError(f"object '{target.object_name}' is gone or no longer a mesh; bake again")
        if target.instancer is not None:  # a new object takes its colours
            chosen.append(target)
            continue
        library = obj.library or obj.data.library
        if library is not None:
            raise WriteError(f"object '{target.object_name}' has its mesh linked from {library.filepath}: colours "
                             "written to it would be lost on saving. Make it local (Object > Relations > Make "
                             "Local > Selected Objects and Data), or exclude it from renders")
        if target.topology_changed and not copy_changed:
            notes.append(f"object '{target.object_name}': its modifiers change the topology; it took part in "
                         "the lighting but got no colours (choose 'Bake Applied Copy' to keep them)")
            continue
        if target.topology_changed:
            chosen.append(target)
            continue
        mesh = obj.data
        if len(mesh.loops) != target.loop_count:
            raise WriteError(f"mesh '{mesh.name}' changed during the bake; bake again")
        for attribute in attributes:
            existing = mesh.attributes.get(attribute)
            if existing is not None and mesh.color_attributes.get(attribute) is None:
                raise WriteError(f"mesh '{mesh.name}' has a {existing.data_type} attribute named '{attribute}' "
                                 "that is not a colour attribute; choose another attribute name")
        if mesh.name in owner:
            notes.append(f"mesh '{mesh.name}' is shared by '{owner[mesh.name]}' and '{target.object_name}': "
                         f"it shows the lighting of '{owner[mesh.name]}' (make it single user to bake each)")
            continue
        owner[mesh.name] = target.object_name
        chosen.append(target)
    return chosen, notes


@dataclass(frozen=True)
class Storage:
    """How the colours are stored: ``data_type`` FLOAT_COLOR (scene-linear) or BYTE_COLOR (sRGB
    bytes, fitted by ``tone``), ``domain`` CORNER or POINT, ``exposure`` in stops."""

    data_type: str = "FLOAT_COLOR"
    domain: str = "CORNER"
    exposure: float = 0.0
    tone: str = "CLIP"


def write(targets: list[MeshTarget], colours: dict[str, np.ndarray], scene=None, view_layer=None,
          storage: Storage = Storage()) -> list[str]:
    """Write each target's colours into each attribute of ``colours`` ({name: (T, 3, 3) float,
    scene-linear}; the first becomes the active and render colour attribute) as ``storage`` says;
    targets whose topology changed get an applied copy of their mesh as ``view_layer`` of ``scene``
    renders it. Returns the names of the objects written."""
    changed = [index for index, target in enumerate(targets) if target.topology_changed]
    applied = read_as_rendered(scene, view_layer, lambda depsgraph: _evaluated_meshes(
        {index: targets[index].object_name for index in changed}, depsgraph)) if changed else {}
    written = []
    for index, target in enumerate(targets):
        obj = bpy.data.objects[target.object_name]
        if target.instancer is not None:
            obj = _instance_copy(obj, bpy.data.objects[target.instancer], target.matrix, applied[index])
        elif target.topology_changed:
            obj = _applied_copy(obj, applied[index])
        mesh = obj.data
        for index, (attribute, corner_colors) in enumerate(colours.items()):
            layer = _write_attribute(mesh, target, attribute, corner_colors, storage)
            if index == 0:
                mesh.color_attributes.active_color = layer
                mesh.color_attributes.render_color_index = mesh.color_attributes.active_color_index
        mesh.update()
        written.append(obj.name)
    return written


def _write_attribute(mesh, target: MeshTarget, attribute: str, corner_colors: np.ndarray, storage: Storage):
    """The colour attribute ``attribute`` of ``mesh`` (replaced if there was one) holding the target's
    corner colours (its rows of ``corner_colors``) as ``storage`` says."""
    values = np.zeros((target.loop_count, 3))
    values[target.loops.ravel()] = corner_colors[target.start:target.stop].reshape(-1, 3)
    if storage.domain == "POINT":
        loop_vertex = np.empty(target.loop_count, dtype=np.int32)
        mesh.loops.foreach_get("vertex_index", loop_vertex)
        values = vertex_means(values, loop_vertex, len(mesh.vertices))
    values = exposed(values, storage.exposure, storage.tone if storage.data_type == "BYTE_COLOR" else None)
    rgba = np.ones((len(values), 4), dtype=np.float32)
    rgba[:, :3] = values
    old = mesh.color_attributes.get(attribute)
    if old is not None:
        mesh.color_attributes.remove(old)
    layer = mesh.color_attributes.new(attribute, storage.data_type, storage.domain)
    layer.data.foreach_set("color", rgba.ravel())  # linear values: Blender encodes BYTE_COLOR as sRGB
    return layer


def _evaluated_meshes(names: dict, depsgraph) -> dict:
    """{key: a new mesh of the evaluated geometry (modifiers applied) of the object named
    ``names[key]``} in ``depsgraph``."""
    return {key: bpy.data.meshes.new_from_object(bpy.data.objects[name].evaluated_get(depsgraph))
            for key, name in names.items()}


def _instance_copy(source, instancer, matrix: np.ndarray, mesh):
    """A new object holding ``mesh`` (a copy of ``source``'s evaluated mesh) where ``instancer``
    put an instance of ``source`` (world ``matrix``), in the instancer's collections; the
    instancer is hidden, its instances now being objects of their own."""
    mesh.name = f"{source.data.name} baked"
    copy = bpy.data.objects.new(f"{instancer.name} {source.name}", mesh)
    copy.matrix_world = Matrix(matrix.tolist())
    for collection in instancer.users_collection:
        collection.objects.link(copy)
    instancer.hide_render = instancer.hide_viewport = True
    return copy


def _applied_copy(obj, mesh):
    """A new object beside ``obj`` holding ``mesh``, its evaluated mesh (modifiers applied)."""
    mesh.name = f"{obj.data.name} baked"
    copy = bpy.data.objects.new(f"{obj.name} baked", mesh)
    copy.matrix_world = obj.matrix_world
    for collection in obj.users_collection:
        collection.objects.link(copy)
    obj.hide_render = obj.hide_viewport = True
    return copy


def clear(objects, attribute: str) -> list[str]:
    """Remove ``attribute`` (a colour attribute only) from the meshes of ``objects``; the names
    of the meshes it was removed from."""
    cleared = []
    for obj in objects:
        if obj.type != "MESH":
            continue
        layer = obj.data.color_attributes.get(attribute)
        if layer is not None and obj.data.name not in cleared:
            obj.data.color_attributes.remove(layer)
            cleared.append(obj.data.name)
    return cleared
