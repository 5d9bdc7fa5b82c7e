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

import numpy as np

import machine  # bench/ is the script's directory, so its modules import by name

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
            "objects": _read_corners(bpy, ATTRIBUTE)}


def _case_cycles(bpy, _package, case: dict) -> dict:
    """A Cycles COMBINED vertex bake of every non-emitting mesh at once (the check case shows it
    equals baking them one by one), timed around ``bpy.ops.object.bake``."""
    _cycles_settings(bpy.context.scene, case["samples"], case["seed"])
    meshes = _baked_meshes(bpy)
    _add_attribute(meshes, CYCLES_ATTRIBUTE)
    _select(bpy, meshes)
    wall, cpu = time.perf_counter(), _cpu_seconds()
    bpy.ops.object.bake(type="COMBINED", target="VERTEX_COLORS")
    wall, cpu = time.perf_counter() - wall, _cpu_seconds() - cpu
    return {"wall": wall, "cpu": cpu, "objects": _read_corners(bpy, CYCLES_ATTRIBUTE)}


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


def _read_corners(bpy, attribute: str) -> dict:
    """{object: {"colours": (n, 3) list, "weights": (n,) list}} over the non-emitting meshes, per
    loop (corner): the colour attribute's RGB and the corner's share of its polygon's area."""
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
    return out


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
            cwd=REPO, capture_output=True, text=True,
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
        for seed, result in zip(SEEDS, self.seeds):
            rows.append([f"Cycles, {self.samples} samples, seed {seed}", f"{result['wall']:.2f}", f"{result['wall']:.2f}",
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
        for seed, result in zip(SEEDS, self.seeds):
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
                         _rgb(ours[k] / reference[k], 3), _pct(error), _pct(without_noise(error, noise / math.sqrt(2)))])
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
    command = " ".join([COMMAND, *argv])
    pictures = a.pictures
    lines = [
        "# Our bake against Cycles: the Cornell box",
        "",
        f"Generated by `{command}` (from the repository root) in {minutes:.1f} minutes"
        + (", in **quick** mode (64 samples: to try the script, not to quote)" if quick else "")
        + ". Rerunning overwrites this file and the two pictures. The machine is shared and noisy: compare the "
        "ratios within one run, not absolute figures across runs.",
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
        + (f"; the core used patch size {counts['patch_size'] * 1000:.0f} mm, {counts['rays_per_form_factor']} rays per "
           f"form factor, tolerance {counts['tolerance']:g}: {counts['triangles']:,} triangles, {counts['patches']:,} "
           f"patches, {counts['nodes']:,} nodes, {counts['shots']:,} shots, "
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
        *FINDINGS,
        "",
    ]
    return "\n".join(lines)


# Findings of investigations outside this script's run (see the report of the task that wrote it);
# kept as plain text, with how they were measured, so a rerun does not silently change them.
FINDINGS: list[str] = []


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
    cases += [(f"ours {k + 1}", {"kind": "ours", "render": str(OUR_PICTURE) if k == 0 else None})
              for k in range(OUR_RUNS)]
    other_presets = QUICK_OTHER_PRESETS if options.quick else OTHER_PRESETS
    cases += [(f"ours {name}", {"kind": "ours", "preset": name}) for name in other_presets]
    cases += [(f"cycles {samples} seed {seed}", {"kind": "cycles", "samples": samples, "seed": seed}) for seed in SEEDS]
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
