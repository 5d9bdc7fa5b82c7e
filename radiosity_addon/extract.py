"""The evaluated Blender scene -> ``core.Scene``, plus where each triangle corner's colour goes
back (object, loop) and a note for everything approximated or skipped.

``depsgraph`` is the one a render evaluates (``rendered.read_as_rendered``), so what it holds is
what renders. Taken: mesh objects (modifiers applied, instances included, world space),
their materials (``materials``), point, spot, sun and area lights (not portals, nor lights
invisible to diffuse rays, which light no diffuse surface in Cycles), and the world's background
colour x strength as sky light (unless it is invisible to diffuse rays).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field

import numpy as np
from mathutils import Euler

from ..core import Scene
from ..core.scene.lights import Environment, PointLight, SpotLight, SunLight, area_light
from ..core.scene.textures import face_means, image_triangle_means
from .materials import MAX_REFLECTANCE, Surface, default_surface, image_pixels, material_surface

# Cycles' Max Bounces of a light, whose default (and highest) value sets no limit.
MAX_LIGHT_BOUNCES = 1024


@dataclass
class MeshTarget:
    """Where the colours of scene triangles [start, stop) go: the corners (loops) of the
    original mesh of object ``object_name``; for an instance (``instancer`` the object that made
    it, ``matrix`` (4, 4) where), of a new object holding a copy of that object's mesh."""

    object_name: str
    mesh_name: str
    start: int
    stop: int
    loops: np.ndarray  # (stop - start, 3) loop index of each triangle corner
    loop_count: int
    topology_changed: bool = False
    instancer: str | None = None
    matrix: np.ndarray | None = None


@dataclass
class LightGroups:
    """The light group (Object > Shading > Light Group; World > Settings) of each light source of
    a scene: its lights (L,), its triangles (T,) (their objects'; they count where they emit) and
    its world; "" for none."""

    lights: list[str]
    triangles: np.ndarray
    world: str

    def names(self) -> list[str]:
        """The groups that hold a source, in the order first met."""
        return list(dict.fromkeys(name for name in [*self.lights, *np.unique(self.triangles), self.world] if name))


@dataclass
class Extraction:
    scene: Scene
    targets: list[MeshTarget]
    notes: list[str] = field(default_factory=list)
    light_groups: LightGroups | None = None

    def lit_by(self, group: str) -> Scene:
        """The scene lit by the sources of light group ``group`` alone: the other lights at no
        power, the other objects' emission off, the world dark unless it is in the group."""
        scene, groups = self.scene, self.light_groups
        dark = [dataclasses.replace(light, **{"strength" if isinstance(light, SunLight) else "power": np.zeros(3)})
                for light in scene.lights]
        lights = tuple(light if name == group else off for light, off, name in zip(scene.lights, dark, groups.lights))
        emission = np.where((groups.triangles == group)[:, None], scene.emission, 0.0)
        world = groups.world == group
        return dataclasses.replace(scene, material=scene.material, lights=lights, emission=emission,
                                   sky=scene.sky if world else np.zeros(3),
                                   environment=scene.environment if world else None)


class _Builder:
    def __init__(self) -> None:
        self.vertices: list[np.ndarray] = []
        self.triangles: list[np.ndarray] = []
        self.material: list[np.ndarray] = []
        self.reflects: list[np.ndarray] = []  # (count,) bool per mesh: its object's Reflects Light
        self.emits: list[np.ndarray] = []
        self.casts: list[np.ndarray] = []  # Object > Visibility > Ray Visibility > Shadow
        self.reflectance_maps: list[np.ndarray] = []  # (count, 3) per mesh, NaN where no SurfaceMap
        self.emission_maps: list[np.ndarray] = []
        self.opacity_maps: list[np.ndarray] = []  # (count, 3) per mesh, NaN where no alpha map
        self._pixels: dict[tuple[str, bool], np.ndarray | None] = {}
        self.instances: dict[str, int] = {}  # instancer name: mesh instances it made
        self.corner_normals: list[np.ndarray] = []
        self.surfaces: list[Surface] = []
        self.surface_index: dict[str, int] = {}
        self.targets: list[MeshTarget] = []
        self.notes: list[str] = []
        self.lights: list = []
        self.light_groups: list[str] = []  # per light
        self.triangle_groups: list[np.ndarray] = []  # per mesh: its object's light group
        self.receivers: set[str] | None = None
        self.real_instances = False
        self.vertex_count = 0
        self.triangle_count = 0

    def image_pixels(self, image, alpha: bool = False) -> np.ndarray | None:
        """An image's linear pixels or alpha (``materials.image_pixels``), read once per bake."""
        key = (image.name, alpha)
        if key not in self._pixels:
            self._pixels[key] = image_pixels(image, alpha)
        return self._pixels[key]

    def surface(self, material) -> int:
        key = material.name if material is not None else ""
        if key not in self.surface_index:
            surface = material_surface(material) if material is not None else default_surface()
            self.notes.extend(surface.notes)
            self.surface_index[key] = len(self.surfaces)
            self.surfaces.append(surface)
        return self.surface_index[key]


