"""Build the sample scenes from nothing and save them as .blend files.

    python sample_blends/build_samples.py [--output-dir sample_blends]

Run it with the ``bpy`` module of the oldest supported Blender (``pip install bpy==4.2.0``): a .blend
saved by Blender 5.0 does not open in Blender 4.2 to 4.4, and newer Blenders open older files. The
script also runs under bpy 5.0.1. Each scene starts from factory settings and an empty file, so
running it again overwrites its outputs with the same scenes.

- ``cornell_box.blend``: the published Cornell box (``cornell_box.obj`` and ``.mtl`` here), one object
  per OBJ object, every quad split into a grid so baked vertex colours can show shadows;
- ``window_room.blend``: a closed room lit by a sun and the sky through one window opening;
- ``lights.blend``: an open box with a point, a spot and an area light, an emissive cube, coloured
  Principled objects and a Diffuse BSDF one.

Every surface is purely diffuse (Principled BSDF with roughness 1 and no specular layer, or Diffuse
BSDF), and each scene renders with Cycles on the CPU using the unbiased reference settings of
shared/CYCLES.md, so a render or a Cycles bake is a fair reference for a radiosity bake. The bake
settings are left at their defaults. Units are metres, Z up.
"""

from __future__ import annotations

import argparse
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from itertools import pairwise
from pathlib import Path

import bpy
from mathutils import Vector

HERE = Path(__file__).resolve().parent

# Cycles settings shared by every scene (see shared/CYCLES.md: the defaults bias a reference).
SAMPLES = 128
MAX_BOUNCES = 64  # with reflectance 0.9, 32 bounces are 2.7 % short

# Vertices closer than this (metres) are welded into one while building a mesh.
WELD_TOLERANCE = 1e-6


# --------------------------------------------------------------------------------------------------
# Meshes
# --------------------------------------------------------------------------------------------------


def divisions(length: float, cell: float) -> int:
    """How many grid cells of about ``cell`` metres fit along ``length`` metres (at least one)."""
    return max(1, round(length / cell))


def cuts(length: float, cell: float, features: Sequence[float] = ()) -> list[float]:
    """Grid lines along [0, length] as fractions of it: every feature position (metres from the
    start, e.g. the edges of a window) is a grid line, and each stretch between them is split into
    cells of about ``cell`` metres."""
    stops = sorted({0.0, length, *(f for f in features if 0.0 < f < length)})
    lines = [0.0]
    for start, end in pairwise(stops):
        count = divisions(end - start, cell)
        lines += [start + (end - start) * k / count for k in range(1, count + 1)]
    return [line / length for line in lines]


@dataclass
class MeshBuilder:
    """Vertices and quads gathered for one mesh; vertices at the same place are welded, so grids
    that share an edge with the same cuts along it join without cracks."""

    vertices: list[Vector] = field(default_factory=list)
    faces: list[tuple[int, ...]] = field(default_factory=list)
    _index: dict[tuple[int, int, int], int] = field(default_factory=dict)

    def vertex(self, position: Vector) -> int:
        """Index of the vertex at ``position``, added if new."""
        key = tuple(round(c / WELD_TOLERANCE) for c in position)
        if key not in self._index:
            self._index[key] = len(self.vertices)
            self.vertices.append(position.copy())
        return self._index[key]

    def add_quad(
        self,
        corners: Sequence[Vector],
        cell: float,
        u_cuts: Sequence[float] | None = None,
        v_cuts: Sequence[float] | None = None,
        keep: Callable[[Vector], bool] | None = None,
    ) -> None:
        """Add the quad c0 c1 c2 c3 (its normal by the right-hand rule) as a grid of smaller quads,
        bilinear between the corners. u runs c0 -> c1 and v runs c0 -> c3; ``u_cuts``/``v_cuts``
        are the grid lines as fractions (default: cells of about ``cell`` metres). A grid cell is
        left out (a hole) when ``keep`` returns False for its centre."""
        c0, c1, c2, c3 = (Vector(c) for c in corners)
        if u_cuts is None:
            u_cuts = cuts(((c1 - c0).length + (c2 - c3).length) / 2, cell)
        if v_cuts is None:
            v_cuts = cuts(((c3 - c0).length + (c2 - c1).length) / 2, cell)

        def point(u: float, v: float) -> Vector:
            return c0.lerp(c1, u).lerp(c3.lerp(c2, u), v)

        for u0, u1 in pairwise(u_cuts):
            for v0, v1 in pairwise(v_cuts):
                if keep is not None and not keep(point((u0 + u1) / 2, (v0 + v1) / 2)):
                    continue
                quad = (point(u0, v0), point(u1, v0), point(u1, v1), point(u0, v1))
                self.faces.append(tuple(self.vertex(p) for p in quad))

    def add_box(self, centre: Vector, size: Vector, cell: float, inward: bool = False, skip: str = "") -> None:
        """Add the six faces of an axis-aligned box, facing out (or in, for a room), each split
        into cells of about ``cell`` metres. ``skip`` names faces to leave out, e.g. "-z" for a
        box standing on the floor (faces: "+x", "-x", "+y", "-y", "+z", "-z")."""
        for name, corners in box_faces(centre, size, inward).items():
            if name not in skip.split():
                self.add_quad(corners, cell)

    def to_object(self, name: str, material: bpy.types.Material) -> bpy.types.Object:
        """A new object of these faces (flat shaded, at the world origin) linked to the scene."""
        mesh = bpy.data.meshes.new(name)
        mesh.from_pydata([tuple(v) for v in self.vertices], [], self.faces)
        mesh.validate()
        mesh.materials.append(material)
        return link_object(name, mesh)


