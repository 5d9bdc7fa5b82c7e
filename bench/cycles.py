"""Our bake of sample_blends/cornell_box.blend at the default preset against a Cycles COMBINED
vertex bake of the same file; writes docs/cycles.md and two pictures for the README
(docs/cornell_box_radiosity.png, docs/cornell_box_cycles.png), and prints the report.

Run from the repository root: ``.venv/bin/python bench/cycles.py [--samples 1024] [--quick]``
(``--quick``: 64 samples, to try the script). Every measurement runs in a process of its own (bpy
can be imported once per process): this script started again in its worker mode, which loads the
checkout as a real extension (tools/source_extension.py), measures one case and writes JSON. The Cycles
bake follows ../shared/CYCLES.md (CPU, no adaptive sampling, no clamping, light threshold 0, 64
bounces, a FLOAT_COLOR CORNER attribute made active, COMBINED into VERTEX_COLORS). The machine is
shared and noisy: compare the ratios of one run, not absolute figures across runs.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import re
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

import machine  # bench/ is the script's directory, so its modules import by name
import numpy as np

REPO = Path(__file__).resolve().parent.parent
BLEND = REPO / "sample_blends" / "cornell_box.blend"
OUTPUT = REPO / "docs" / "cycles.md"
OUR_PICTURE = REPO / "docs" / "cornell_box_radiosity.png"
CYCLES_PICTURE = REPO / "docs" / "cornell_box_cycles.png"
COMMAND = ".venv/bin/python bench/cycles.py"

ATTRIBUTE = "Radiosity"  # scene.radiosity.attribute_name's default: what the bake writes
CYCLES_ATTRIBUTE = "cycles"
EMITTERS = ("light",)  # the Cornell light's mesh: its corners carry its emission, left out of every comparison
# The non-emitting surfaces of the file, in the order the tables list them (object names).
SURFACES = ("floor", "ceiling", "back_wall", "left_wall_red", "right_wall_green", "short_block", "tall_block")

SAMPLES = 1024  # Cycles reference samples per corner, two seeds
QUICK_SAMPLES = 64
SEEDS = (1, 2)  # scene.cycles.seed of the two reference bakes
LOW_SAMPLES = (16, 64, 256)  # the error-against-time curve (one bake each, seed LOW_SEED)
QUICK_LOW_SAMPLES = (4, 16)
LOW_SEED = 3
OUR_RUNS = 3  # our bake is short: time it in this many processes and report the median
# Our other presets, one run each, for the error-against-time table (REFERENCE takes minutes: not --quick)
OTHER_PRESETS = ("DRAFT", "PRODUCTION", "REFERENCE")
QUICK_OTHER_PRESETS = ("DRAFT",)
CHECK_SAMPLES = 16  # per-object and all-at-once bakes compared at this many samples
PICTURE_SAMPLES = 256  # the Cycles render for the README
PICTURE_SCALE = 75  # percent of the scene's 512 x 512: a 256-sample render at 512 is too large a PNG
PICTURE_LIMIT = 300_000  # bytes per PNG
LUMINANCE = np.array([0.2126, 0.7152, 0.0722])  # Rec. 709 weights: one number per surface
TOUCH = 1e-4  # m: a corner whose vertex is this close to another surface sits where two surfaces meet
NODE_INSETS = (1e-4, 1e-2)  # our node placement, moved either way from core.discretize.NODE_INSET (1e-3)
CORNER_INSET = 1e-4  # Cycles bakes a corner this x max(1, |coords|) inside its face (CYCLES.md)


# --------------------------------------------------------------------------------------------------
# Worker mode: one measurement inside bpy, in a process of its own
# --------------------------------------------------------------------------------------------------


def worker(case: dict, result_path: str) -> None:
    """Measure ``case`` (see the ``_case_*`` functions) and write its JSON to ``result_path``."""
    # bench/ is first on sys.path (the script's directory), where this file would shadow Blender's
    # own "cycles" add-on: take it off before bpy is imported, after importing what we need from it.
    here = str(Path(__file__).resolve().parent)
    sys.path[:] = [entry for entry in sys.path if os.path.abspath(entry or ".") != here]
    sys.modules.pop("cycles", None)
    sys.path.insert(0, str(Path(here).parent))
    from tools.source_extension import blender_with_extension

    bpy, package = blender_with_extension()

    bpy.ops.wm.open_mainfile(filepath=str(BLEND), load_ui=False)
    kind = case["kind"]
    result = {"ours": _case_ours, "cycles": _case_cycles, "check": _case_check, "render": _case_render}[kind](
        bpy, package, case
    )
    result["threads"] = bpy.context.scene.render.threads
    result["bpy"] = bpy.app.version_string
    Path(result_path).write_text(json.dumps(result))


def _case_ours(bpy, package, case: dict) -> dict:
    """Our bake as a user runs it (``bpy.ops.radiosity.bake()``, scene.radiosity as saved in the
    file), timed around the call; the core's own seconds from its stats (captured on the way
    through the operator module's ``run_straight``) or, failing that, from the summary line."""
    operators = package.radiosity_addon.operators
    captured = {}
    original = getattr(operators, "run_straight", None)
    if original is not None:
        def capturing(prepared, *args, **kwargs):
            captured["result"] = original(prepared, *args, **kwargs)
            return captured["result"]
        operators.run_straight = capturing
    scene = bpy.context.scene
    if case.get("preset"):
        scene.radiosity.preset = case["preset"]
    if "two_sided" in case:
        scene.radiosity.two_sided = case["two_sided"]
    if "node_inset" in case:  # a sensitivity check: where the core evaluates a vertex colour
        discretize = package.core.discretize
        if not hasattr(discretize, "NODE_INSET"):
            raise RuntimeError("core.discretize.NODE_INSET is gone: update the node-inset case of bench/cycles.py")
        discretize.NODE_INSET = case["node_inset"]
    settings = {name: str(getattr(scene.radiosity, name)) for name in ("preset", "method", "solver", "two_sided")}
    wall, cpu = time.perf_counter(), _cpu_seconds()
    outcome = bpy.ops.radiosity.bake()
    wall, cpu = time.perf_counter() - wall, _cpu_seconds() - cpu
    if outcome != {"FINISHED"}:
        raise RuntimeError(f"bpy.ops.radiosity.bake() returned {outcome}")
    summary = scene.radiosity.last_report
    if "result" in captured:
        stats = captured["result"].stats
        core_seconds, stages = stats["seconds"]["total"], {k: v for k, v in stats["seconds"].items() if k != "total"}
        counts = {key: stats.get(key) for key in ("triangles", "patches", "nodes", "shots", "rays_cast")}
        counts["patch_size"] = stats["settings"]["patch_size"]
        counts["rays_per_form_factor"] = stats["settings"]["rays_per_form_factor"]
        counts["tolerance"] = stats["settings"]["tolerance"]
        counts["unshot_fraction"] = stats.get("unshot_fraction")
    else:
        core_seconds, stages, counts = float(re.search(r"([\d.]+) s\b", summary).group(1)), {}, {}
    if case.get("render"):
        _picture_settings(scene)
        package.radiosity_addon.preview.render_colours(scene, ATTRIBUTE, case["render"])
    return {"wall": wall, "cpu": cpu, "core_seconds": core_seconds, "stages": stages, "counts": counts,
            "summary": summary, "settings": settings, "threads_core": package.core.parallel.THREADS,
            "objects": _read_corners(bpy, ATTRIBUTE, with_geometry=bool(case.get("render")))}


