"""Our bakes of sample_blends/cornell_box.blend against Cycles' COMBINED vertex bake of the same file,
in one run: the headline (error against time for our presets, methods x solvers and Cycles at
increasing samples, against our converged reference, cross-checked with Cycles: bench/cycles_headline.py)
and a closer look at the default bake against Cycles' highest-sample bake (per surface, where the
error is, what it does not come from). Writes docs/cycles.md, docs/headline.png and two pictures for
the README (docs/cornell_box_radiosity.png, docs/cornell_box_cycles.png), and prints the report.

Run from the repository root: ``.venv/bin/python bench/cycles.py [--samples 16384] [--quick]``
(``--quick``: a few minutes, to try the script, written into build/cycles-quick/; its numbers are
not to quote). Every run saves its raw results in build/; ``--from-results FILE`` writes the report
and plot again from them without baking. Every measurement runs in a process of its own
(bench/cycles_worker.py; bpy can be imported once per process). The
Cycles bake follows ../shared/CYCLES.md (CPU, no adaptive sampling, no clamping, light threshold 0,
64 bounces, a FLOAT_COLOR CORNER attribute made active, COMBINED into VERTEX_COLORS). The machine is
shared and noisy: compare the ratios of one run, not absolute figures across runs.
"""

from __future__ import annotations

import argparse
import json
import math
import statistics
import sys
import time
from dataclasses import dataclass
from itertools import zip_longest
from pathlib import Path

import cycles_headline as headline  # bench/ is the script's directory, so its modules import by name
import machine
import numpy as np
from cycles_metrics import LUMINANCE, TOUCH, Corners, nrmse, pct, rgb, seed_noise, table, touching, without_noise
from cycles_worker import ATTRIBUTE, EMITTERS, REPO, SURFACES, VARIANTS, run_case

sys.path.insert(0, str(REPO))
from core.mesh.discretize import NODE_INSET  # noqa: E402

# What a run writes, in docs/ (in build/cycles-quick/ with --quick, so trying the script leaves the
# committed files alone), and the raw results, in build/ (read back by --from-results).
DOCS, QUICK_DOCS = REPO / "docs", REPO / "build" / "cycles-quick"
REPORT, HEADLINE_PICTURE = "cycles.md", "headline.png"
OUR_PICTURE, CYCLES_PICTURE = "cornell_box_radiosity.png", "cornell_box_cycles.png"
RESULTS, QUICK_RESULTS = REPO / "build" / "cycles_results.json", QUICK_DOCS / "cycles_results.json"
COMMAND = ".venv/bin/python bench/cycles.py"

SAMPLES = 16384  # Cycles' highest samples per corner: the cross-check and the closer look
QUICK_SAMPLES = 256
FIRST_SAMPLES = 16  # Cycles' samples run from this up to SAMPLES, x 4 at each step
SEEDS = (1, 2)  # scene.cycles.seed: two bakes at every sample count, for their noise
VARIANT_SAMPLES = 1024  # Cycles bakes of a changed scene (and their unchanged twin) take this many
QUICK_VARIANT_SAMPLES = 64
CHECK_SAMPLES = 16  # per-object and all-at-once bakes compared at this many samples
PICTURE_SAMPLES = 256  # the Cycles render for the README
QUICK_PICTURE_SAMPLES = 16
PICTURE_LIMIT = 300_000  # bytes per PNG
NODE_INSETS = (NODE_INSET / 10, NODE_INSET * 10)  # our node placement, moved either way from core's
CORNER_INSET = 1e-4  # Cycles bakes a corner this x max(1, |coords|) inside its face (CYCLES.md)


# --------------------------------------------------------------------------------------------------
# The closer look: the default bake against Cycles' highest-sample bakes
# --------------------------------------------------------------------------------------------------