def box_faces(centre: Vector, size: Vector, inward: bool = False) -> dict[str, tuple[Vector, ...]]:
    """The corners of the six faces of an axis-aligned box, keyed "+x", "-x", ..., "-z" by the side
    they are on, ordered so each face's normal points out of the box (or into it)."""
    axes = [Vector((1, 0, 0)), Vector((0, 1, 0)), Vector((0, 0, 1))]
    half = [size[k] / 2 for k in range(3)]
    faces = {}
    for a in range(3):
        b, c = (a + 1) % 3, (a + 2) % 3  # axes[b] x axes[c] = axes[a]
        for sign, label in ((1, "+"), (-1, "-")):
            u, v = (b, c) if (sign > 0) != inward else (c, b)  # swapping u and v flips the normal
            base = Vector(centre) + sign * half[a] * axes[a] - half[u] * axes[u] - half[v] * axes[v]
            du, dv = 2 * half[u] * axes[u], 2 * half[v] * axes[v]
            faces[label + "xyz"[a]] = (base, base + du, base + du + dv, base + dv)
    return faces


def link_object(name: str, data: bpy.types.ID | None) -> bpy.types.Object:
    """A new object of ``data`` linked to the current scene."""
    obj = bpy.data.objects.new(name, data)
    bpy.context.scene.collection.objects.link(obj)
    return obj


def triangle_count(scene: bpy.types.Scene) -> int:
    """Triangles in the scene's meshes (quads count as two)."""
    return sum(
        sum(len(polygon.vertices) - 2 for polygon in obj.data.polygons) for obj in scene.objects if obj.type == "MESH"
    )


# --------------------------------------------------------------------------------------------------
# Materials, world, lights, camera
# --------------------------------------------------------------------------------------------------


def empty_node_tree(owner: bpy.types.ID) -> bpy.types.NodeTree:
    """The node tree of a new material or world, emptied. Blender 4.x creates the tree only when
    ``use_nodes`` is turned on; Blender 5.0 always has one (and deprecates ``use_nodes``)."""
    if owner.node_tree is None:
        owner.use_nodes = True
    tree = owner.node_tree
    tree.nodes.clear()
    return tree


def set_input(node: bpy.types.Node, name: str, value) -> None:
    """Set an input socket's default value if this Blender version has the socket."""
    if name in node.inputs:
        node.inputs[name].default_value = value


def shader_material(name: str, shader_type: str, colour: Sequence[float], **inputs) -> bpy.types.Material:
    """A material made of one shader node (``shader_type``, e.g. "ShaderNodeEmission") whose
    Color/Base Color is ``colour`` (linear RGB), plus other inputs by name (spaces as
    underscores), skipped where this Blender version lacks them."""
    material = bpy.data.materials.new(name)
    material.diffuse_color = (*colour, 1.0)  # the colour the Solid viewport shows
    tree = empty_node_tree(material)
    shader = tree.nodes.new(shader_type)
    output = tree.nodes.new("ShaderNodeOutputMaterial")
    output.location = (300, 0)
    tree.links.new(shader.outputs[0], output.inputs["Surface"])
    set_input(shader, "Base Color" if "Base Color" in shader.inputs else "Color", (*colour, 1.0))
    for input_name, value in inputs.items():
        set_input(shader, input_name.replace("_", " "), value)
    return material