def _case_cycles(bpy, _package, case: dict) -> dict:
    """A Cycles COMBINED vertex bake of every non-emitting mesh at once (the check case shows it
    equals baking them one by one), timed around ``bpy.ops.object.bake``."""
    _cycles_settings(bpy.context.scene, case["samples"], case["seed"])
    if case.get("variant"):
        VARIANTS[case["variant"]][1](bpy)
    meshes = _baked_meshes(bpy)
    _add_attribute(meshes, CYCLES_ATTRIBUTE)
    _select(bpy, meshes)
    wall, cpu = time.perf_counter(), _cpu_seconds()
    bpy.ops.object.bake(type="COMBINED", target="VERTEX_COLORS")
    wall, cpu = time.perf_counter() - wall, _cpu_seconds() - cpu
    return {"wall": wall, "cpu": cpu, "objects": _read_corners(bpy, CYCLES_ATTRIBUTE)}


def _diffuse_bsdf(bpy) -> None:
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


def _light_front_only(bpy) -> None:
    """The emitters' Emission shader masked by Geometry > Backfacing, so they emit from their
    front only (a plain Emission shader emits from both sides): does the light's back matter?"""
    for name in EMITTERS:
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


# Cycles bakes of a changed scene: (what the table says, the change)
VARIANTS = {
    "diffuse_bsdf": ("Diffuse BSDF instead of the Principled BSDF", _diffuse_bsdf),
    "light_front_only": ("the light emitting from its front only", _light_front_only),
}


def _case_check(bpy, _package, case: dict) -> dict:
    """The same Cycles bake (same seed) done per object, each selected alone and active, and for
    all the meshes selected at once: the largest difference, and both times."""
    _cycles_settings(bpy.context.scene, case["samples"], case["seed"])
    meshes = _baked_meshes(bpy)
    times = {}
    for name, groups in (("per_object", [[m] for m in meshes]), ("together", [meshes])):
        _add_attribute(meshes, name)
        start = time.perf_counter()
        for group in groups:
            _select(bpy, group)
            bpy.ops.object.bake(type="COMBINED", target="VERTEX_COLORS")
        times[name] = time.perf_counter() - start
    one, both = _read_corners(bpy, "per_object"), _read_corners(bpy, "together")
    difference = max(float(np.abs(np.array(one[n]["colours"]) - np.array(both[n]["colours"])).max()) for n in one)
    return {"max_difference": difference, "seconds": times}


def _case_render(bpy, _package, case: dict) -> dict:
    """A normal Cycles render of the scene's camera view, in the scene's own colour management."""
    scene = bpy.context.scene
    _cycles_settings(scene, case["samples"], 0)
    scene.cycles.use_denoising = False
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


def _cycles_settings(scene, samples: int, seed: int) -> None:
    """The unbiased settings of CYCLES.md (the file has them already; set again so the bench does not
    depend on it)."""
    scene.render.engine = "CYCLES"
    cycles = scene.cycles
    cycles.device = "CPU"
    cycles.samples = samples
    cycles.seed = seed
    cycles.use_adaptive_sampling = False
    cycles.max_bounces = cycles.diffuse_bounces = 64
    cycles.sample_clamp_direct = cycles.sample_clamp_indirect = 0.0
    cycles.light_sampling_threshold = 0.0


def _baked_meshes(bpy) -> list:
    """The non-emitting mesh objects, in SURFACES order; fails if the file has other surfaces."""
    meshes = {obj.name: obj for obj in bpy.context.scene.objects if obj.type == "MESH"}
    if set(meshes) != set(SURFACES) | set(EMITTERS):
        raise RuntimeError(f"unexpected meshes in {BLEND.name}: {sorted(meshes)}")
    return [meshes[name] for name in SURFACES]


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


def _read_corners(bpy, attribute: str, with_geometry: bool = False) -> dict:
    """{object: {"colours": (n, 3) list, "weights": (n,) list}} over the non-emitting meshes, per
    loop (corner): the colour attribute's RGB and the corner's share of its polygon's area; with
    ``with_geometry``, also the _geometry of each mesh."""
    out = {}
    for obj in _baked_meshes(bpy):
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
        scale = abs(np.linalg.det(np.array(obj.matrix_world)[:3, :3])) ** (2 / 3)  # the file's are identity
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


