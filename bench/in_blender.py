"""The studies' work inside Blender (the bpy module), each call in a process of its own through
bench/runner.py (bpy can be imported once per process): a measurement of a .blend (``measure``),
the core scene the add-on reads from one (``extract``), and the .blend files the studies build
(``build_cornell_box``, ``save_scene``). The checkout is loaded as a real extension
(tools/source_extension.py); times are taken around the bake calls alone (Blender's start-up and
the file load excluded).

Cases of ``measure`` (dicts, saved with the results as JSON), by ``kind``, on the file ``blend``
whose emitting meshes are ``emitters`` (left out of every comparison; every other mesh is compared):

- ``ours``: ``bpy.ops.radiosity.bake()``; ``settings`` sets scene.radiosity first (the core's
  knobs by the core's names and values, through the add-on's ``set_knob``; its own properties,
  such as ``preset``, as they are), ``node_inset`` moves core.mesh.nodes.NODE_INSET, ``render`` is
  a path for a picture of the baked colours.
- ``cycles``: a COMBINED vertex bake with ``samples`` and ``seed`` (../shared/CYCLES.md's recipe),
  optionally on a scene changed by one of VARIANTS.
- ``check``: the same Cycles bake per object and all at once (``samples``, ``seed``).
- ``render``: a Cycles render of the camera view to ``path`` (``samples``).
- ``live``: a bake as the panel's button runs it (its session kept), then Live's update after each
  of ``updates`` changes of the first material's colour, each timed (reading the scene, the
  re-solve and the write).
"""

from __future__ import annotations

import math
import re
import time
from pathlib import Path

import numpy as np

from bench.runner import cpu_seconds

ATTRIBUTE = "Radiosity"  # scene.radiosity.attribute_name's default: what our bake writes
CYCLES_ATTRIBUTE = "cycles"
CORNELL_EMITTERS = ("light",)  # the Cornell box's light: its corners carry its emission
# The Cornell box's non-emitting surfaces (object names), in the order the tables list them.
SURFACES = ("floor", "ceiling", "back_wall", "left_wall_red", "right_wall_green", "short_block", "tall_block")
PICTURE_SCALE = 75  # percent of the scene's 512 x 512: a 256-sample render at 512 is too large a PNG


def measure(case: dict) -> dict:
    """Open ``case["blend"]`` with the extension enabled and measure ``case``; its result (JSON-ready)."""
    from tools.source_extension import blender_with_extension

    bpy, package = blender_with_extension()
    bpy.ops.wm.open_mainfile(filepath=case["blend"], load_ui=False)
    kinds = {"ours": _case_ours, "cycles": _case_cycles, "check": _case_check, "render": _case_render,
             "live": _case_live}
    return kinds[case["kind"]](bpy, package, case) | {"threads": bpy.context.scene.render.threads,
                                                      "bpy": bpy.app.version_string}


def _case_ours(bpy, package, case: dict) -> dict:
    """Our bake as a user runs it (``bpy.ops.radiosity.bake()``, scene.radiosity as saved in the
    file, then ``case["settings"]`` set on it), timed around the call; the core's stats captured on
    the way through the operator module's ``run_straight`` (or, failing that, the seconds of the
    summary line)."""
    operators = package.radiosity_addon.operators
    captured = {}
    original = getattr(operators, "run_straight", None)
    if original is not None:
        def capturing(prepared, *args, **kwargs):
            captured["result"] = original(prepared, *args, **kwargs)
            return captured["result"]
        operators.run_straight = capturing
    scene = bpy.context.scene
    for name, value in case.get("settings", {}).items():  # the core's knobs by the core's names and values
        if name in package.core.settings.KNOB:
            scene.radiosity.set_knob(name, value)
        else:  # the add-on's own: preset, two_sided, ...
            setattr(scene.radiosity, name, value)
    if "node_inset" in case:  # a sensitivity check: where the core evaluates a vertex colour
        nodes = package.core.mesh.nodes
        if not hasattr(nodes, "NODE_INSET"):
            raise RuntimeError("core.mesh.nodes.NODE_INSET is gone: update the node-inset case of bench versus_cycles")
        nodes.NODE_INSET = case["node_inset"]
    settings = {name: str(getattr(scene.radiosity, name)) for name in ("preset", "method", "solver", "two_sided")}
    wall, cpu = time.perf_counter(), cpu_seconds()
    outcome = bpy.ops.radiosity.bake()
    wall, cpu = time.perf_counter() - wall, cpu_seconds() - cpu
    if outcome != {"FINISHED"}:
        raise RuntimeError(f"bpy.ops.radiosity.bake() returned {outcome}")
    summary = scene.radiosity.last_report
    if "result" in captured:
        stats = captured["result"].result.stats  # baking.Baked: the bake, and its light groups
        core_seconds, stages = stats["seconds"]["total"], {k: v for k, v in stats["seconds"].items() if k != "total"}
        counts = _counts(stats)
    else:
        core_seconds, stages, counts = float(re.search(r"([\d.]+) s\b", summary).group(1)), {}, {}
    if case.get("render"):
        _picture_settings(scene)
        package.radiosity_addon.preview.render_colours(scene, ATTRIBUTE, case["render"])
    return {"wall": wall, "cpu": cpu, "core_seconds": core_seconds, "stages": stages, "counts": counts,
            "summary": summary, "settings": settings, "threads_core": package.core.util.parallel.THREADS,
            "objects": _read_corners(bpy, ATTRIBUTE, case["emitters"], with_geometry=bool(case.get("render")))}


