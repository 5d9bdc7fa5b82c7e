"""The closer look of the study against Cycles (docs/results/versus_cycles.md): our default bake of
the sample Cornell box against the mean of Cycles' two highest-sample seeds, corner by corner: per
surface, where the error is (the corners where two surfaces meet), what it does not come from
(bakes of a changed scene or core), the speed, the pictures, and the reading."""

from __future__ import annotations

import math
import statistics
from dataclasses import dataclass

import numpy as np

from bench.comparison import SEEDS, Corners, CyclesAnswer
from bench.in_blender import ATTRIBUTE, CORNELL_EMITTERS, SURFACES
from bench.markdown import pct, rgb, table
from bench.metrics import nrmse, rms, seed_noise, without_noise
from bench.studies.versus_cycles_headline import PRESETS
from core.mesh.nodes import NODE_INSET

LUMINANCE = np.array([0.2126, 0.7152, 0.0722])  # Rec. 709 weights: one number per surface
TOUCH = 1e-4  # m: a corner whose vertex is this close to another surface sits where two surfaces meet
CORNER_INSET = 1e-4  # Cycles bakes a corner this x max(1, |coords|) inside its face (CYCLES.md)
OUR_PICTURE, CYCLES_PICTURE = "cornell_box_radiosity.png", "cornell_box_cycles.png"


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
        answer = CyclesAnswer(self.seeds)
        first, second = answer.seeds
        self.reference = Corners(answer.colours, first.weights, first.surface)
        self.our_corners = Corners.of(self.ours[0])
        self.noise, self.reference_noise = answer.seed_noise, answer.noise
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
        error = rms(self.our_corners.colours[mask] - self.reference.colours[mask]) / scale
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
                cells += [f"{group.sum()}", f"{ours[group].mean() / reference[group].mean():.3f}",
                          pct(nrmse(self.our_corners.colours[group], self.reference.colours[group]))]
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
        order = [name for name in PRESETS if name in ratios]
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


def sections(a: Analysis) -> list[list[str]]:
    """The closer look's sections of the report, in order."""
    return [_compared(a), _results(a), _surfaces(a), _where(a), _variants(a), _speed(a), _pictures(a), _reading(a)]


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
        f"meshes; the light's mesh (`{', '.join(CORNELL_EMITTERS)}`) is left out of every comparison.",
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
        "the way (core/mesh/nodes.py NODE_INSET). "
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
        f"(`core.mesh.nodes.NODE_INSET`, {NODE_INSET:g} of the extent in the code).",
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
        "and the direct light there exactly where a shadow starts at the vertex (core/reconstruct/touching.py, "
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
    "(the floor's patches straddled the blocks' footprints). Measured with the rescore study (then "
    "bench/cycles_rescore.py) on that run's Cycles answer: the contact cuts alone took the default bake to 4.1 %, "
    "with the near field to 0.86 % (every ray cast; probe rays, the default since, add about 0.1 %).",
    "- Before the touching patches were read at the right place (core/reconstruct/touching.py; core of commit "
    "d002675, the previous run of this script, 2026-11-22): the default bake was 0.77 % from Cycles' converged "
    "answer (1.04 s) and our converged reference 0.56 % (1.3 x Cycles' noise), 51 % of the default's squared "
    "error on the corners where two surfaces meet (1.47 % there); the blocks' bottom corners were up to 35 % off (the "
    "short block's 16 touching corners 4.1 % RMS for the reference). A brute-force final gather at the worst "
    "corners (one more bounce, gathered exactly at each ray's hit point) came within 2-4 % of Cycles there, "
    "which located the error in the floor's light right at the blocks' feet.",
    "- The core's own error estimate (last column of the first table): since the core of commit 2812e32 ray-cast "
    "bakes estimate the discretisation from how far the patches next to each vertex are from linear "
    "(core/reconstruct/nearfield.py, reading_error); the previous run reported 27 % for the default bake's 1.0 %.",
]


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