def _cpu_seconds() -> float:
    usage = resource.getrusage(resource.RUSAGE_SELF)
    return usage.ru_utime + usage.ru_stime


# --------------------------------------------------------------------------------------------------
# Driver: run the cases in fresh processes, one at a time
# --------------------------------------------------------------------------------------------------


def run_case(case: dict) -> dict:
    """``case`` measured by this script's worker mode in a new interpreter; its JSON."""
    with tempfile.TemporaryDirectory(prefix="radiosity-cycles-") as scratch:
        path = os.path.join(scratch, "result.json")
        process = subprocess.run(
            [sys.executable, str(Path(__file__).resolve()), "--worker", json.dumps(case), "--result", path],
            cwd=REPO, capture_output=True, text=True, check=False,
        )
        if process.returncode != 0 or not os.path.exists(path):
            sys.stderr.write(process.stdout[-3000:] + process.stderr[-5000:])
            raise RuntimeError(f"worker for {case} failed (exit code {process.returncode})")
        return json.loads(Path(path).read_text())


@dataclass
class Corners:
    """Corner colours of the non-emitting surfaces, stacked in SURFACES order."""

    colours: np.ndarray  # (M, 3)
    weights: np.ndarray  # (M,) the corner's share of its polygon's area
    surface: np.ndarray  # (M,) index into SURFACES

    @classmethod
    def of(cls, result: dict) -> Corners:
        objects = result["objects"]
        return cls(
            np.concatenate([np.array(objects[name]["colours"], dtype=np.float64) for name in SURFACES]),
            np.concatenate([np.array(objects[name]["weights"], dtype=np.float64) for name in SURFACES]),
            np.concatenate([np.full(len(objects[name]["weights"]), k) for k, name in enumerate(SURFACES)]),
        )

    def surface_means(self) -> np.ndarray:
        """(S, 3) area-weighted mean colour of each surface."""
        return np.array([np.average(self.colours[self.surface == k], axis=0, weights=self.weights[self.surface == k])
                         for k in range(len(SURFACES))])


def touching(objects: dict) -> np.ndarray:
    """(M,) bool in SURFACES order: the corner's vertex lies within TOUCH of a triangle of another
    non-emitting mesh, i.e. where two surfaces meet (the room's edges, the blocks' bottom edges)."""
    parts = []
    for name in SURFACES:
        others = np.concatenate([np.array(objects[other]["triangles"]) for other in SURFACES if other != name])
        parts.append(_near_triangles(np.array(objects[name]["positions"]), others, TOUCH))
    return np.concatenate(parts)


def _near_triangles(points: np.ndarray, triangles: np.ndarray, distance: float) -> np.ndarray:
    """(n,) bool: points (n, 3) within ``distance`` of any of triangles (t, 3, 3) (of its plane, and
    of its inside or no further than ``distance`` outside its edges)."""
    a, b, c = triangles[:, 0], triangles[:, 1], triangles[:, 2]
    normal = np.cross(b - a, c - a)
    normal /= np.linalg.norm(normal, axis=1, keepdims=True)
    near = np.zeros(len(points), bool)
    for start in range(0, len(points), 128):
        p = points[start:start + 128, None, :]  # (k, 1, 3) against (t, 3)
        height = np.einsum("ktx,tx->kt", p - a, normal)
        foot = p - height[..., None] * normal
        hit = np.abs(height) <= distance
        for u, v in ((a, b), (b, c), (c, a)):  # signed distance of the foot inside each edge
            inside = np.einsum("ktx,tx->kt", np.cross(v - u, foot - u), normal)
            hit &= inside >= -distance * np.linalg.norm(v - u, axis=1)
        near[start:start + 128] = hit.any(axis=1)
    return near


def nrmse(values: np.ndarray, reference: np.ndarray) -> float:
    """RMS of the difference over the mean of the reference, over every element."""
    return float(np.sqrt(np.mean((values - reference) ** 2)) / np.mean(reference))


def without_noise(error: float, noise: float) -> float:
    """``error`` with ``noise`` subtracted in quadrature (0 when the noise explains it all)."""
    return math.sqrt(max(error**2 - noise**2, 0.0))


# --------------------------------------------------------------------------------------------------
# The report
# --------------------------------------------------------------------------------------------------


def _table(header: list[str], rows: list[list[str]]) -> str:
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    return "\n".join(lines + ["| " + " | ".join(row) + " |" for row in rows])


def _pct(value: float) -> str:
    return f"{100 * value:.2f} %"


def _rgb(values, digits: int = 4) -> str:
    return ", ".join(f"{v:.{digits}f}" for v in values)