def _counts(stats: dict) -> dict:
    """What the reports quote of a bake's stats: sizes, work, the knobs the core used, how far
    the solver got, and the core's own error estimate where it gives one (None where it does not)."""
    counts = {key: stats.get(key) for key in ("triangles", "panels", "patches", "nodes", "shots", "iterations",
                                              "rays_cast", "unshot_fraction", "error_bound", "error_estimate",
                                              "refinements")}
    return counts | {key: stats["settings"][key] for key in ("patch_size", "rays_per_form_factor", "tolerance")}


def _case_cycles(bpy, _package, case: dict) -> dict:
    """A Cycles COMBINED vertex bake of every compared mesh at once (the check case shows it
    equals baking them one by one), timed around ``bpy.ops.object.bake``."""
    unbiased_cycles(bpy.context.scene, case["samples"], case["seed"])
    if case.get("variant"):
        VARIANTS[case["variant"]][1](bpy, case["emitters"])
    meshes = _compared_meshes(bpy, case["emitters"])
    _add_attribute(meshes, CYCLES_ATTRIBUTE)
    _select(bpy, meshes)
    wall, cpu = time.perf_counter(), cpu_seconds()
    bpy.ops.object.bake(type="COMBINED", target="VERTEX_COLORS")
    wall, cpu = time.perf_counter() - wall, cpu_seconds() - cpu
    return {"wall": wall, "cpu": cpu, "objects": _read_corners(bpy, CYCLES_ATTRIBUTE, case["emitters"])}


def _diffuse_bsdf(bpy, _emitters: list[str]) -> None:
    """Every Principled BSDF feeding a material output replaced by a Diffuse BSDF (roughness 0,
    Lambertian) of its base colour: does the Principled BSDF reflect more than a diffuse one?"""
    for material in bpy.data.materials:
        tree = material.node_tree
        output = tree.get_output_node("CYCLES") if tree is not None else None
        if output is None or not output.inputs["Surface"].is_linked:
            continue
        shader = output.inputs["Surface"].links[0].from_node
        if shader.bl_idname == "ShaderNodeBsdfPrincipled":
            diffuse = tree.nodes.new("ShaderNodeBsdfDiffuse")
            diffuse.inputs["Color"].default_value = shader.inputs["Base Color"].default_value
            diffuse.inputs["Roughness"].default_value = 0.0
            tree.links.new(diffuse.outputs["BSDF"], output.inputs["Surface"])