def extract(depsgraph, two_sided: bool = True, shading_normals: bool = True,
            receivers: set[str] | None = None, real_instances: bool = False) -> Extraction:
    """Read ``depsgraph`` (evaluated) into an Extraction; ValueError if nothing can be baked.
    With ``shading_normals`` the scene carries each corner's normal (Shade Flat / Smooth, sharp
    edges, custom normals: ``Mesh.corner_normals``), which then decide where vertex colours are
    shared; without, the bake's crease angle does. Each object's ``radiosity`` settings say
    whether it receives colours, reflects and emits; ``receivers`` (object names), when given,
    limits the colours to those objects. With ``real_instances`` each mesh instance's colours go
    to an object of its own (``write``), else instances only light and shade, with a note."""
    builder = _Builder()
    builder.receivers, builder.real_instances = receivers, real_instances
    skipped: dict[str, list[str]] = {}
    for instance in depsgraph.object_instances:
        obj = instance.object
        original = obj.original
        if not (instance.is_instance or instance.show_self):
            continue
        if obj.type == "LIGHT":
            try:
                _add_light(builder, obj, np.array(instance.matrix_world))
            except ValueError as error:
                raise ValueError(f"light '{original.name}': {error}") from error
        elif obj.type == "MESH":
            instancer = (instance.parent.original.name if instance.parent else "an instancer") \
                if instance.is_instance else None
            _add_mesh(builder, obj, np.array(instance.matrix_world), instancer)
        elif obj.type in ("CURVE", "SURFACE", "FONT", "META", "CURVES", "POINTCLOUD", "VOLUME"):
            skipped.setdefault(obj.type.lower(), []).append(original.name)
    for kind, names in skipped.items():
        builder.notes.append(f"{len(names)} {kind} object(s) skipped (only meshes are baked): {_names(names)}")
    for instancer, count in builder.instances.items():
        builder.notes.append(f"'{instancer}': its {count} mesh instance(s) light and shade the scene but get no "
                             "colours, as their meshes belong to the instanced objects (Advanced > Instances > "
                             "Bake Into Objects gives each an object of its own)")
    if not builder.triangles:
        raise ValueError("there is no mesh visible in renders to bake")
    if not builder.targets:
        reason = "among the selected objects (Selected Only)" if receivers is not None else "in the scene"
        raise ValueError(f"no mesh {reason} receives colours: check Receives Colours in Object Properties")
    world = depsgraph.scene.world
    if world is not None and not getattr(getattr(world, "cycles_visibility", None), "diffuse", True):
        builder.notes.append(f"world '{world.name}': invisible to diffuse rays (Ray Visibility), so it lights no "
                             "diffuse surface in Cycles, skipped")
        world = None  # nor does its light group hold any light
    sky, environment = _world_light(world, builder) if world is not None else (np.zeros(3), None)
    reflectance = np.array([s.reflectance for s in builder.surfaces])
    emission = np.array([s.emission for s in builder.surfaces])
    material = np.concatenate(builder.material)
    triangles = np.concatenate(builder.triangles)
    reflects, emits = np.concatenate(builder.reflects), np.concatenate(builder.emits)
    mapped_reflectance, mapped_emission = (np.concatenate(builder.reflectance_maps),
                                           np.concatenate(builder.emission_maps))
    reflectance = np.where(np.isnan(mapped_reflectance), reflectance[material],
                           np.clip(mapped_reflectance, 0.0, MAX_REFLECTANCE))
    emission = np.where(np.isnan(mapped_emission), emission[material], np.maximum(mapped_emission, 0.0))
    # see-through surfaces: a per-face alpha scales the opaque part's colours to the whole face's
    mapped_opacity = np.concatenate(builder.opacity_maps)[:, 0]
    by_map = ~np.isnan(mapped_opacity)
    opacity = np.where(by_map, np.clip(mapped_opacity, 0.0, 1.0),
                       np.array([s.opacity for s in builder.surfaces])[material])
    reflectance = np.minimum(np.where(by_map[:, None], reflectance * opacity[:, None], reflectance),
                             MAX_REFLECTANCE * opacity[:, None])
    emission = np.where(by_map[:, None], emission * opacity[:, None], emission)
    scene = Scene(
        np.concatenate(builder.vertices), triangles, reflectance * reflects[:, None], emission * emits[:, None],
        material=material, two_sided=np.full(len(triangles), two_sided), lights=builder.lights, sky=sky,
        environment=environment,
        casts_shadows=np.concatenate(builder.casts),
        corner_normals=np.concatenate(builder.corner_normals) if shading_normals else None,
        opacity=opacity,
    )
    groups = LightGroups(builder.light_groups, np.concatenate(builder.triangle_groups),
                         getattr(world, "lightgroup", "") if world is not None else "")
    notes = list(dict.fromkeys(builder.notes))  # an object's notes once, however many its instances
    return Extraction(scene, builder.targets, notes, groups)