def diffuse_principled(name: str, colour: Sequence[float]) -> bpy.types.Material:
    """Principled BSDF made purely diffuse: roughness 1, no specular layer (Specular IOR Level 0)."""
    return shader_material(name, "ShaderNodeBsdfPrincipled", colour, Roughness=1.0, Specular_IOR_Level=0.0)


def diffuse_bsdf(name: str, colour: Sequence[float]) -> bpy.types.Material:
    """Diffuse BSDF (Lambertian: roughness 0)."""
    return shader_material(name, "ShaderNodeBsdfDiffuse", colour, Roughness=0.0)


def emission(name: str, colour: Sequence[float], strength: float) -> bpy.types.Material:
    """Emission shader: radiance ``strength`` x ``colour``, from both sides of the surface."""
    return shader_material(name, "ShaderNodeEmission", colour, Strength=strength)


def set_world(scene: bpy.types.Scene, colour: Sequence[float], strength: float) -> None:
    """A uniform world background (it lights the scene like a uniform sky)."""
    world = bpy.data.worlds.new("World")
    world.color = colour  # the viewport's world colour
    tree = empty_node_tree(world)
    background = tree.nodes.new("ShaderNodeBackground")
    background.inputs["Color"].default_value = (*colour, 1.0)
    background.inputs["Strength"].default_value = strength
    output = tree.nodes.new("ShaderNodeOutputWorld")
    output.location = (300, 0)
    tree.links.new(background.outputs["Background"], output.inputs["Surface"])
    scene.world = world


def aim(obj: bpy.types.Object, direction: Vector) -> None:
    """Turn a camera or light (they look down their local -Z) towards ``direction``, keeping
    their local +Y up."""
    obj.rotation_mode = "QUATERNION"
    obj.rotation_quaternion = Vector(direction).to_track_quat("-Z", "Y")


def add_light(
    name: str,
    kind: str,
    location: Sequence[float],
    energy: float,
    target: Sequence[float] | None = None,
    **settings,
) -> bpy.types.Object:
    """A light of ``kind`` ('POINT', 'SPOT', 'AREA', 'SUN') at ``location``; ``energy`` is the
    power in W (a sun's strength in W/m^2), aimed at the point ``target`` if given; other
    settings (``spot_size``, ``size``...) are set on the light data."""
    light = bpy.data.lights.new(name, kind)
    light.energy = energy
    for key, value in settings.items():
        setattr(light, key, value)
    obj = link_object(name, light)
    obj.location = location
    if target is not None:
        aim(obj, Vector(target) - Vector(location))
    return obj


def add_camera(
    scene: bpy.types.Scene, location: Sequence[float], target: Sequence[float], lens: float, sensor_width: float = 36.0
) -> bpy.types.Object:
    """The scene camera at ``location`` looking at ``target``; ``lens`` and ``sensor_width`` in mm."""
    camera = bpy.data.cameras.new("Camera")
    camera.lens = lens
    camera.sensor_width = sensor_width
    obj = link_object("Camera", camera)
    obj.location = location
    aim(obj, Vector(target) - Vector(location))
    scene.camera = obj
    return obj


def set_render(scene: bpy.types.Scene, name: str, width: int, height: int) -> None:
    """One frame rendered by Cycles on the CPU with unbiased settings (shared/CYCLES.md): no
    clamping, no light threshold, no adaptive sampling, 64 bounces, no denoiser. The output goes
    next to the .blend file (``//render/<name>.png``) unless another path is given."""
    scene.name = name
    scene.frame_start = scene.frame_end = scene.frame_current = 1
    scene.render.engine = "CYCLES"
    scene.render.resolution_x, scene.render.resolution_y = width, height
    scene.render.resolution_percentage = 100
    scene.render.image_settings.file_format = "PNG"
    scene.render.filepath = f"//render/{name}"
    cycles = scene.cycles
    cycles.device = "CPU"
    cycles.samples = SAMPLES
    cycles.use_adaptive_sampling = False
    cycles.use_denoising = False
    cycles.max_bounces = MAX_BOUNCES
    cycles.diffuse_bounces = MAX_BOUNCES
    cycles.sample_clamp_direct = 0.0
    cycles.sample_clamp_indirect = 0.0  # the default, 10, darkens bright interreflection
    cycles.light_sampling_threshold = 0.0  # the default, 0.01, biases too