def _light_front_only(bpy, emitters: list[str]) -> None:
    """The emitters' Emission shader masked by Geometry > Backfacing, so they emit from their
    front only (a plain Emission shader emits from both sides): does the light's back matter?"""
    for name in emitters:
        for slot in bpy.context.scene.objects[name].material_slots:
            tree = slot.material.node_tree
            output = tree.get_output_node("CYCLES")
            emission = output.inputs["Surface"].links[0].from_node
            geometry, mix = tree.nodes.new("ShaderNodeNewGeometry"), tree.nodes.new("ShaderNodeMixShader")
            black = tree.nodes.new("ShaderNodeEmission")
            black.inputs["Strength"].default_value = 0.0
            tree.links.new(geometry.outputs["Backfacing"], mix.inputs["Fac"])
            tree.links.new(emission.outputs["Emission"], mix.inputs[1])
            tree.links.new(black.outputs["Emission"], mix.inputs[2])
            tree.links.new(mix.outputs["Shader"], output.inputs["Surface"])


# Cycles bakes of a changed scene: (what the report says, the change)
VARIANTS = {
    "diffuse_bsdf": ("Diffuse BSDF instead of the Principled BSDF", _diffuse_bsdf),
    "light_front_only": ("the light emitting from its front only", _light_front_only),
}


def _case_check(bpy, _package, case: dict) -> dict:
    """The same Cycles bake (same seed) done per object, each selected alone and active, and for
    all the meshes selected at once: the largest difference, and both times."""
    unbiased_cycles(bpy.context.scene, case["samples"], case["seed"])
    meshes = _compared_meshes(bpy, case["emitters"])
    times = {}
    for name, groups in (("per_object", [[m] for m in meshes]), ("together", [meshes])):
        _add_attribute(meshes, name)
        start = time.perf_counter()
        for group in groups:
            _select(bpy, group)
            bpy.ops.object.bake(type="COMBINED", target="VERTEX_COLORS")
        times[name] = time.perf_counter() - start
    one, both = (_read_corners(bpy, name, case["emitters"]) for name in ("per_object", "together"))
    difference = max(float(np.abs(np.array(one[n]["colours"]) - np.array(both[n]["colours"])).max()) for n in one)
    return {"max_difference": difference, "seconds": times}


def _case_live(bpy, package, case: dict) -> dict:
    """The first bake's seconds (kept for re-solves, as in the user interface) and each Live
    update's, after changing the base colour of the first material with one."""
    baking, live = package.radiosity_addon.baking, package.radiosity_addon.live
    scene = bpy.context.scene
    start = time.perf_counter()
    prepared = baking.prepare(scene, keep=True)
    baking.finish(prepared, baking.run_straight(prepared, echo=False))
    first = time.perf_counter() - start
    material = next(m for m in bpy.data.materials if m.node_tree is not None and any(
        "Base Color" in node.inputs or "Color" in node.inputs for node in m.node_tree.nodes))
    socket = next(node.inputs.get("Base Color") or node.inputs.get("Color") for node in material.node_tree.nodes
                  if "Base Color" in node.inputs or "Color" in node.inputs)
    updates, statuses = [], []
    for index in range(case["updates"]):
        socket.default_value = (0.2 + 0.6 * index / case["updates"], 0.4, 0.7, 1.0)
        start = time.perf_counter()
        statuses.append(live.update(scene))
        updates.append(time.perf_counter() - start)
    return {"first": first, "updates": updates, "statuses": statuses, "material": material.name}


def _case_render(bpy, _package, case: dict) -> dict:
    """A normal Cycles render of the scene's camera view, in the scene's own colour management."""
    scene = bpy.context.scene
    unbiased_cycles(scene, case["samples"], 0)
    _picture_settings(scene)
    scene.render.filepath = case["path"]
    start = time.perf_counter()
    bpy.ops.render.render(write_still=True)
    scale = scene.render.resolution_percentage / 100
    return {"wall": time.perf_counter() - start,
            "resolution": [round(scene.render.resolution_x * scale), round(scene.render.resolution_y * scale)],
            "view": scene.view_settings.view_transform, "look": scene.view_settings.look,
            "exposure": scene.view_settings.exposure}


def _picture_settings(scene) -> None:
    """Both pictures: PICTURE_SCALE of the scene's resolution, PNG at full compression, no dither
    (its noise only makes the files larger); the scene's colour management as it is."""
    scene.render.resolution_percentage = PICTURE_SCALE
    scene.render.dither_intensity = 0.0
    scene.render.image_settings.file_format = "PNG"
    scene.render.image_settings.compression = 100