def _add_mesh(builder: _Builder, obj, matrix: np.ndarray, instancer: str | None) -> None:
    """One evaluated mesh into ``builder``: ``instancer`` names the object that instanced it, if any."""
    if not getattr(obj, "visible_diffuse", True):
        builder.notes.append(f"object '{obj.original.name}': invisible to diffuse rays in Cycles, which this bake "
                             "does not follow: it reflects, emits and shades as any surface")
    materials = [slot.material for slot in obj.material_slots] or [None]
    ids = np.array([builder.surface(material) for material in materials])
    if any(builder.surfaces[i].emission.any() or builder.surfaces[i].emission_map is not None for i in ids):
        _note_light_linking(builder, obj, f"object '{obj.original.name}'")
    mesh = obj.to_mesh()
    try:
        mesh.calc_loop_triangles()
        count = len(mesh.loop_triangles)
        if count == 0:
            return
        corners = _get(mesh.loop_triangles, "vertices", count * 3, np.int64).reshape(-1, 3)
        loops = _get(mesh.loop_triangles, "loops", count * 3, np.int64).reshape(-1, 3)
        slots = np.clip(_get(mesh.loop_triangles, "material_index", count, np.int64), 0, len(ids) - 1)
        positions = _get(mesh.vertices, "co", len(mesh.vertices) * 3, np.float64).reshape(-1, 3)
        loop_count = len(mesh.loops)
        loop_normals = _get(mesh.corner_normals, "vector", loop_count * 3, np.float64).reshape(-1, 3)
        world = positions @ matrix[:3, :3].T + matrix[:3, 3]
        faces = _get(mesh.loop_triangles, "polygon_index", count, np.int64)
        areas = np.linalg.norm(np.cross(*(world[corners[:, 1:]] - world[corners[:, :1]]).transpose(1, 0, 2)), axis=1)
        surfaces = [builder.surfaces[i] for i in ids]
        builder.reflectance_maps.append(_mapped(builder, mesh, obj.original.name, [s.reflectance_map for s in surfaces],
                                                slots, loops, areas, faces))
        builder.emission_maps.append(_mapped(builder, mesh, obj.original.name, [s.emission_map for s in surfaces],
                                             slots, loops, areas, faces))
        builder.opacity_maps.append(_mapped(builder, mesh, obj.original.name, [s.opacity_map for s in surfaces],
                                            slots, loops, areas, faces))
    finally:
        obj.to_mesh_clear()
    if np.linalg.det(matrix[:3, :3]) < 0:  # a mirroring transform turns the faces inside out
        corners, loops = corners[:, ::-1], loops[:, ::-1]
    builder.corner_normals.append(_world_normals(loop_normals[loops], matrix, world[corners]))
    builder.vertices.append(world)
    builder.triangles.append(corners + builder.vertex_count)
    builder.material.append(ids[slots])
    original = obj.original
    builder.reflects.append(np.full(count, original.radiosity.reflects))
    builder.emits.append(np.full(count, original.radiosity.emits))
    builder.casts.append(np.full(count, getattr(original, "visible_shadow", True)))
    builder.triangle_groups.append(np.full(count, getattr(original, "lightgroup", ""), dtype=object))
    start = builder.triangle_count
    builder.vertex_count += len(world)
    builder.triangle_count += count
    if instancer is not None:  # its mesh belongs to the instanced object: a copy gets the colours, on request
        wanted = original.radiosity.receives and (builder.receivers is None or instancer in builder.receivers)
        if builder.real_instances and wanted:
            builder.targets.append(MeshTarget(original.name, original.data.name, start, builder.triangle_count,
                                              loops, loop_count, True, instancer, matrix))
        elif not builder.real_instances:
            builder.instances[instancer] = builder.instances.get(instancer, 0) + 1
        return
    if not original.radiosity.receives or (builder.receivers is not None and original.name not in builder.receivers):
        return
    changed = loop_count != len(original.data.loops)
    builder.targets.append(MeshTarget(original.name, original.data.name, start, builder.triangle_count, loops,
                                      loop_count, changed))