@dataclass
class Analysis:
    """Everything the report says, computed from the cases' results."""

    samples: int
    ours: list[dict]
    seeds: list[dict]
    low: list[dict]
    check: dict
    pictures: dict
    presets: dict  # preset name -> the result of one bake of ours at that preset
    variants: dict  # label -> (kind "ours" or "cycles", what changed, the result)

    def __post_init__(self) -> None:
        first, second = (Corners.of(r) for r in self.seeds)
        self.reference = Corners(0.5 * (first.colours + second.colours), first.weights, first.surface)
        self.our_corners = Corners.of(self.ours[0])
        scale = float(np.mean(self.reference.colours))
        # One seed's noise, from the two seeds' difference; the mean of both has 1/sqrt(2) of it.
        self.noise = float(np.sqrt(np.mean((first.colours - second.colours) ** 2) / 2) / scale)
        self.reference_noise = self.noise / math.sqrt(2)
        self.error = nrmse(self.our_corners.colours, self.reference.colours)
        self.bias = without_noise(self.error, self.reference_noise)
        self.seed_means = (first.surface_means(), second.surface_means())
        self.our_walls = [r["wall"] for r in self.ours]
        self.our_wall = statistics.median(self.our_walls)
        self.cycles_wall = statistics.mean(r["wall"] for r in self.seeds)
        # time = a + b samples, fitted to every Cycles bake of the run
        counts = [r["samples"] for r in self.low] + [self.samples] * len(self.seeds)
        walls = [r["wall"] for r in self.low] + [r["wall"] for r in self.seeds]
        self.fit = np.polyfit(counts, walls, 1) if len(set(counts)) > 1 else None
        # Cycles samples whose noise alone equals our bias (noise falls as 1 / sqrt(samples))
        self.equal_samples = self.samples * (self.noise / self.bias) ** 2 if self.bias > 0 else math.inf
        # where the error is: corners where two surfaces meet; corners Cycles bakes black (enclosed)
        self.touching = touching(self.ours[0]["objects"])
        self.enclosed = (self.reference.colours <= 0).all(axis=1)
        self.elsewhere = ~self.touching & ~self.enclosed
        self.seed_colours = (first.colours, second.colours)

    def squared_share(self, mask: np.ndarray) -> float:
        """Share of our squared error (against the reference) on the corners of ``mask``."""
        squared = ((self.our_corners.colours - self.reference.colours) ** 2).sum(axis=1)
        return float(squared[mask].sum() / squared.sum())

    def masked_errors(self, mask: np.ndarray) -> tuple[float, float]:
        """(NRMSE, bias) of ours on the corners of ``mask``, both relative to the mean of the whole
        reference (so they add up in quadrature over complementary masks)."""
        scale = float(np.mean(self.reference.colours))
        error = float(np.sqrt(np.mean((self.our_corners.colours[mask] - self.reference.colours[mask]) ** 2))) / scale
        first, second = (colours[mask] for colours in self.seed_colours)
        noise = float(np.sqrt(np.mean((first - second) ** 2) / 2)) / scale / math.sqrt(2)
        return error, without_noise(error, noise)

    def where_rows(self) -> list[list[str]]:
        """Per surface: the corners where it meets another surface, the enclosed ones, the others."""
        ours, reference = self.our_corners.colours @ LUMINANCE, self.reference.colours @ LUMINANCE
        rows = []
        for k, name in enumerate(SURFACES):
            cells = [f"`{name}`"]
            for mask in (self.touching, self.elsewhere):
                group = (self.our_corners.surface == k) & mask
                if not group.any():
                    cells += ["0", "", ""]
                    continue
                rms = np.sqrt(np.mean((self.our_corners.colours[group] - self.reference.colours[group]) ** 2))
                cells += [f"{group.sum()}", f"{ours[group].mean() / reference[group].mean():.3f}",
                          _pct(rms / self.reference.colours[group].mean())]
            group = (self.our_corners.surface == k) & self.enclosed
            cells += [f"{group.sum()}", f"{ours[group].mean():.4f}" if group.any() else ""]
            rows.append(cells)
        return rows

    def variant_ratios(self, result: dict) -> np.ndarray:
        """(S,) luminance ratio of a bake's surface means to the reference's."""
        return Corners.of(result).surface_means() @ LUMINANCE / (self.reference.surface_means() @ LUMINANCE)

    def variant_rows(self) -> list[list[str]]:
        """Each changed bake against its unchanged twin (ours: run 1; Cycles: seed 1, same seed)."""
        baselines = {"ours": (f"ours, preset {self.ours[0]['settings']['preset']}", self.ours[0]),
                     "cycles": (f"Cycles, {self.samples} samples, seed {SEEDS[0]}", self.seeds[0])}
        rows = []
        for kind, (label, result) in baselines.items():
            rows.append([label, "(as measured above)", _pct(nrmse(Corners.of(result).colours, self.reference.colours)),
                         "", *(f"{r:.3f}" for r in self.variant_ratios(result))])
            for variant_kind, change, changed in self.variants.values():
                if variant_kind != kind:
                    continue
                difference = np.abs(Corners.of(changed).colours - Corners.of(result).colours).max()
                rows.append(["", change, _pct(nrmse(Corners.of(changed).colours, self.reference.colours)),
                             "0 (identical)" if difference == 0 else f"{difference:.3g}",
                             *(f"{r:.3f}" for r in self.variant_ratios(changed))])
        return rows

    def variant_sentences(self) -> list[str]:
        """What the changed bakes say about where the difference comes from."""
        sentences = []
        base = {"ours": self.ours[0], "cycles": self.seeds[0]}
        for kind, change, changed in self.variants.values():
            difference = float(np.abs(Corners.of(changed).colours - Corners.of(base[kind]).colours).max())
            shift = self.variant_ratios(changed) - self.variant_ratios(base[kind])
            worst = int(np.argmax(np.abs(shift)))
            who = "Cycles" if kind == "cycles" else "ours"
            if difference == 0:
                sentences.append(f"{who} with {change}: bit-identical (same seed), so it plays no part here")
            elif abs(shift[worst]) < 0.0005:
                sentences.append(f"{who} with {change}: surface ratios move by less than 0.001; corners by up to "
                                 f"{difference:.3g}")
            else:
                sentences.append(f"{who} with {change}: surface ratios move by at most {abs(shift[worst]):.3f} "
                                 f"(`{SURFACES[worst]}`, {shift[worst]:+.3f}); corners by up to {difference:.3g}")
        return sentences

    def low_rows(self) -> list[list[str]]:
        rows = []
        for result in self.low:
            values = Corners.of(result).colours
            error = nrmse(values, self.reference.colours)
            expected = self.noise * math.sqrt(self.samples / result["samples"])
            rows.append([f"Cycles, {result['samples']} samples (seed {LOW_SEED})", f"{result['wall']:.2f}",
                         f"{result['cpu'] / result['wall']:.2f}", _pct(error),
                         _pct(without_noise(error, self.reference_noise)), _pct(expected)])
        return rows

    def speed_rows(self) -> list[list[str]]:
        ours = self.ours[0]
        stage_text = ", ".join(f"{k} {v:.2f}" for k, v in ours["stages"].items())
        rows = [[f"ours, preset {ours['settings']['preset']}", ", ".join(f"{r['wall']:.2f}" for r in self.ours),
                 f"{self.our_wall:.2f}",
                 ", ".join(f"{r['core_seconds']:.2f}" for r in self.ours),
                 f"{statistics.median(r['cpu'] / r['wall'] for r in self.ours):.2f}",
                 f"{ours['threads_core']} (core.parallel)", stage_text or "n/a"]]
        for seed, result in zip(SEEDS, self.seeds, strict=True):
            rows.append([f"Cycles, {self.samples} samples, seed {seed}", f"{result['wall']:.2f}",
                         f"{result['wall']:.2f}",
                         "", f"{result['cpu'] / result['wall']:.2f}", f"{result['threads']} (render.threads)", ""])
        return rows

    def error_rows(self) -> list[list[str]]:
        rows = [[f"ours, preset {self.ours[0]['settings']['preset']} (median of {len(self.ours)})",
                 f"{self.our_wall:.2f}", f"{statistics.median(r['cpu'] / r['wall'] for r in self.ours):.2f}",
                 _pct(self.error), _pct(self.bias), "0 (deterministic)"]]
        for name, result in self.presets.items():
            error = nrmse(Corners.of(result).colours, self.reference.colours)
            rows.append([f"ours, preset {name}", f"{result['wall']:.2f}", f"{result['cpu'] / result['wall']:.2f}",
                         _pct(error), _pct(without_noise(error, self.reference_noise)), "0 (deterministic)"])
        rows += self.low_rows()
        for seed, result in zip(SEEDS, self.seeds, strict=True):
            rows.append([f"Cycles, {self.samples} samples (seed {seed})", f"{result['wall']:.2f}",
                         f"{result['cpu'] / result['wall']:.2f}", "(part of the reference)", "0 (unbiased)",
                         _pct(self.noise)])
        return rows

    def surface_rows(self) -> list[list[str]]:
        ours, reference = self.our_corners.surface_means(), self.reference.surface_means()
        spread = np.abs(self.seed_means[0] - self.seed_means[1]) / 2  # standard error of the two seeds' mean
        rows = []
        for k, name in enumerate(SURFACES):
            mask = self.our_corners.surface == k
            error = nrmse(self.our_corners.colours[mask], self.reference.colours[mask])
            first, second = (Corners.of(r).colours[mask] for r in self.seeds)
            noise = float(np.sqrt(np.mean((first - second) ** 2) / 2) / np.mean(self.reference.colours[mask]))
            rows.append([f"`{name}`", _rgb(ours[k]), _rgb(reference[k]), _rgb(spread[k], 4),
                         _rgb(ours[k] / reference[k], 3), _pct(error),
                         _pct(without_noise(error, noise / math.sqrt(2)))])
        return rows

    def preset_rows(self) -> list[list[str]]:
        """Per surface, the luminance ratio ours / Cycles at every preset measured."""
        reference = self.reference.surface_means() @ LUMINANCE
        bakes = {self.ours[0]["settings"]["preset"]: self.ours[0]} | self.presets
        ratios = {name: Corners.of(result).surface_means() @ LUMINANCE / reference for name, result in bakes.items()}
        spread = np.abs(self.seed_means[0] - self.seed_means[1]) @ LUMINANCE / 2 / reference
        order = [name for name in ("DRAFT", "PREVIEW", "PRODUCTION", "REFERENCE") if name in ratios]
        return [[f"`{surface}`", *(f"{ratios[name][k]:.3f}" for name in order), f"{spread[k]:.3f}"]
                for k, surface in enumerate(SURFACES)], order

    def refinement_sentence(self) -> str:
        """What the PRODUCTION preset changed, if it was measured."""
        production = self.presets.get("PRODUCTION")
        if production is None or not production["counts"] or not self.ours[0]["counts"]:
            return ""
        ours, finer = self.ours[0]["counts"], production["counts"]
        error = nrmse(Corners.of(production).colours, self.reference.colours)
        same = ours["patches"] == finer["patches"]
        return (f" PRODUCTION ({finer['rays_per_form_factor']} rays, tolerance {finer['tolerance']:g}"
                + (f", and on this file the same {finer['patches']:,} patches as PREVIEW: the input triangles are "
                   "already smaller than either patch size" if same else f", {finer['patches']:,} patches")
                + f") moves the NRMSE from {_pct(self.error)} to {_pct(error)}.")

    def fitted_seconds(self, samples: float) -> float | None:
        return None if self.fit is None or not math.isfinite(samples) else float(np.polyval(self.fit, samples))