def unbiased_cycles(scene, samples: int, seed: int) -> None:
    """The unbiased settings of CYCLES.md, and no denoiser (the files have them already; set again
    so that the studies do not depend on it). Cycles denoises a vertex-colour bake too, as a row of
    pixels in corner order: on by default, it blends the values of corners that are neighbours in
    that order, wherever they are (tests/addon/test_cycles_yardstick.py)."""
    scene.render.engine = "CYCLES"
    cycles = scene.cycles
    cycles.device = "CPU"
    cycles.samples = samples
    cycles.seed = seed
    cycles.use_adaptive_sampling = False
    cycles.use_denoising = False
    cycles.max_bounces = cycles.diffuse_bounces = 64
    cycles.sample_clamp_direct = cycles.sample_clamp_indirect = 0.0
    cycles.light_sampling_threshold = 0.0


def _compared_meshes(bpy, emitters: list[str]) -> list:
    """Every mesh object but the ``emitters``: the Cornell box's in SURFACES order, others by name."""
    meshes = {obj.name: obj for obj in bpy.context.scene.objects if obj.type == "MESH"}
    if not set(emitters) <= set(meshes):
        raise RuntimeError(f"emitters {sorted(set(emitters) - set(meshes))} are not meshes of the file")
    order = {name: index for index, name in enumerate(SURFACES)}
    return [meshes[name] for name in sorted(set(meshes) - set(emitters), key=lambda n: (order.get(n, len(order)), n))]


def _add_attribute(meshes: list, name: str) -> None:
    """A FLOAT_COLOR CORNER attribute on each mesh, made active (the bake writes the active one)."""
    for obj in meshes:
        attribute = obj.data.color_attributes.new(name, "FLOAT_COLOR", "CORNER")
        obj.data.color_attributes.active_color = attribute


def _select(bpy, objects: list) -> None:
    """Select only ``objects``, the first one active."""
    for obj in bpy.context.scene.objects:
        obj.select_set(False)
    for obj in objects:
        obj.select_set(True)
    bpy.context.view_layer.objects.active = objects[0]


def _read_corners(bpy, attribute: str, emitters: list[str], with_geometry: bool = False) -> dict:
    """{object: {"colours": (n, 3) list, "weights": (n,) list}} over the compared meshes, per loop
    (corner): the colour attribute's RGB and the corner's share of its polygon's area; with
    ``with_geometry``, also the _geometry of each mesh."""
    out = {}
    for obj in _compared_meshes(bpy, emitters):
        mesh = obj.data
        data = mesh.color_attributes[attribute]
        if data.data_type != "FLOAT_COLOR" or data.domain != "CORNER":
            raise RuntimeError(f"{obj.name}: '{attribute}' is {data.data_type} {data.domain}, not FLOAT_COLOR CORNER")
        colours = np.empty(len(mesh.loops) * 4, np.float32)
        data.data.foreach_get("color", colours)
        areas = np.empty(len(mesh.polygons), np.float32)
        mesh.polygons.foreach_get("area", areas)
        sizes = np.empty(len(mesh.polygons), np.int32)
        mesh.polygons.foreach_get("loop_total", sizes)
        scale = abs(np.linalg.det(np.array(obj.matrix_world)[:3, :3])) ** (2 / 3)  # the files' are identity
        weights = np.repeat(areas * scale / sizes, sizes)  # polygons' loops are contiguous, in order
        out[obj.name] = {"colours": colours.reshape(-1, 4)[:, :3].tolist(), "weights": weights.tolist()}
        if with_geometry:
            out[obj.name] |= _geometry(obj)
    return out


def _geometry(obj) -> dict:
    """World-space "positions" (n, 3) of each loop's vertex, and "triangles" (t, 3, 3) of the mesh."""
    mesh = obj.data
    matrix = np.array(obj.matrix_world)
    vertices = np.empty(len(mesh.vertices) * 3, np.float64)
    mesh.vertices.foreach_get("co", vertices)
    vertices = vertices.reshape(-1, 3) @ matrix[:3, :3].T + matrix[:3, 3]
    loops = np.empty(len(mesh.loops), np.int32)
    mesh.loops.foreach_get("vertex_index", loops)
    mesh.calc_loop_triangles()
    triangles = np.empty(len(mesh.loop_triangles) * 3, np.int32)
    mesh.loop_triangles.foreach_get("vertices", triangles)
    return {"positions": vertices[loops].tolist(), "triangles": vertices[triangles.reshape(-1, 3)].tolist()}