@dataclass
class Analysis:
    """What the closer look says, computed from the cases' results. "The reference" here is the
    mean of Cycles' two highest-sample seeds."""

    samples: int
    ours: list[dict]  # the default bake's runs; the first has the geometry
    seeds: list[dict]  # Cycles at ``samples``, one per seed
    check: dict
    pictures: dict
    presets: dict  # preset name -> the result of one bake of ours at that preset
    variants: dict  # label -> (kind "ours" or "cycles", what changed, the result)
    twin: dict  # the Cycles bake the Cycles variants are compared with (same samples and seed)

    def __post_init__(self) -> None:
        first, second = (Corners.of(r) for r in self.seeds)
        self.reference = Corners(0.5 * (first.colours + second.colours), first.weights, first.surface)
        self.our_corners = Corners.of(self.ours[0])
        self.noise = seed_noise(first.colours, second.colours, float(np.mean(self.reference.colours)))
        self.reference_noise = self.noise / math.sqrt(2)
        self.error = nrmse(self.our_corners.colours, self.reference.colours)
        self.bias = without_noise(self.error, self.reference_noise)
        self.seed_means = (first.surface_means(), second.surface_means())
        self.our_wall = statistics.median(r["wall"] for r in self.ours)
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
        return error, without_noise(error, seed_noise(first, second, scale) / math.sqrt(2))

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
                          pct(rms / self.reference.colours[group].mean())]
            group = (self.our_corners.surface == k) & self.enclosed
            cells += [f"{group.sum()}", f"{ours[group].mean():.4f}" if group.any() else ""]
            rows.append(cells)
        return rows

    def variant_ratios(self, result: dict) -> np.ndarray:
        """(S,) luminance ratio of a bake's surface means to the reference's."""
        return Corners.of(result).surface_means() @ LUMINANCE / (self.reference.surface_means() @ LUMINANCE)

    def _baselines(self) -> dict[str, tuple[str, dict]]:
        """The unchanged twin of each kind of variant, and what the table calls it."""
        return {"ours": (f"ours, preset {self.ours[0]['settings']['preset']}", self.ours[0]),
                "cycles": (f"Cycles, {self.twin['samples']} samples, seed {SEEDS[0]}", self.twin)}

    def variant_rows(self) -> list[list[str]]:
        """Each changed bake against its unchanged twin (ours: run 1; Cycles: the same samples and seed)."""
        rows = []
        for kind, (label, result) in self._baselines().items():
            rows.append([label, "(as measured above)", pct(nrmse(Corners.of(result).colours, self.reference.colours)),
                         "", *(f"{r:.3f}" for r in self.variant_ratios(result))])
            for variant_kind, change, changed in self.variants.values():
                if variant_kind != kind:
                    continue
                difference = np.abs(Corners.of(changed).colours - Corners.of(result).colours).max()
                rows.append(["", change, pct(nrmse(Corners.of(changed).colours, self.reference.colours)),
                             "0 (identical)" if difference == 0 else f"{difference:.3g}",
                             *(f"{r:.3f}" for r in self.variant_ratios(changed))])
        return rows

    def variant_sentences(self) -> list[str]:
        """What the changed bakes say about where the difference comes from."""
        sentences = []
        base = {kind: result for kind, (_label, result) in self._baselines().items()}
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

    def speed_rows(self) -> list[list[str]]:
        ours = self.ours[0]
        stage_text = ", ".join(f"{k} {v:.2f}" for k, v in ours["stages"].items())
        rows = [[f"ours, preset {ours['settings']['preset']}", ", ".join(f"{r['wall']:.2f}" for r in self.ours),
                 f"{self.our_wall:.2f}",
                 ", ".join(f"{r['core_seconds']:.2f}" for r in self.ours),
                 f"{statistics.median(r['cpu'] / r['wall'] for r in self.ours):.2f}",
                 f"{ours['threads_core']} (core.util.parallel)", stage_text or "n/a"]]
        for seed, result in zip(SEEDS, self.seeds, strict=True):
            rows.append([f"Cycles, {self.samples} samples, seed {seed}", f"{result['wall']:.2f}",
                         f"{result['wall']:.2f}",
                         "", f"{result['cpu'] / result['wall']:.2f}", f"{result['threads']} (render.threads)", ""])
        return rows

    def surface_rows(self) -> list[list[str]]:
        ours, reference = self.our_corners.surface_means(), self.reference.surface_means()
        spread = np.abs(self.seed_means[0] - self.seed_means[1]) / 2  # standard error of the two seeds' mean
        rows = []
        for k, name in enumerate(SURFACES):
            mask = self.our_corners.surface == k
            error = nrmse(self.our_corners.colours[mask], self.reference.colours[mask])
            first, second = (colours[mask] for colours in self.seed_colours)
            noise = seed_noise(first, second, float(np.mean(self.reference.colours[mask])))
            rows.append([f"`{name}`", rgb(ours[k]), rgb(reference[k]), rgb(spread[k], 4),
                         rgb(ours[k] / reference[k], 3), pct(error),
                         pct(without_noise(error, noise / math.sqrt(2)))])
        return rows

    def preset_rows(self) -> tuple[list[list[str]], list[str]]:
        """Per surface, the luminance ratio ours / Cycles at every preset measured; the presets' order."""
        reference = self.reference.surface_means() @ LUMINANCE
        bakes = {self.ours[0]["settings"]["preset"]: self.ours[0]} | self.presets
        ratios = {name: Corners.of(result).surface_means() @ LUMINANCE / reference for name, result in bakes.items()}
        spread = np.abs(self.seed_means[0] - self.seed_means[1]) @ LUMINANCE / 2 / reference
        order = [name for name in headline.PRESETS if name in ratios]
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
                + f") moves the NRMSE from {pct(self.error)} to {pct(error)}.")