def markdown(analysis: Analysis, header: dict[str, str], minutes: float, quick: bool, argv: list[str]) -> str:
    a = analysis
    ours = a.ours[0]
    counts = ours["counts"]
    surface_ratios = a.our_corners.surface_means() / a.reference.surface_means()
    ratio_y = (a.our_corners.surface_means() @ LUMINANCE) / (a.reference.surface_means() @ LUMINANCE)
    preset_rows, preset_order = a.preset_rows()
    worst = int(np.argmax(np.abs(ratio_y - 1)))
    equal_time = a.fitted_seconds(a.equal_samples)
    touch_error, touch_bias = a.masked_errors(a.touching)
    rest_error, rest_bias = a.masked_errors(a.elsewhere)
    where_header = ["surface", "corners touching another surface", "ours / Cycles", "RMS / mean",
                    "other corners", "ours / Cycles", "RMS / mean", "enclosed corners", "ours there"]
    command = " ".join([COMMAND, *argv])
    pictures = a.pictures
    lines = [
        "# Our bake against Cycles: the Cornell box",
        "",
        f"Generated by `{command}` (from the repository root) in {minutes:.1f} minutes"
        + (", in **quick** mode (64 samples: to try the script, not to quote)" if quick else "")
        + ". Rerunning overwrites this file and the two pictures. Options: `--samples N` (the Cycles reference, "
        f"default {SAMPLES}), `--quick` ({QUICK_SAMPLES} samples, fewer bakes: to try the script). Every bake runs "
        "in a fresh process (the script's worker mode). The machine is shared and noisy: compare the ratios "
        "within one run, not absolute figures across runs.",
        "",
        *(f"- {key}: {value}" for key, value in header.items()),
        "",
        "## What is compared",
        "",
        f"- Scene: `sample_blends/cornell_box.blend` (built by `sample_blends/build_samples.py`): the published "
        "Cornell box, purely diffuse Principled BSDF surfaces (roughness 1, Specular IOR Level 0), the light an "
        "Emission shader of radiance (17, 12, 4), a black world. "
        f"{sum(len(ours['objects'][n]['weights']) for n in SURFACES):,} corners on the {len(SURFACES)} non-emitting "
        f"meshes; the light's mesh (`{', '.join(EMITTERS)}`) is left out of every comparison.",
        f"- Ours: `bpy.ops.radiosity.bake()` on the file as saved (scene.radiosity at its defaults: preset "
        f"{ours['settings']['preset']}, method {ours['settings']['method']}, solver {ours['settings']['solver']}, "
        f"two-sided {ours['settings']['two_sided']}), writing the FLOAT_COLOR CORNER attribute "
        f"`{ATTRIBUTE}`"
        + (f"; the core used patch size {counts['patch_size'] * 1000:.0f} mm, "
           f"{counts['rays_per_form_factor']} rays per form factor, tolerance {counts['tolerance']:g}: "
           f"{counts['triangles']:,} triangles, {counts['patches']:,} patches, {counts['nodes']:,} nodes, "
           f"{counts['shots']:,} shots, "
           f"{100 * (counts['unshot_fraction'] or 0):.2g} % of the light unshot" if counts else "")
        + f". Timed around the operator call (extraction, core, writing: \"wall\") in {len(a.ours)} separate "
        "processes; \"core\" is the core's own total from its stats. The summary line: "
        f"\"{ours['summary']}\".",
        f"- Cycles: `bpy.ops.object.bake(type='COMBINED', target='VERTEX_COLORS')` into a new FLOAT_COLOR CORNER "
        "attribute made active on each mesh, with the recipe of ../shared/CYCLES.md: CPU, "
        f"{a.samples} samples, no adaptive sampling, max_bounces = diffuse_bounces = 64, sample_clamp_direct = "
        "sample_clamp_indirect = 0, light_sampling_threshold = 0; seeds "
        f"{' and '.join(map(str, SEEDS))}; their mean is the reference. The {len(SURFACES)} meshes are selected and "
        f"baked in one call: in this run, baking them one by one (each selected alone and active) at "
        f"{a.check['samples']} samples with the same seed gave a largest difference of {a.check['max_difference']:.3g} "
        f"({a.check['seconds']['per_object']:.2f} s one by one, {a.check['seconds']['together']:.2f} s at once). "
        "Timed around the bake call, after the file is loaded.",
        "- Where the values sit: Cycles bakes each corner at one point "
        f"{CORNER_INSET:g} x max(1, |coords|) inside the corner's own face, and seeds its random numbers by the "
        "vertex index, so the corners of one vertex share their noise. Our nodes (one per vertex, material and "
        "smooth normal; faces meeting at more than the 30 degree crease angle do not share one) are evaluated "
        "1e-3 of the way from the vertex towards the centre of their faces (core/discretize.py NODE_INSET). "
        "Both are, in effect, the value at the vertex; neither is a mean over an area.",
        "- NRMSE = RMS(values - reference) / mean(reference), over every corner and R, G, B channel of the "
        "non-emitting meshes (per corner, as baked; not area weighted). Cycles' noise: RMS(seed 1 - seed 2) / "
        "sqrt(2) / mean(reference) is one seed's; the reference, a mean of two, has 1/sqrt(2) of it. Bias = the "
        "NRMSE with the reference's noise subtracted in quadrature: the error against a converged Cycles bake.",
        "",
        "## Results",
        "",
        f"- **Ours against Cycles: NRMSE {_pct(a.error)}, bias {_pct(a.bias)}** (Cycles' own noise: "
        f"{_pct(a.noise)} per seed at {a.samples} samples, {_pct(a.reference_noise)} in the two seeds' mean).",
        f"- **Time: ours {a.our_wall:.2f} s** (median wall of {len(a.ours)}; core "
        f"{statistics.median(r['core_seconds'] for r in a.ours):.2f} s), **Cycles {a.cycles_wall:.2f} s** per "
        f"{a.samples}-sample bake (mean of the seeds): Cycles takes {a.cycles_wall / a.our_wall:.1f} x as long.",
        "- Cycles' noise alone equals our bias at about "
        + (f"{a.equal_samples:,.0f} samples" if math.isfinite(a.equal_samples) else "infinitely many samples")
        + (f", which would take about {equal_time:.2f} s (a straight line fitted to this run's Cycles times)"
           if equal_time is not None else "")
        + ".",
        "",
        "### Error against time",
        "",
        _table(["bake", "wall s", "CPU s / wall s", "NRMSE vs the reference", "bias (reference noise removed)",
                "own noise"], a.error_rows()),
        "",
        f"\"own noise\" for the lower sample counts is the {a.samples}-sample noise scaled by "
        "sqrt(samples ratio): the bias column of a Cycles row should be near 0, which checks the noise estimate.",
        "",
        "### Per surface",
        "",
        "Area-weighted mean colour (linear RGB) of each surface; ± is the standard error of the reference's "
        "mean (|seed 1 - seed 2| / 2, per channel); the ratio is ours / Cycles; NRMSE and bias are per corner, "
        "as above, on the surface alone.",
        "",
        _table(["surface", "ours R, G, B", "Cycles R, G, B", "±", "ratio R, G, B", "NRMSE", "bias"],
               a.surface_rows()),
        "",
        "The same ratio for luminance (Rec. 709 weights), at each of our presets measured; ± as above, relative:",
        "",
        _table(["surface", *(f"ours / Cycles, {name}" for name in preset_order), "±"], preset_rows),
        "",
        "### Where the error is",
        "",
        f"Corners whose vertex lies within {TOUCH * 1000:g} mm of another non-emitting surface (the room's edges "
        "and corners, the blocks' bottom edges standing on the floor), the corners Cycles bakes exactly black "
        "(their point is enclosed: floor under the blocks), and the others. Ratio: mean luminance ours / Cycles "
        "over the corners; RMS / mean: RMS(ours - Cycles) over them relative to the Cycles mean over them; ours "
        "there: our mean luminance where Cycles has 0.",
        "",
        f"- **{100 * a.squared_share(a.touching):.0f} % of our squared error is on the {a.touching.sum()} of "
        f"{len(a.touching)} corners where two surfaces meet** (NRMSE {_pct(touch_error)}, bias {_pct(touch_bias)}, "
        f"relative to the mean of every corner); {100 * a.squared_share(a.enclosed):.1f} % on the "
        f"{a.enclosed.sum()} enclosed corners; on the {a.elsewhere.sum()} others, NRMSE {_pct(rest_error)}, "
        f"bias {_pct(rest_bias)}.",
        "",
        _table(where_header, a.where_rows()),
        "",
        "### What the difference does not come from",
        "",
        "Bakes of a changed scene or core, each against its unchanged twin of this run (ours: the first PREVIEW "
        f"run; Cycles: seed {SEEDS[0]}, so the same random numbers): NRMSE against the reference, the largest "
        "corner difference to the twin, and the surfaces' luminance ratios to the reference. "
        f"The node inset is set in the worker process (`core.discretize.NODE_INSET`, 1e-3 in the code).",
        "",
        _table(["bake", "changed", "NRMSE vs the reference", "largest difference to the twin",
                *(f"`{name}`" for name in SURFACES)], a.variant_rows()),
        "",
        *(f"- {sentence}." for sentence in a.variant_sentences()),
        "",
        "### Speed",
        "",
        _table(["bake", "wall s per run", "wall s", "core s per run", "CPU s / wall s", "threads", "core stages s"],
               a.speed_rows()),
        "",
        "## Pictures",
        "",
        f"Both {pictures['render']['resolution'][0]} x {pictures['render']['resolution'][1]}, from the scene's "
        f"camera, in the scene's colour management (view {pictures['render']['view']}, look "
        f"{pictures['render']['look']}, exposure {pictures['render']['exposure']:g}). Left: our baked colours, "
        "rendered by `radiosity_addon.preview.render_colours` (every surface an emitter of its colour attribute, "
        "interpolated across faces, no lighting). Right: a normal Cycles render, "
        f"{PICTURE_SAMPLES} samples, no denoising ({pictures['render']['wall']:.1f} s).",
        "",
        "| ours (baked vertex colours) | Cycles render |",
        "|---|---|",
        f"| ![ours]({OUR_PICTURE.name}) | ![Cycles]({CYCLES_PICTURE.name}) |",
        "",
        "## Reading",
        "",
        f"- Ours is within {_pct(a.bias)} (RMS over corners, relative to the mean) of a converged Cycles vertex "
        f"bake, in {a.our_wall:.2f} s against {a.cycles_wall:.2f} s for {a.samples} Cycles samples. A Cycles bake "
        "with as little error would need about "
        + (f"{a.equal_samples:,.0f} samples" if math.isfinite(a.equal_samples) else "any number of samples")
        + (f" ({equal_time:.2f} s)" if equal_time is not None else "")
        + ", but its error is noise (grain from vertex to vertex), ours is smooth and systematic: at equal "
        "NRMSE the two do not look alike.",
        f"- Per surface, the luminance ratio ours / Cycles runs from {ratio_y.min():.3f} to {ratio_y.max():.3f}; "
        f"the furthest from 1 is `{SURFACES[worst]}` ({ratio_y[worst]:.3f}; R, G, B "
        f"{_rgb(surface_ratios[worst], 3)}).",
        f"- The difference is at the edges: {100 * a.squared_share(a.touching):.0f} % of our squared error sits on "
        f"the {100 * a.touching.mean():.0f} % of corners where two surfaces meet; elsewhere our bias is "
        f"{_pct(rest_bias)}. It is not Cycles' Principled BSDF, the light's back or where our nodes sit (see "
        "\"What the difference does not come from\")." + a.refinement_sentence() + " Our reading: it is our "
        "discretisation. Each patch has one radiosity, and a vertex on an edge gathers much of its light from "
        "the patch just across the edge, whose one value is not the value at the edge.",
        *FINDINGS,
        "",
    ]
    return "\n".join(lines)