# --------------------------------------------------------------------------------------------------
# Scene 1: the Cornell box
# --------------------------------------------------------------------------------------------------

CORNELL_OBJ = HERE / "cornell_box.obj"
# OBJ millimetres, +Y up, camera at -Z looking +Z -> Blender metres, +Z up, camera at -Y looking +Y:
# (x, y, z) -> ((CORNELL_CENTRE_X - x), z, y) / 1000, a rotation (so faces keep their sides) that
# puts the box's front edge on the X axis and the published camera on the Y axis.
MM = 0.001
CORNELL_CENTRE_X = 278.0  # mm, the published camera's x
CORNELL_CAMERA = (278.0, 273.0, -800.0)  # mm, OBJ coordinates, looking along +Z
CORNELL_LENS = 35.0  # mm focal length on a 25 mm wide sensor: a 39.3 degree field of view
CORNELL_SENSOR = 25.0
CORNELL_RESOLUTION = 512
# Grid cells of about 69 mm split the 0.55 m walls 8 x 8 and the blocks 2 x 2 (5 high for the
# tall one), and fit the ceiling's cuts around the light, 3 + 2 + 3 cells each way (with 70 mm
# the 105 mm strip beside the light would round down to one cell).
CORNELL_CELL = 0.069


def cornell_point(x: float, y: float, z: float) -> Vector:
    """An OBJ position (mm, +Y up) in Blender's frame (metres, +Z up, opening towards -Y)."""
    return Vector(((CORNELL_CENTRE_X - x) * MM, z * MM, y * MM))


@dataclass
class ObjObject:
    """One ``o``/``g`` object of an OBJ file: its material and its polygons (corner positions)."""

    name: str
    material: str = ""
    polygons: list[list[Vector]] = field(default_factory=list)


def read_obj(path: Path) -> tuple[list[ObjObject], dict[str, dict[str, tuple[float, ...]]]]:
    """The objects of an OBJ file in Blender's frame (``cornell_point``), and its MTL materials
    as {name: {"Kd": rgb, "Ke": rgb}}. Only what the Cornell box file uses is read."""
    positions: list[Vector] = []
    objects: list[ObjObject] = []
    materials: dict[str, dict[str, tuple[float, ...]]] = {}
    for line in path.read_text().splitlines():
        keyword, *values = line.split("#", 1)[0].split() or [""]
        if keyword == "v":
            positions.append(cornell_point(*map(float, values[:3])))
        elif keyword in ("o", "g"):
            objects.append(ObjObject(" ".join(values)))
        elif keyword == "usemtl":
            objects[-1].material = " ".join(values)
        elif keyword == "f":
            objects[-1].polygons.append([positions[int(v.split("/")[0]) - 1] for v in values])
        elif keyword == "mtllib":
            materials.update(read_mtl(path.parent / " ".join(values)))
    return objects, materials


def read_mtl(path: Path) -> dict[str, dict[str, tuple[float, ...]]]:
    """{material: {"Kd": rgb, "Ke": rgb}} from an MTL file."""
    materials: dict[str, dict[str, tuple[float, ...]]] = {}
    current: dict[str, tuple[float, ...]] = {}
    for line in path.read_text().splitlines():
        keyword, *values = line.split("#", 1)[0].split() or [""]
        if keyword == "newmtl":
            current = materials.setdefault(" ".join(values), {})
        elif keyword in ("Kd", "Ke"):
            current[keyword] = tuple(float(v) for v in values[:3])
    return materials


def cornell_material(name: str, mtl: dict[str, tuple[float, ...]]) -> bpy.types.Material:
    """The Blender material of an MTL entry: an emitter (Ke) becomes an Emission shader of
    colour Ke / max(Ke) and strength max(Ke), so its radiance is Ke exactly (the published light,
    Ke = (17, 12, 4), leaves the walls well exposed); the others purely diffuse with Kd."""
    emitted = mtl.get("Ke", (0.0, 0.0, 0.0))
    if max(emitted) > 0:
        strength = max(emitted)
        return emission(name, [c / strength for c in emitted], strength)
    return diffuse_principled(name, mtl["Kd"])