# --------------------------------------------------------------------------------------------------
# The report
# --------------------------------------------------------------------------------------------------


def markdown(a: Analysis, top: headline.Headline, header: dict[str, str], minutes: float, quick: bool,
             argv: list[str]) -> str:
    """docs/cycles.md."""
    sections = [_introduction(header, minutes, quick, argv), headline.markdown(top, HEADLINE_PICTURE),
                _compared(a), _results(a), _surfaces(a), _where(a), _variants(a), _speed(a), _pictures(a),
                _reading(a)]
    return "\n".join(line for section in sections for line in [*section, ""])


def _introduction(header: dict[str, str], minutes: float, quick: bool, argv: list[str]) -> list[str]:
    return [
        "# Our bake against Cycles: the Cornell box",
        "",
        f"Generated by `{' '.join([COMMAND, *argv])}` (from the repository root) in {minutes:.1f} minutes"
        + (", in **quick** mode (few samples, a cheap stand-in for the converged reference: to try the script, "
           "not to quote)" if quick else "")
        + ". Rerunning overwrites this file, the headline plot and the two pictures. Options: `--samples N` "
        f"(Cycles' highest sample count, default {SAMPLES}: the bakes go from {FIRST_SAMPLES} samples up to it, x 4 "
        f"at each step, two seeds each), `--quick` (up to {QUICK_SAMPLES} samples, fewer and cheaper bakes: a few "
        f"minutes; writes into {QUICK_DOCS.relative_to(REPO)}/ instead), `--from-results JSON` (the report and "
        f"plot again, without baking, from the raw results every run saves: {RESULTS.relative_to(REPO)}). Every "
        "bake runs in a fresh process (bench/cycles_worker.py) and is timed around the bake call alone (Blender's "
        "start-up and the file load excluded). The machine is shared and noisy: compare within one run, not "
        "absolute figures across runs.",
        "",
        *(f"- {key}: {value}" for key, value in header.items()),
    ]


def _compared(a: Analysis) -> list[str]:
    ours = a.ours[0]
    counts = ours["counts"]
    return [
        "## The closer look: what is compared",
        "",
        "The rest of this file compares our default bake with the mean of Cycles' two "
        f"{a.samples}-sample seeds (\"the reference\" from here on), corner by corner.",
        "",
        "- Scene: `sample_blends/cornell_box.blend` (built by `sample_blends/build_samples.py`): the published "
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
        "- Cycles: `bpy.ops.object.bake(type='COMBINED', target='VERTEX_COLORS')` into a new FLOAT_COLOR CORNER "
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
        "shading normal: the mesh's corner normals, so a flat-shaded face's corners have its own) are evaluated "
        f"{NODE_INSET:g} of the scene's extent from the vertex towards the centre of their faces, at most half "
        "the way (core/discretize.py NODE_INSET). "
        "Both are, in effect, the value at the vertex; neither is a mean over an area.",
        "- NRMSE = RMS(values - reference) / mean(reference), over every corner and R, G, B channel of the "
        "non-emitting meshes (per corner, as baked; not area weighted). Cycles' noise: RMS(seed 1 - seed 2) / "
        "sqrt(2) / mean(reference) is one seed's; the reference, a mean of two, has 1/sqrt(2) of it. Bias = the "
        "NRMSE with the reference's noise subtracted in quadrature: the error against a converged Cycles bake.",
    ]