def _mapped(builder: _Builder, mesh, object_name: str, maps: list, slots: np.ndarray, loops: np.ndarray,
            areas: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """(T, 3) the colour each triangle's SurfaceMap gives it, its mean over the triangle's face
    (``maps`` per material slot, ``slots`` (T,)); NaN where its material has none."""
    values = np.full((len(slots), 3), np.nan)
    for slot, surface_map in enumerate(maps):
        chosen = np.flatnonzero(slots == slot)
        if surface_map is None or len(chosen) == 0:
            continue
        per_triangle = _triangle_colours(builder, mesh, object_name, surface_map, loops[chosen])
        if per_triangle is not None:
            values[chosen] = face_means(per_triangle, areas[chosen], faces[chosen]) * surface_map.scale
    return values


def _triangle_colours(builder: _Builder, mesh, object_name: str, surface_map, loops: np.ndarray) -> np.ndarray | None:
    """(t, 3) mean colour of ``surface_map`` over each triangle (corner loops ``loops`` (t, 3)),
    None (with a note) when the mesh lacks what it reads."""
    if surface_map.image is not None:
        layer = (mesh.uv_layers.get(surface_map.uv_map) if surface_map.uv_map else
                 next((uv for uv in mesh.uv_layers if uv.active_render), mesh.uv_layers.active))
        pixels = builder.image_pixels(surface_map.image, surface_map.alpha)
        if layer is None or pixels is None:
            missing = (f"pixels in image '{surface_map.image.name}'" if layer is not None else
                       f"UV map '{surface_map.uv_map}'" if surface_map.uv_map else "UV map")
            builder.notes.append(f"object '{object_name}': no {missing}, its texture's mean colour used")
            return None
        uv = np.empty(len(mesh.loops) * 2, dtype=np.float32)
        layer.uv.foreach_get("vector", uv)
        return image_triangle_means(pixels, uv.reshape(-1, 2)[loops].astype(np.float64))
    attributes = mesh.color_attributes
    name = surface_map.attribute or (attributes[attributes.render_color_index].name if len(attributes) else "")
    layer = attributes.get(name)
    if layer is None or layer.domain not in ("CORNER", "POINT"):
        builder.notes.append(f"object '{object_name}': no colour attribute '{name}' on its faces' corners or "
                             "vertices, the node's colour used")
        return None
    colours = np.empty(len(layer.data) * 4, dtype=np.float32)
    layer.data.foreach_get("color", colours)
    colours = colours.reshape(-1, 4)[:, :3].astype(np.float64)
    if layer.domain == "POINT":
        loop_vertex = np.empty(len(mesh.loops), dtype=np.int32)
        mesh.loops.foreach_get("vertex_index", loop_vertex)
        colours = colours[loop_vertex]
    return colours[loops].mean(axis=1)  # the mean of a linear interpolant over a triangle


def _add_light(builder: _Builder, obj, matrix: np.ndarray) -> None:
    """The light of ``obj`` as Cycles renders it (``BlenderSync::sync_light``): a portal, which
    only guides Cycles' sampling of the world, gives no light, nor does a light invisible to
    diffuse rays (Cycles leaves diffuse surfaces out of its light: ``light_object_visibility_flags``);
    Cast Shadow off casts none; Soft Falloff dims a point or spot light near it; an area
    light's Spread narrows it."""
    light = obj.data
    name = obj.original.name
    position, axis = matrix[:3, 3], -matrix[:3, 2]
    cycles = getattr(light, "cycles", None)
    if light.type == "AREA" and getattr(cycles, "is_portal", False):
        builder.notes.append(f"light '{name}': a portal, which guides Cycles' sampling of the world and gives no "
                             "light of its own, skipped")
        return
    if not getattr(obj, "visible_diffuse", True):
        builder.notes.append(f"light '{name}': invisible to diffuse rays (Visibility > Ray Visibility), so it "
                             "lights no diffuse surface in Cycles, skipped")
        return
    power = _light_colour(builder, light, name) * light.energy * 2.0 ** getattr(light, "exposure", 0.0)
    _note_light_linking(builder, obj, f"light '{name}'")
    if getattr(cycles, "max_bounces", MAX_LIGHT_BOUNCES) < MAX_LIGHT_BOUNCES:
        builder.notes.append(f"light '{name}': its Max Bounces ({cycles.max_bounces}) is ignored (its light "
                             "bounces as all light does)")
    shadows = bool(getattr(light, "use_shadow", True))
    if light.type == "POINT":
        builder.lights.append(PointLight(position, power, light.shadow_soft_size, casts_shadow=shadows,
                                         soft_falloff=light.use_soft_falloff))
    elif light.type == "SPOT":
        builder.lights.append(SpotLight(position, axis, power, light.spot_size, light.spot_blend,
                                        light.shadow_soft_size, casts_shadow=shadows,
                                        soft_falloff=light.use_soft_falloff))
    elif light.type == "SUN":
        builder.lights.append(SunLight(axis, power, light.angle, casts_shadow=shadows))
    elif light.type == "AREA":
        builder.lights.append(area_light(light.shape, light.size, light.size_y, matrix, power,
                                         getattr(light, "normalize", True), casts_shadow=shadows,
                                         spread=min(max(light.spread, 1e-6), np.pi)))
    added = len(builder.lights) - len(builder.light_groups)  # one, or none for a kind not baked
    builder.light_groups += [getattr(obj.original, "lightgroup", "")] * added


def _light_colour(builder: _Builder, light, name: str) -> np.ndarray:
    """(3,) a light's colour as Cycles multiplies its power by it (``BlenderSync::sync_light`` and
    the light's shader): its Color, times its blackbody ``temperature_color`` where it uses a
    temperature (where this Blender has one), times an Emission node's unlinked Color x Strength
    where its node setup is just that into the Light Output (checked against Cycles renders:
    docs/notes/experiments.md, "A light's colour"); any other setup is left out, with a note."""
    colour = np.array(light.color[:3], dtype=np.float64)
    if getattr(light, "use_temperature", False):
        colour *= np.array(light.temperature_color[:3])
    tree = light.node_tree if getattr(light, "use_nodes", False) else None
    output = tree.get_output_node("CYCLES") if tree is not None else None
    if output is None or not output.inputs["Surface"].is_linked:
        return colour
    node = output.inputs["Surface"].links[0].from_node
    inputs = node.inputs if node.bl_idname == "ShaderNodeEmission" else None
    if inputs is None or inputs["Color"].is_linked or inputs["Strength"].is_linked:
        builder.notes.append(f"light '{name}': its node setup is ignored (colour x power used)")
        return colour
    return colour * np.array(inputs["Color"].default_value[:3]) * float(inputs["Strength"].default_value)


def _note_light_linking(builder: _Builder, obj, what: str) -> None:
    """A note where ``obj`` (a light or an emitting mesh) links its light to some receivers or
    blockers (Object > Shading > Light Linking), which this bake does not follow."""
    linking = getattr(obj, "light_linking", None)
    if linking is not None and (linking.receiver_collection is not None or linking.blocker_collection is not None):
        builder.notes.append(f"{what}: its light linking is not followed (it lights every surface, and every "
                             "surface shades it)")


def _world_light(world, builder: _Builder) -> tuple[np.ndarray, Environment | None]:
    """The world's light: (3,) background colour x strength as uniform sky light, or an
    Environment where an Environment Texture (equirectangular, through a Mapping's rotation or
    none) feeds the background colour."""
    notes = builder.notes
    tree = world.node_tree if getattr(world, "use_nodes", True) else None
    output = tree.get_output_node("CYCLES") if tree is not None else None
    if output is None or not output.inputs["Surface"].is_linked:
        return (np.array(world.color[:3], dtype=np.float64) if tree is None else np.zeros(3)), None
    node = output.inputs["Surface"].links[0].from_node
    if node.bl_idname != "ShaderNodeBackground":
        notes.append(f"world '{world.name}': {node.bl_idname} not understood, viewport colour used as sky")
        return np.array(world.color[:3], dtype=np.float64), None
    colour, strength = node.inputs["Color"], node.inputs["Strength"]
    if strength.is_linked:
        notes.append(f"world '{world.name}': the background strength is driven by nodes; its unlinked value used")
    if colour.is_linked:
        texture = colour.links[0].from_node
        environment = _environment(texture, float(strength.default_value), builder, world.name)
        if environment is not None:
            return np.zeros(3), environment
        notes.append(f"world '{world.name}': a textured background is taken as its unlinked colour")
    return np.array(colour.default_value[:3], dtype=np.float64) * float(strength.default_value), None


def _environment(texture, strength: float, builder: _Builder, world_name: str) -> Environment | None:
    """The Environment of an Environment Texture node, None when it is not one this reads."""
    if texture.bl_idname != "ShaderNodeTexEnvironment" or texture.image is None or \
            texture.projection != "EQUIRECTANGULAR":
        return None
    pixels = builder.image_pixels(texture.image)
    if pixels is None:
        return None
    rotation = np.eye(3)
    vector = texture.inputs["Vector"]
    if vector.is_linked:
        mapping = vector.links[0].from_node
        if mapping.bl_idname != "ShaderNodeMapping" or mapping.vector_type not in ("POINT", "VECTOR") or \
                any(mapping.inputs[name].is_linked for name in ("Rotation", "Location", "Scale")):
            return None
        if tuple(mapping.inputs["Scale"].default_value) != (1.0, 1.0, 1.0):
            builder.notes.append(f"world '{world_name}': the environment's mapping scale is ignored")
        rotation = np.array(Euler(mapping.inputs["Rotation"].default_value, "XYZ").to_matrix())
    return Environment(pixels * strength, rotation)


def _world_normals(normals: np.ndarray, matrix: np.ndarray, corners: np.ndarray) -> np.ndarray:
    """(T, 3, 3) unit corner normals in world space (by the inverse transpose of ``matrix``); where
    Blender gives none (a zero-area face), the face's own normal, or +Z if it has none either."""
    normals = normals @ np.linalg.inv(matrix[:3, :3])
    face = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    face = np.where(np.linalg.norm(face, axis=1, keepdims=True) > 0, face, [0.0, 0.0, 1.0])
    length = np.linalg.norm(normals, axis=2, keepdims=True)
    normals = np.where(np.isfinite(length) & (length > 0), normals / np.where(length > 0, length, 1.0), face[:, None])
    return normals / np.linalg.norm(normals, axis=2, keepdims=True)


def _get(collection, attribute: str, size: int, dtype) -> np.ndarray:
    values = np.empty(size, dtype=np.int32 if dtype == np.int64 else np.float32)
    collection.foreach_get(attribute, values)
    return values.astype(dtype)


def _names(names: list[str], shown: int = 5) -> str:
    text = ", ".join(f"'{n}'" for n in names[:shown])
    return text + (f" and {len(names) - shown} more" if len(names) > shown else "")