# Findings of experiments this script does not repeat (they take minutes or edit the scene's meshes);
# plain text, with how and when they were measured, so a rerun does not pretend to have checked them.
FINDINGS: list[str] = [
    "- Measured by hand on 2026-11-22 (not repeated by this script: the finer meshes take minutes to bake), "
    "PREVIEW against the same kind of 1024-sample Cycles reference, as mean luminance ratios ours / Cycles "
    "over the corners named. (1) At the ceiling's edges ours is too bright because the top of each wall is "
    "darker than the mean of its patch (the light grazes it): with the three walls' grids cut 4 x finer (17 mm "
    "cells, the ceiling's mesh unchanged; a 400 s bake), the 46 ceiling corners on the walls went from 1.221 to "
    "1.075 (luminance RMS 26 % to 10 %) and the whole ceiling from 1.026 to 1.009; the REFERENCE preset (60 mm "
    "patches) gives 1.114. (2) At the blocks' bottom edges the floor is not cut along the blocks' footprints, "
    "so floor patches straddle the contact line, partly under the block: a block-bottom corner's ratio "
    "correlated with the covered share of the floor cell in front of it (r = -0.53; about 0.33 at 91 % "
    "covered, near 1 below 50 %), and cutting the floor 4 x finer did not cure it (short block bottom 0.831 to "
    "0.843, luminance RMS 54 % to 29 %; tall block 0.887 to 0.784, 33 % to 40 %): the patches along the "
    "contact line still straddle it. The same straddling patches let light under the blocks (the enclosed "
    "corners above), which the blocks' two-sided inner faces reflect back. Remedies belong to the core or the "
    "scene: patches cut along contact lines (discontinuity meshing), or a floor with the footprints cut out.",
]