def _results(a: Analysis) -> list[str]:
    return [
        "### Result",
        "",
        f"- **Our default bake against Cycles: NRMSE {pct(a.error)}, bias {pct(a.bias)}** (Cycles' own noise: "
        f"{pct(a.noise)} per seed at {a.samples} samples, {pct(a.reference_noise)} in the two seeds' mean).",
        f"- Time: ours {a.our_wall:.2f} s (median wall of {len(a.ours)}; core "
        f"{statistics.median(r['core_seconds'] for r in a.ours):.2f} s), Cycles "
        f"{statistics.mean(r['wall'] for r in a.seeds):.2f} s per {a.samples}-sample bake (mean of the seeds).",
    ]


def _surfaces(a: Analysis) -> list[str]:
    preset_rows, preset_order = a.preset_rows()
    return [
        "### Per surface",
        "",
        "Area-weighted mean colour (linear RGB) of each surface; ± is the standard error of the reference's "
        "mean (|seed 1 - seed 2| / 2, per channel); the ratio is ours / Cycles; NRMSE and bias are per corner, "
        "as above, on the surface alone.",
        "",
        table(["surface", "ours R, G, B", "Cycles R, G, B", "±", "ratio R, G, B", "NRMSE", "bias"], a.surface_rows()),
        "",
        "The same ratio for luminance (Rec. 709 weights), at each of our presets measured; ± as above, relative:",
        "",
        table(["surface", *(f"ours / Cycles, {name}" for name in preset_order), "±"], preset_rows),
    ]


def _where(a: Analysis) -> list[str]:
    touch_error, touch_bias = a.masked_errors(a.touching)
    rest_error, rest_bias = a.masked_errors(a.elsewhere)
    header = ["surface", "corners touching another surface", "ours / Cycles", "RMS / mean",
              "other corners", "ours / Cycles", "RMS / mean", "enclosed corners", "ours there"]
    return [
        "### Where the error is",
        "",
        f"Corners whose vertex lies within {TOUCH * 1000:g} mm of another non-emitting surface (the room's edges "
        "and corners, the blocks' bottom edges standing on the floor), the corners Cycles bakes exactly black "
        "(their point is enclosed: floor under the blocks), and the others. Ratio: mean luminance ours / Cycles "
        "over the corners; RMS / mean: RMS(ours - Cycles) over them relative to the Cycles mean over them; ours "
        "there: our mean luminance where Cycles has 0.",
        "",
        f"- **{100 * a.squared_share(a.touching):.0f} % of our squared error is on the {a.touching.sum()} of "
        f"{len(a.touching)} corners where two surfaces meet** (NRMSE {pct(touch_error)}, bias {pct(touch_bias)}, "
        f"relative to the mean of every corner); {100 * a.squared_share(a.enclosed):.1f} % on the "
        f"{a.enclosed.sum()} enclosed corners; on the {a.elsewhere.sum()} others, NRMSE {pct(rest_error)}, "
        f"bias {pct(rest_bias)}.",
        "",
        table(header, a.where_rows()),
    ]


def _variants(a: Analysis) -> list[str]:
    return [
        "### What the difference does not come from",
        "",
        "Bakes of a changed scene or core, each against its unchanged twin of this run (ours: the first "
        f"{a.ours[0]['settings']['preset']} run; Cycles: {a.twin['samples']} samples, seed {SEEDS[0]}, so the same "
        "random numbers): NRMSE against the reference, the largest corner difference to the twin, and the surfaces' "
        "luminance ratios to the reference. The node inset is set in the worker process "
        f"(`core.mesh.discretize.NODE_INSET`, {NODE_INSET:g} of the extent in the code).",
        "",
        table(["bake", "changed", "NRMSE vs the reference", "largest difference to the twin",
               *(f"`{name}`" for name in SURFACES)], a.variant_rows()),
        "",
        *(f"- {sentence}." for sentence in a.variant_sentences()),
    ]


def _speed(a: Analysis) -> list[str]:
    return [
        "### Speed",
        "",
        table(["bake", "wall s per run", "wall s", "core s per run", "CPU s / wall s", "threads", "core stages s"],
              a.speed_rows()),
    ]


