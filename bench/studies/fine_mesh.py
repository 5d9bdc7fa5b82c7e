"""Our bake against Cycles' on the Cornell box with finely split walls: the issue's anchor mesh
(walls 40 x 40, COMBINED vertex bake), where Cycles' time grows with the corners it bakes and ours
should not. Built from the same OBJ as sample_blends/cornell_box.blend (bench/scenes.py,
"fine_mesh"); every bake runs in a process of its own (bench/in_blender.py), timed around the bake
call. Writes docs/results/fine_mesh.md.

Errors are NRMSE per corner against our converged reference on this mesh (REFERENCE_SETTINGS),
which is cross-checked against the mean of Cycles' two highest-sample seeds within their noise;
Cycles' time at our error is interpolated in log-log between its sample counts, or extrapolated
along noise's law (bench/comparison.py, ``seconds_at``).
"""

from __future__ import annotations

from pathlib import Path

from bench import comparison, markdown, scenes
from bench.comparison import ANCHOR, TARGET_SPEEDUP, Corners, CyclesAnswer, cycles_steps, seconds_at
from bench.markdown import pct, table
from bench.metrics import nrmse, rms, seed_noise, without_noise
from bench.paths import reports

STUDY = "fine_mesh"
SAMPLES, QUICK_SAMPLES = 1024, 64
PRESETS = ("DRAFT", "PREVIEW", "PRODUCTION")
QUICK_PRESETS = ("DRAFT",)
# Our converged reference here: as the sample box's (versus_cycles_headline.py FINER), patches of
# 45 mm (extent / 21, flat regions merged), 64 rays, tolerance 1e-4, Monte Carlo off (shot to the
# tolerance: Auto would hand the light left to 64 noisy gather rays at its size). Checked against
# Cycles' answer, and against the REFERENCE preset (extent / 16).
REFERENCE_SETTINGS = {"preset": "CUSTOM", "patch_size": 0.045, "rays_per_form_factor": 64, "tolerance": 1e-4,
                      "monte_carlo_rays": 0}
QUICK_REFERENCE_SETTINGS = {"preset": "REFERENCE"}
TWIN = "REFERENCE"  # the preset the reference is compared with, to show it converged


def presets(quick: bool) -> tuple[str, ...]:
    """Our presets a run bakes (with --quick, the reference is the twin itself)."""
    return QUICK_PRESETS if quick else PRESETS + (TWIN,)


def measure(samples: int, quick: bool, reuse: dict | None) -> dict:
    """Every case's result, with the run's header; Cycles' from ``reuse`` (an earlier run's data,
    same samples) if given, so that a change of ours is measured without baking Cycles again."""
    blend = scenes.blend(STUDY)
    common = blend.case()
    ours = [(f"ours {name}", {"kind": "ours", "settings": {"preset": name}} | common) for name in presets(quick)]
    ours.append(("ours reference", {"kind": "ours", "settings": QUICK_REFERENCE_SETTINGS if quick
                                    else REFERENCE_SETTINGS} | common))
    header = {"scene built": blend.description}
    cycles = comparison.cycles_cases(comparison.ladder(samples), common)
    if reuse is not None:
        if reuse["samples"] != samples:
            raise SystemExit(f"--reuse-cycles: that run went to {reuse['samples']} samples, not {samples}")
        cycles = []
        header["Cycles' bakes"] = f"reused from the run of {reuse['header']['date']} (--reuse-cycles)"
    data = comparison.measure(comparison.alternate(ours, cycles), header)
    if reuse is not None:
        data["results"] |= {label: result for label, result in reuse["results"].items() if label.startswith("cycles")}
    return data