def _load(moment: str) -> dict[str, str]:
    """The load average and the cores free, at ``moment`` ("start" or "end")."""
    return {
        f"load average (1, 5, 15 min) at the {moment}": machine.load_average(),
        f"cores free at the {moment} (CPU-bound probe, see bench/machine.py)": f"{machine.free_cores():.1f}",
    }


def main(argv: list[str]) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--samples", type=int, help=f"Cycles reference samples (default {SAMPLES}; {QUICK_SAMPLES} "
                        "with --quick)")
    parser.add_argument("--quick", action="store_true", help=f"{QUICK_SAMPLES} samples and fewer low-sample bakes")
    parser.add_argument("--worker", help=argparse.SUPPRESS)
    parser.add_argument("--result", help=argparse.SUPPRESS)
    options = parser.parse_args(argv)
    if options.worker is not None:
        worker(json.loads(options.worker), options.result)
        return 0
    samples = options.samples or (QUICK_SAMPLES if options.quick else SAMPLES)
    if samples < 1:
        parser.error(f"--samples must be a positive number, got {samples}")
    low_counts = [n for n in (QUICK_LOW_SAMPLES if options.quick else LOW_SAMPLES) if n < samples]

    start = time.perf_counter()
    header = machine.machine() | {"core/*.py SHA-1": machine.core_digest()} | _load("start")
    print(", ".join(f"{k}: {v}" for k, v in header.items()), flush=True)
    cases: list[tuple[str, dict]] = [("check", {"kind": "check", "samples": CHECK_SAMPLES, "seed": SEEDS[0]})]
    # ours and the Cycles references alternate, so both see the machine's load of the same minutes
    ours = [(f"ours {k + 1}", {"kind": "ours", "render": str(OUR_PICTURE) if k == 0 else None})
            for k in range(OUR_RUNS)]
    references = [(f"cycles {samples} seed {seed}", {"kind": "cycles", "samples": samples, "seed": seed})
                  for seed in SEEDS]
    for k in range(max(len(ours), len(references))):
        cases += ours[k:k + 1] + references[k:k + 1]
    other_presets = QUICK_OTHER_PRESETS if options.quick else OTHER_PRESETS
    cases += [(f"ours {name}", {"kind": "ours", "preset": name}) for name in other_presets]
    variants = {"ours one-sided": ("ours", "two-sided surfaces off", {"kind": "ours", "two_sided": False})}
    variants |= {f"ours inset {inset:g}": ("ours", f"nodes {inset:g} of the way to their faces' centre",
                                           {"kind": "ours", "node_inset": inset}) for inset in NODE_INSETS}
    variants |= {f"cycles {name}": ("cycles", change, {"kind": "cycles", "samples": samples, "seed": SEEDS[0],
                                                      "variant": name})
                 for name, (change, _apply) in VARIANTS.items()}
    cases += [(label, case) for label, (_kind, _change, case) in variants.items()]
    cases += [(f"cycles {n}", {"kind": "cycles", "samples": n, "seed": LOW_SEED}) for n in low_counts]
    cases += [("render", {"kind": "render", "samples": PICTURE_SAMPLES, "path": str(CYCLES_PICTURE)})]
    OUR_PICTURE.parent.mkdir(parents=True, exist_ok=True)
    results = {}
    for number, (label, case) in enumerate(cases, 1):
        print(f"[{number}/{len(cases)}] {label} ...", end=" ", flush=True)
        results[label] = run_case(case) | {"samples": case.get("samples")}
        timing = results[label].get("wall", results[label].get("seconds"))
        print(f"{timing} ; {time.perf_counter() - start:.0f} s so far", flush=True)
    header |= _load("end")
    header["bpy"] = results["ours 1"]["bpy"]
    for path in (OUR_PICTURE, CYCLES_PICTURE):
        size = path.stat().st_size
        if size > PICTURE_LIMIT:
            print(f"warning: {path.name} is {size / 1000:.0f} kB, above {PICTURE_LIMIT / 1000:.0f} kB", file=sys.stderr)
    analysis = Analysis(
        samples=samples,
        ours=[results[f"ours {k + 1}"] for k in range(OUR_RUNS)],
        seeds=[results[f"cycles {samples} seed {seed}"] for seed in SEEDS],
        low=[results[f"cycles {n}"] for n in low_counts],
        check=results["check"] | {"samples": CHECK_SAMPLES},
        pictures={"render": results["render"]},
        presets={name: results[f"ours {name}"] for name in other_presets},
        variants={label: (kind, change, results[label]) for label, (kind, change, _case) in variants.items()},
    )
    text = markdown(analysis, header, (time.perf_counter() - start) / 60, options.quick, argv)
    OUTPUT.write_text(text)
    print()
    print(text)
    print(f"wrote {OUTPUT}, {OUR_PICTURE.name} ({OUR_PICTURE.stat().st_size / 1000:.0f} kB), "
          f"{CYCLES_PICTURE.name} ({CYCLES_PICTURE.stat().st_size / 1000:.0f} kB)")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