def _pictures(a: Analysis) -> list[str]:
    render = a.pictures["render"]
    return [
        "## Pictures",
        "",
        f"Both {render['resolution'][0]} x {render['resolution'][1]}, from the scene's camera, in the scene's "
        f"colour management (view {render['view']}, look {render['look']}, exposure {render['exposure']:g}). Left: "
        "our baked colours, rendered by `radiosity_addon.preview.render_colours` (every surface an emitter of its "
        "colour attribute, interpolated across faces, no lighting). Right: a normal Cycles render, "
        f"{render['samples']} samples, no denoising ({render['wall']:.1f} s).",
        "",
        "| ours (baked vertex colours) | Cycles render |",
        "|---|---|",
        f"| ![ours]({OUR_PICTURE}) | ![Cycles]({CYCLES_PICTURE}) |",
    ]


def _reading(a: Analysis) -> list[str]:
    ratios = a.our_corners.surface_means() / a.reference.surface_means()
    luminance = (a.our_corners.surface_means() @ LUMINANCE) / (a.reference.surface_means() @ LUMINANCE)
    worst = int(np.argmax(np.abs(luminance - 1)))
    _rest_error, rest_bias = a.masked_errors(a.elsewhere)
    return [
        "## Reading",
        "",
        f"- Per surface, the luminance ratio ours / Cycles runs from {luminance.min():.3f} to {luminance.max():.3f}; "
        f"the furthest from 1 is `{SURFACES[worst]}` ({luminance[worst]:.3f}; R, G, B {rgb(ratios[worst], 3)}).",
        f"- Where the difference sits: {100 * a.squared_share(a.touching):.0f} % of our squared error is on "
        f"the {100 * a.touching.mean():.0f} % of corners where two surfaces meet; elsewhere our bias is "
        f"{pct(rest_bias)}. It is not Cycles' Principled BSDF, the light's back or where our nodes sit (see "
        "\"What the difference does not come from\")." + a.refinement_sentence() + " Our reading: what is left "
        "is our discretisation. A vertex on an edge gathers much of its light from the patch just across it; "
        "the near field reads that patch as linear between its corner colours at the point the vertex looks at, "
        "and the direct light there exactly where a shadow starts at the vertex (core/touching.py, "
        "docs/methods.md), but the indirect light next to a contact line is not linear either.",
        "- Ours is smooth and systematic where Cycles' error is noise (grain from vertex to vertex): at equal "
        "NRMSE the two do not look alike.",
        *FINDINGS,
    ]


# Findings of experiments this script does not repeat (they take minutes or edit the scene's meshes);
# plain text, with how and when they were measured, so a rerun does not pretend to have checked them.
FINDINGS: list[str] = [
    "- Before the near field and the contact cuts (core of commit b1b9a2c; the previous run of this script, "
    "2026-11-22): the default bake was 5.90 % from Cycles' converged answer, 96 % of its squared error on the "
    "corners where two surfaces meet: the ceiling's corners on the walls 1.22 x too bright (the top of each "
    "wall, grazed by the light, is darker than its patch's mean) and the blocks' bottom corners 0.83 x too dark "
    "(the floor's patches straddled the blocks' footprints). Measured with bench/cycles_rescore.py on that run's "
    "Cycles answer: the contact cuts alone took the default bake to 4.1 %, with the near field to 0.86 % (every "
    "ray cast; probe rays, the default since, add about 0.1 %).",
    "- Before the touching patches were read at the right place (core/touching.py; core of commit d002675, the "
    "previous run of this script, 2026-11-22): the default bake was 0.77 % from Cycles' converged answer (1.04 s) "
    "and our converged reference 0.56 % (1.3 x Cycles' noise), 51 % of the default's squared error on the "
    "corners where two surfaces meet (1.47 % there); the blocks' bottom corners were up to 35 % off (the "
    "short block's 16 touching corners 4.1 % RMS for the reference). A brute-force final gather at the worst "
    "corners (one more bounce, gathered exactly at each ray's hit point) came within 2-4 % of Cycles there, "
    "which located the error in the floor's light right at the blocks' feet.",
    "- The core's own error estimate (last column of the first table): since the core of commit 2812e32 ray-cast "
    "bakes estimate the discretisation from how far the patches next to each vertex are from linear "
    "(core/nearfield.py, reading_error); the previous run reported 27 % for the default bake's 1.0 %.",
]