def report(data: dict) -> str:
    """The Markdown report of a run's results."""
    results, samples, quick = data["results"], data["samples"], data["quick"]
    reference = Corners.of(results["ours reference"]).colours
    cycles_errors, cycles_seconds, cycles_rows = [], [], []
    for step in cycles_steps(results, comparison.ladder(samples)):
        error = rms([nrmse(colours, reference) for colours in step.colours])
        cycles_errors.append(error)
        cycles_seconds.append(step.seconds)
        anchor = f"{ANCHOR[step.samples][0]:g} s, {pct(ANCHOR[step.samples][1])}" if step.samples in ANCHOR else ""
        cycles_rows.append([f"Cycles {step.samples} samples, seeds 1 and 2", f"{step.seconds:.2f}", pct(error),
                            pct(seed_noise(*step.colours, float(reference.mean()))), anchor])
    answer = CyclesAnswer(comparison.cycles_runs(results, samples))
    cross = nrmse(reference, answer.colours)
    bias = without_noise(cross, answer.noise)
    our_rows, speedups = [], {}
    for name in presets(quick):
        result = results[f"ours {name}"]
        error = nrmse(Corners.of(result).colours, reference)
        cycles_time, how = seconds_at(error, cycles_errors, cycles_seconds)
        speedups[name] = (cycles_time / result["wall"], error, result["wall"])
        our_rows.append([name, f"{result['wall']:.2f}", pct(error) + (" †" if error < bias else ""),
                         f"{cycles_time:.3g}" + (" (extrapolated)" if how else ""),
                         f"{cycles_time / result['wall']:.3g}", _sizes(result["counts"]),
                         result["summary"].split(": ", 1)[-1]])
    reference_result = results["ours reference"]
    about = (f"Options: `--samples N` (Cycles' highest samples, default {SAMPLES}), `--quick`, `--from-results JSON`, "
             "`--reuse-cycles JSON`. The machine is shared and noisy: compare within one run.")
    lines = [
        *markdown.opening("Our bake against Cycles on a finely split Cornell box (the issue's 40 x 40 walls)", STUDY,
                          " ".join(data["argv"]), data["minutes"], quick, about, data["header"]),
        "",
        "## Scene and yardstick",
        "",
        f"- The published Cornell box (`sample_blends/cornell_box.obj`), every quad split into cells of about "
        f"{scenes.FINE_MESH_CELL * 1000:g} mm (walls 40 x 40) by `sample_blends/build_samples.py`: "
        f"{data['header']['scene built'].split(': ')[-1]}; {len(reference):,} corners on the 7 non-emitting meshes, "
        "all compared. The same materials, light and Cycles recipe as docs/results/versus_cycles.md "
        "(../shared/CYCLES.md).",
        f"- Our converged reference: `bpy.ops.radiosity.bake()` with "
        f"{comparison.settings_text(reference_result['case_settings'])} ({_sizes(reference_result['counts'])}; "
        f"{reference_result['wall']:.0f} s). "
        + (f"Its twin, the {TWIN} preset, differs from it by NRMSE "
           f"{pct(nrmse(Corners.of(results['ours ' + TWIN]).colours, reference))}." if not quick else ""),
        f"- Cross-check: against the mean of Cycles' two {samples}-sample seeds our reference's NRMSE is {pct(cross)}; "
        f"that mean's own noise is {pct(answer.noise)}; with it removed in quadrature {pct(bias)} remains "
        + ("(**within** Cycles' noise)." if bias <= answer.noise else
           "(**not** within Cycles' noise: errors below it against our reference are not confirmed by Cycles)."),
        "",
        "## Ours",
        "",
        table(["bake", "wall s", "NRMSE vs our reference", "Cycles s at that NRMSE", "x", "size", "summary line"],
              our_rows),
        "",
        "\"Cycles s\": Cycles' time per bake at the same NRMSE against our reference, interpolated in log-log "
        "between this run's sample counts (extrapolated beyond them: below its lowest error along noise's law, "
        "time x 1 / error^2, which assumes Cycles keeps converging to our reference). \"x\": that over ours. "
        f"†: below our reference's remaining difference from Cycles' answer ({pct(bias)}): not confirmed by Cycles.",
        "",
        "## Cycles",
        "",
        table(["bake", "wall s", "NRMSE vs our reference (RMS over the seeds)", "own noise per seed",
               "the issue's anchor (quoted)"], cycles_rows),
        "",
        "## Reading",
        "",
    ]
    default = speedups.get("PREVIEW") or next(iter(speedups.values()))
    fast = [f"{name} ({value[0]:.3g} x{', not confirmed by Cycles' if value[1] < bias else ''})"
            for name, value in speedups.items() if value[0] >= TARGET_SPEEDUP]
    slow = [f"{name} ({value[0]:.3g} x)" for name, value in speedups.items() if value[0] < TARGET_SPEEDUP]
    lines += [
        f"- The default bake (PREVIEW) is {pct(default[1])} from our reference in {default[2]:.2f} s; Cycles needs "
        f"{default[0] * default[2]:.3g} s for that error: {default[0]:.3g} x.",
        f"- **At least {TARGET_SPEEDUP:g} x faster than Cycles at equal error on this mesh**: "
        + (f"met by {', '.join(fast)}" if fast else "met by no preset")
        + (f"; not by {', '.join(slow)}." if slow else "."),
        "- Flat regions of small triangles are solved on panels up to the patch size (core/mesh/panels.py), so "
        "the patches do not grow with the mesh; the vertex colours are still evaluated at every vertex, so that "
        "part of our cost does.",
    ]
    return "\n".join(lines) + "\n"


def _sizes(counts: dict) -> str:
    if not counts:
        return ""
    return (f"{counts['triangles']:,} triangles in {counts['panels']:,} panels, {counts['patches']:,} patches, "
            f"{counts['nodes']:,} nodes")


def main(argv: list[str]) -> int:
    parser = comparison.options(STUDY, __doc__.split("\n\n")[0], SAMPLES, QUICK_SAMPLES)
    parser.add_argument("--reuse-cycles", type=Path, metavar="JSON", help="bake ours only; Cycles' bakes "
                        "from a saved run (the report says so)")
    options = parser.parse_args(argv)
    reuse = comparison.load(options.reuse_cycles) if options.reuse_cycles else None
    data = comparison.measured_or_saved(STUDY, options, argv, SAMPLES, QUICK_SAMPLES,
                                        lambda samples, quick: measure(samples, quick, reuse))
    markdown.write(report(data), reports(data["quick"]) / f"{STUDY}.md")
    return 0