def build_cornell_box(cell: float = CORNELL_CELL) -> bpy.types.Scene:
    """The Cornell box of cornell_box.obj: one object per OBJ object, quads split into grids of
    cells of about ``cell`` metres."""
    scene = bpy.context.scene
    objects, mtl = read_obj(CORNELL_OBJ)
    materials = {name: cornell_material(name, entry) for name, entry in mtl.items()}
    for item in objects:
        builder = MeshBuilder()
        for polygon in item.polygons:
            builder.add_quad(polygon, cell)
        builder.to_object(item.name, materials[item.material])

    set_world(scene, (0.0, 0.0, 0.0), 1.0)
    add_camera(
        scene,
        cornell_point(*CORNELL_CAMERA),
        cornell_point(*CORNELL_CAMERA) + Vector((0.0, 1.0, 0.0)),  # OBJ +Z is Blender +Y
        CORNELL_LENS,
        CORNELL_SENSOR,
    )
    set_render(scene, "cornell_box", CORNELL_RESOLUTION, CORNELL_RESOLUTION)
    return scene


# --------------------------------------------------------------------------------------------------
# Scene 2: a room lit through a window
# --------------------------------------------------------------------------------------------------

ROOM_SIZE = Vector((4.0, 4.0, 2.7))  # m, floor centred on the origin, window in the +Y wall
ROOM_CELL = 0.35  # m: 11-12 cells across the floor and 8 up the walls
# The window opening (m): x from -0.8 to 0.8 across the +Y wall, z from the sill to the head.
WINDOW_HALF_WIDTH = 0.8
WINDOW_SILL = 0.8
WINDOW_HEAD = 2.2
# The sun shines in through the window, 40 degrees above the horizon and 25 degrees off the
# wall's normal, so its patch falls on the floor and the table, about 1-2.5 m from the wall.
SUN_ELEVATION = math.radians(40.0)
SUN_AZIMUTH = math.radians(25.0)
SUN_STRENGTH = 5.0  # W/m^2 on a surface facing the sun
SKY_COLOUR = (0.45, 0.65, 1.0)  # linear RGB, light sky blue
SKY_STRENGTH = 1.0
# A room lit through one window is dim: show it one stop brighter. This is a display setting of
# the scene (renders and the viewport); the light, the radiance and a bake are unchanged.
ROOM_EXPOSURE = 1.0
WALL_COLOUR = (0.8, 0.78, 0.73)  # off-white plaster
FLOOR_COLOUR = (0.32, 0.16, 0.07)  # wood brown (sRGB about 153, 111, 74)
TABLE_COLOUR = (0.1, 0.3, 0.35)  # teal paint, to show colour bleeding onto the floor
TABLE_TOP = (Vector((-0.2, 0.7, 0.725)), Vector((1.2, 0.7, 0.05)))  # (centre, size) m
TABLE_LEG = 0.06  # m, square legs
TABLE_LEG_INSET = 0.08  # m from the edges of the top
TABLE_CELL = 0.2  # m: the table is small; finer cells show the light across its top


def inside_window(point: Vector) -> bool:
    """True for a point in the window opening of the +Y wall."""
    return abs(point.x) < WINDOW_HALF_WIDTH and WINDOW_SILL < point.z < WINDOW_HEAD


def build_room_shell(wall: bpy.types.Material, floor: bpy.types.Material) -> None:
    """Floor, ceiling and four walls facing inward (closed: nothing outside to waste patches),
    the +Y wall with the window opening cut along grid lines."""
    faces = box_faces(Vector((0.0, 0.0, ROOM_SIZE.z / 2)), ROOM_SIZE, inward=True)

    builder = MeshBuilder()
    builder.add_quad(faces["-z"], ROOM_CELL)
    builder.to_object("Floor", floor)

    builder = MeshBuilder()
    builder.add_quad(faces["+z"], ROOM_CELL)
    builder.to_object("Ceiling", wall)

    builder = MeshBuilder()
    for name in ("-x", "+x", "-y"):
        builder.add_quad(faces[name], ROOM_CELL)
    # The +Y wall's u axis runs along +X from x = -width/2, its v axis up from the floor.
    window_x = (ROOM_SIZE.x / 2 - WINDOW_HALF_WIDTH, ROOM_SIZE.x / 2 + WINDOW_HALF_WIDTH)
    builder.add_quad(
        faces["+y"],
        ROOM_CELL,
        u_cuts=cuts(ROOM_SIZE.x, ROOM_CELL, window_x),
        v_cuts=cuts(ROOM_SIZE.z, ROOM_CELL, (WINDOW_SILL, WINDOW_HEAD)),
        keep=lambda centre: not inside_window(centre),
    )
    builder.to_object("Walls", wall)