# --------------------------------------------------------------------------------------------------
# The run
# --------------------------------------------------------------------------------------------------


def ladder(top: int) -> tuple[int, ...]:
    """Cycles' sample counts: FIRST_SAMPLES x 4^k below ``top``, then ``top``."""
    counts = [FIRST_SAMPLES]
    while counts[-1] * 4 < top:
        counts.append(counts[-1] * 4)
    return tuple(n for n in counts if n < top) + (top,)


def variants(variant_samples: int) -> dict[str, tuple[str, str, dict]]:
    """Bakes of a changed scene or core: label -> (kind, what changed, the case)."""
    out = {"ours one-sided": ("ours", "two-sided surfaces off", {"kind": "ours", "settings": {"two_sided": False}})}
    out |= {f"ours inset {inset:g}": ("ours", f"nodes {inset:g} of the way to their faces' centre",
                                      {"kind": "ours", "node_inset": inset}) for inset in NODE_INSETS}
    out |= {f"cycles {name}": ("cycles", change, {"kind": "cycles", "samples": variant_samples, "seed": SEEDS[0],
                                                  "variant": name})
            for name, (change, _apply) in VARIANTS.items()}
    return out


def cases(counts: tuple[int, ...], quick: bool, picture_samples: int, variant_samples: int,
          changed: dict[str, tuple[str, str, dict]], docs: Path) -> list[tuple[str, dict]]:
    """Every case of a run, labelled, in the order they run: ours and Cycles' alternate, so both
    see the machine's load of the same minutes. The pictures go to ``docs``."""
    ours = headline.our_cases(quick, str(docs / OUR_PICTURE))
    cycles = [(headline.cycles_label(n, seed), {"kind": "cycles", "samples": n, "seed": seed})
              for n in counts for seed in SEEDS]
    if variant_samples not in counts:
        cycles.append((headline.cycles_label(variant_samples, SEEDS[0]),
                       {"kind": "cycles", "samples": variant_samples, "seed": SEEDS[0]}))
    mixed = [case for pair in zip_longest(ours, cycles) for case in pair if case is not None]
    return [("check", {"kind": "check", "samples": CHECK_SAMPLES, "seed": SEEDS[0]}), *mixed,
            *((label, case) for label, (_kind, _change, case) in changed.items()),
            ("render", {"kind": "render", "samples": picture_samples, "path": str(docs / CYCLES_PICTURE)})]


def run(labelled: list[tuple[str, dict]], start: float) -> dict[str, dict]:
    """Each case's result (with the case's samples and settings), printing progress."""
    results = {}
    for number, (label, case) in enumerate(labelled, 1):
        print(f"[{number}/{len(labelled)}] {label} ...", end=" ", flush=True)
        results[label] = run_case(case) | {"samples": case.get("samples"), "case_settings": case.get("settings", {})}
        timing = results[label].get("wall", results[label].get("seconds"))
        print(f"{timing} ; {time.perf_counter() - start:.0f} s so far", flush=True)
    return results


def driver_parser(doc: str, samples: int, quick_samples: int) -> argparse.ArgumentParser:
    """The options bench/fine_mesh.py and bench/sponza.py share: --samples, --quick, --from-results."""
    parser = argparse.ArgumentParser(description=doc.split("\n\n")[0])
    parser.add_argument("--samples", type=int, help=f"Cycles' highest samples (default {samples}; "
                        f"{quick_samples} with --quick)")
    parser.add_argument("--quick", action="store_true", help="a few cheap bakes, to try the script")
    parser.add_argument("--from-results", type=Path, metavar="JSON", help="report a saved run again")
    return parser


def save_results(data: dict, path: Path) -> None:
    """A run's raw results as JSON at ``path``, for ``--from-results``."""
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(data))
    print(f"wrote {path.relative_to(REPO)}")


def write_report(text: str, path: Path) -> None:
    """The Markdown ``text`` at ``path``, and on the terminal."""
    path.write_text(text)
    print(text)
    print(f"wrote {path.relative_to(REPO)}")