def extract(path: Path) -> tuple[dict, np.ndarray, np.ndarray]:
    """The core scene of the .blend at ``path`` as the add-on reads it (its fields, as plain
    arrays: the extension's own classes cannot be unpickled without Blender), and the (object
    name, loop) each triangle corner's colour is written to, both (T, 3)."""
    from tools.source_extension import blender_with_extension

    bpy, package = blender_with_extension()
    bpy.ops.wm.open_mainfile(filepath=str(path), load_ui=False)
    extraction = package.radiosity_addon.baking.prepare(bpy.context.scene).extraction
    scene = extraction.scene
    if scene.lights:
        raise ValueError(f"{path.name} has lights, which only Blender's process can hold")
    fields = {name: getattr(scene, name) for name in scene.__dataclass_fields__ if name != "lights"}
    count = len(scene.triangles)
    owner, loop = np.empty((count, 3), dtype=object), np.zeros((count, 3), dtype=np.int64)
    for target in extraction.targets:
        owner[target.start:target.stop] = target.object_name
        loop[target.start:target.stop] = np.asarray(target.loops).reshape(-1, 3)
    return fields, owner, loop


def build_cornell_box(path: Path, cell: float) -> str:
    """The sample Cornell box with grid cells of about ``cell`` metres, saved at ``path`` by
    sample_blends/build_samples.py (with this bpy); what was built."""
    from tools.source_extension import import_bpy

    bpy = import_bpy()
    from sample_blends import build_samples

    built = build_samples.build("cornell_box", path.parent, cell).rename(path)
    return f"{build_samples.triangle_count(bpy.context.scene)} triangles, {built.stat().st_size / 1024:.0f} KiB"


def save_scene(scene, names: list[str], path: Path, smooth_angle: float | None = None) -> str:
    """A core ``scene`` (+Y up, as the OBJ files) saved as a .blend at ``path``, turned to Blender's
    +Z up by (x, y, z) -> (x, -z, y): one mesh object per material, named by ``names``, shaded flat
    or, with ``smooth_angle`` (degrees), smooth but
    across edges sharper than that (as the core joins a scene's nodes without corner normals at its
    crease angle); surfaces purely diffuse Principled BSDFs of their reflectance, emitters a plain
    Emission shader; the scene's uniform ``sky`` (RGB) as the world's background (none where it is
    black); Cycles set up as ../shared/CYCLES.md says. What was built."""
    from tools.source_extension import import_bpy

    bpy = import_bpy()
    from sample_blends import build_samples

    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.context.preferences.filepaths.save_version = 0
    vertices = scene.vertices[:, [0, 2, 1]] * np.array([1.0, -1.0, 1.0])
    for material in np.unique(scene.material):
        chosen = np.flatnonzero(scene.material == material)
        used, corners = np.unique(scene.triangles[chosen], return_inverse=True)
        mesh = bpy.data.meshes.new(names[material])
        mesh.from_pydata(vertices[used].tolist(), [], corners.reshape(-1, 3).tolist())
        if smooth_angle is not None:
            mesh.shade_smooth()
            mesh.set_sharp_from_angle(angle=math.radians(smooth_angle))
        mesh.update()
        emission = scene.emission[chosen[0]]
        if emission.any():
            strength = float(emission.max())
            mesh.materials.append(build_samples.emission(names[material], tuple(emission / strength), strength))
        else:
            reflectance = tuple(scene.reflectance[chosen[0]])
            mesh.materials.append(build_samples.diffuse_principled(names[material], reflectance))
        build_samples.link_object(names[material], mesh)
    if np.any(scene.sky):
        strength = float(np.max(scene.sky))
        build_samples.set_world(bpy.context.scene, tuple(np.asarray(scene.sky) / strength), strength)
    build_samples.set_render(bpy.context.scene, path.stem, 512, 512)
    bpy.ops.wm.save_as_mainfile(filepath=str(path), compress=True, check_existing=False)
    return f"{len(scene.triangles)} triangles, {len(names)} meshes, {path.stat().st_size / 1024:.0f} KiB"