def build_table(material: bpy.types.Material) -> None:
    """A table: a top on four square legs (the legs have no bottom faces: they stand on the floor)."""
    centre, size = TABLE_TOP
    builder = MeshBuilder()
    builder.add_box(centre, size, TABLE_CELL)
    leg_height = centre.z - size.z / 2
    offset_x = size.x / 2 - TABLE_LEG_INSET - TABLE_LEG / 2
    offset_y = size.y / 2 - TABLE_LEG_INSET - TABLE_LEG / 2
    for sx in (-1, 1):
        for sy in (-1, 1):
            leg_centre = Vector((centre.x + sx * offset_x, centre.y + sy * offset_y, leg_height / 2))
            # one cell across a leg, cells of about TABLE_CELL up it; no bottom, the top touches the table
            builder.add_box(leg_centre, Vector((TABLE_LEG, TABLE_LEG, leg_height)), TABLE_CELL, skip="-z +z")
    builder.to_object("Table", material)


def sun_direction() -> Vector:
    """The way sunlight travels: down at SUN_ELEVATION, into the room through the +Y wall,
    turned SUN_AZIMUTH towards -X."""
    horizontal = math.cos(SUN_ELEVATION)
    return Vector((-horizontal * math.sin(SUN_AZIMUTH), -horizontal * math.cos(SUN_AZIMUTH), -math.sin(SUN_ELEVATION)))


def build_window_room() -> bpy.types.Scene:
    """A closed 4 x 4 x 2.7 m room with a window opening, a sun shining through it onto the floor
    and a table, and the sky (world colour) lighting the room through the opening."""
    scene = bpy.context.scene
    wall = diffuse_principled("Wall", WALL_COLOUR)
    build_room_shell(wall, diffuse_principled("Floor", FLOOR_COLOUR))
    build_table(diffuse_principled("Table", TABLE_COLOUR))

    # A sun has no position; it is placed outside the window only to be easy to find.
    sun_location = Vector((0.0, ROOM_SIZE.y / 2, WINDOW_HEAD)) - 2.0 * sun_direction()
    add_light("Sun", "SUN", sun_location, SUN_STRENGTH, target=sun_location + sun_direction())
    set_world(scene, SKY_COLOUR, SKY_STRENGTH)
    # From the corner opposite the window, at eye height, looking at the sunlit floor and the window.
    add_camera(scene, (1.7, -1.8, 1.6), (-0.35, 0.9, 0.75), lens=20.0)
    set_render(scene, "window_room", 640, 480)
    scene.view_settings.exposure = ROOM_EXPOSURE
    return scene


# --------------------------------------------------------------------------------------------------
# Scene 3: every kind of light
# --------------------------------------------------------------------------------------------------

STAGE_SIZE = Vector((5.0, 4.0, 2.5))  # m: floor, back wall (+Y) and two side walls, open front and top
STAGE_CELL = 0.4  # m: 12 x 10 cells on the floor, 6 up the walls
BLOCK_CELL = 0.2  # m: the blocks' faces split 2 to 6 times, so light and shadow across them show


def build_stage() -> None:
    """An open box: the floor and three walls facing inward (no ceiling, no front wall)."""
    faces = box_faces(Vector((0.0, 0.0, STAGE_SIZE.z / 2)), STAGE_SIZE, inward=True)
    builder = MeshBuilder()
    builder.add_quad(faces["-z"], STAGE_CELL)
    builder.to_object("Floor", diffuse_principled("Floor", (0.6, 0.6, 0.6)))
    builder = MeshBuilder()
    for name in ("-x", "+x", "+y"):
        builder.add_quad(faces[name], STAGE_CELL)
    builder.to_object("Walls", diffuse_principled("Walls", (0.75, 0.73, 0.7)))


def add_block(
    name: str, material: bpy.types.Material, centre: Sequence[float], size: Sequence[float], turn: float = 0.0
) -> bpy.types.Object:
    """A box of ``size`` (m) standing on the floor at ``centre`` (x, y), without a bottom face,
    turned ``turn`` degrees about Z."""
    builder = MeshBuilder()
    builder.add_box(Vector((0.0, 0.0, size[2] / 2)), Vector(size), BLOCK_CELL, skip="-z")
    obj = builder.to_object(name, material)
    obj.location = (centre[0], centre[1], 0.0)
    obj.rotation_euler.z = math.radians(turn)
    return obj