def measure(samples: int, quick: bool, docs: Path) -> dict:
    """Run every case; the results with the run's header, settings and minutes (JSON-ready)."""
    counts = ladder(samples)
    variant_samples = min(QUICK_VARIANT_SAMPLES if quick else VARIANT_SAMPLES, samples)
    start = time.perf_counter()
    header = machine.machine() | {"core/*.py SHA-1": machine.core_digest()} | machine.load("start")
    print(", ".join(f"{k}: {v}" for k, v in header.items()), flush=True)
    labelled = cases(counts, quick, QUICK_PICTURE_SAMPLES if quick else PICTURE_SAMPLES, variant_samples,
                     variants(variant_samples), docs)
    results = run(labelled, start)
    header |= machine.load("end") | {"core/*.py SHA-1 at the end": machine.core_digest(), "bpy": results["check"]["bpy"]}
    if header["core/*.py SHA-1 at the end"] != header["core/*.py SHA-1"]:
        print("warning: core/ changed during the run: its bakes may mix two cores", file=sys.stderr)
    return {"samples": samples, "quick": quick, "counts": counts, "variant_samples": variant_samples,
            "header": header, "results": results, "minutes": (time.perf_counter() - start) / 60}


def report(run_data: dict, argv: list[str], docs: Path) -> str:
    """Analyse a run's results; write the headline plot and the report into ``docs``; the report."""
    samples, quick, results = run_data["samples"], run_data["quick"], run_data["results"]
    counts, variant_samples = tuple(run_data["counts"]), run_data["variant_samples"]
    top = headline.Headline(results, counts, SEEDS, quick)
    headline.plot(top, docs / HEADLINE_PICTURE, run_data["header"])
    changed = variants(variant_samples)
    analysis = Analysis(
        samples=samples,
        ours=[results[headline.preset_label(headline.DEFAULT_PRESET, k)] for k in range(headline.DEFAULT_RUNS)],
        seeds=[results[headline.cycles_label(samples, seed)] for seed in SEEDS],
        check=results["check"] | {"samples": CHECK_SAMPLES},
        pictures={"render": results["render"]},
        presets={name: results[headline.preset_label(name)] for name in headline.presets(quick)
                 if name != headline.DEFAULT_PRESET},
        variants={label: (kind, change, results[label]) for label, (kind, change, _case) in changed.items()},
        twin=results[headline.cycles_label(variant_samples, SEEDS[0])],
    )
    text = markdown(analysis, top, run_data["header"], run_data["minutes"], quick, argv)
    (docs / REPORT).write_text(text)
    return text


def main(argv: list[str]) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--samples", type=int, help=f"Cycles' highest sample count (default {SAMPLES}; "
                        f"{QUICK_SAMPLES} with --quick)")
    parser.add_argument("--quick", action="store_true", help="fewer samples and cheaper bakes, a few minutes; "
                        f"writes into {QUICK_DOCS.relative_to(REPO)}/")
    parser.add_argument("--from-results", type=Path, metavar="JSON", help="no bakes: the report and plot again "
                        f"from the raw results a run saved ({RESULTS.relative_to(REPO)}, "
                        f"{QUICK_RESULTS.relative_to(REPO)})")
    options = parser.parse_args(argv)
    if options.from_results is not None:
        run_data = json.loads(options.from_results.read_text())
        argv = run_data["argv"]
    else:
        samples = options.samples or (QUICK_SAMPLES if options.quick else SAMPLES)
        if samples < FIRST_SAMPLES * 4:
            parser.error(f"--samples must be at least {FIRST_SAMPLES * 4}, got {samples}")
        docs = QUICK_DOCS if options.quick else DOCS
        docs.mkdir(parents=True, exist_ok=True)
        run_data = measure(samples, options.quick, docs) | {"argv": argv}
        save_results(run_data, QUICK_RESULTS if options.quick else RESULTS)
    docs = QUICK_DOCS if run_data["quick"] else DOCS
    print()
    print(report(run_data, argv, docs))
    for name in (HEADLINE_PICTURE, OUR_PICTURE, CYCLES_PICTURE, REPORT):
        size = (docs / name).stat().st_size
        print(f"wrote {(docs / name).relative_to(REPO)} ({size / 1000:.0f} kB)")
        if name.endswith(".png") and size > PICTURE_LIMIT:
            print(f"warning: {name} is {size / 1000:.0f} kB, above {PICTURE_LIMIT / 1000:.0f} kB", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