def add_sphere(name: str, material: bpy.types.Material, centre: Sequence[float], radius: float) -> bpy.types.Object:
    """A smooth-shaded icosphere (320 triangles) centred at ``centre``."""
    import bmesh  # the bpy module provides bmesh only once bpy is imported

    mesh = bpy.data.meshes.new(name)
    sphere = bmesh.new()
    bmesh.ops.create_icosphere(sphere, subdivisions=3, radius=radius)
    sphere.to_mesh(mesh)
    sphere.free()
    mesh.materials.append(material)
    mesh.shade_smooth()
    obj = link_object(name, mesh)
    obj.location = centre
    return obj


def build_lights() -> bpy.types.Scene:
    """An open box lit by a point, a spot and an area light and an emissive cube, with coloured
    Principled blocks, a Diffuse BSDF sphere, and a dim grey world."""
    scene = bpy.context.scene
    build_stage()
    # Colours are linear RGB; each object stands in one light's pool (centres in m, sizes in m).
    add_block("RedBlock", diffuse_principled("Red", (0.65, 0.07, 0.05)), (-1.4, 0.5), (0.6, 0.6, 0.6), turn=20)
    add_block("BlueBlock", diffuse_principled("Blue", (0.08, 0.15, 0.6)), (0.1, 0.9), (0.5, 0.5, 1.2), turn=-15)
    add_sphere("Sphere", diffuse_bsdf("YellowDiffuse", (0.7, 0.6, 0.15)), (1.4, 0.3, 0.4), 0.4)
    # A small orange glowing cube in front: radiance 5 x colour, from every face.
    add_block("GlowCube", emission("Glow", (1.0, 0.45, 0.12), 5.0), (0.5, -0.6), (0.25, 0.25, 0.25), turn=30)

    # Powers in W, chosen by eye so that no pool of light is washed out. The point and spot
    # lights' radii soften shadows and, with Soft Falloff (on), dim their light within a few radii.
    add_light("PointLight", "POINT", (-1.4, 0.0, 1.6), 60.0, shadow_soft_size=0.1)
    add_light(
        "SpotLight",
        "SPOT",
        (0.0, -1.0, 2.4),
        250.0,
        target=(0.1, 0.6, 0.0),
        spot_size=math.radians(45.0),
        spot_blend=0.15,
        shadow_soft_size=0.05,
    )
    # An area light shines down its local -Z: unturned, it lights the floor under it.
    add_light("AreaLight", "AREA", (1.4, 0.3, 1.8), 40.0, shape="RECTANGLE", size=1.0, size_y=0.5)

    set_world(scene, (0.5, 0.5, 0.5), 0.05)  # dark grey, dim: the lights do the work
    add_camera(scene, (0.0, -5.0, 1.9), (0.0, 0.3, 0.7), lens=35.0)
    set_render(scene, "lights", 640, 480)
    return scene


# --------------------------------------------------------------------------------------------------

SCENES = {
    "cornell_box": build_cornell_box,
    "window_room": build_window_room,
    "lights": build_lights,
}


def build(name: str, output_dir: Path, cornell_cell: float = CORNELL_CELL) -> Path:
    """Build one scene in a fresh empty file and save it (compressed, no .blend1 backup)."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.context.preferences.filepaths.save_version = 0  # no .blend1 backup when overwriting
    scene = build_cornell_box(cornell_cell) if name == "cornell_box" else SCENES[name]()
    path = output_dir / f"{name}.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(path), compress=True, check_existing=False)
    print(f"{path}: {triangle_count(scene)} triangles, {path.stat().st_size / 1024:.0f} KiB")
    return path


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--output-dir", type=Path, default=HERE, help="where to save the .blend files")
    parser.add_argument("--scene", action="append", choices=list(SCENES), help="build only this scene (repeatable)")
    parser.add_argument("--cornell-cell", type=float, default=CORNELL_CELL, metavar="METRES",
                        help=f"grid cells of the Cornell box (default {CORNELL_CELL}: walls 8 x 8; 0.01375: 40 x 40)")
    args = parser.parse_args(argv)
    args.output_dir.mkdir(parents=True, exist_ok=True)
    for name in args.scene or SCENES:
        build(name, args.output_dir.resolve(), args.cornell_cell)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
