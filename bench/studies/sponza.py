"""Our bake against Cycles' on Sponza, the medium scene (../shared/scenes/dabrovic_sponza with the
sky quad of bench/scenes.py): no converged bake of ours exists there, so the yardstick is Cycles'
own answer, the mean of its two highest-sample seeds with that mean's noise removed in quadrature.
Built as a .blend into build/ (bench/scenes.py, "sponza"); every bake runs in a process of its
own (bench/in_blender.py), timed around the bake call. Writes docs/results/sponza.md.

Ours are ``bpy.ops.radiosity.bake()``: progressive refinement stopped after a number of shots with the
rest as the ambient term (no bake reaches a tolerance here in minutes), and the emitters' shots with
the rest carried by Monte Carlo ("Monte Carlo" in the panel's Advanced settings).
"""

from __future__ import annotations

import numpy as np

from bench import comparison, markdown, scenes
from bench.comparison import TARGET_SPEEDUP, Corners, CyclesAnswer, cycles_steps, seconds_at
from bench.markdown import pct, table
from bench.metrics import nrmse, seed_noise, without_noise
from bench.paths import reports
from core.solve import montecarlo

STUDY = "sponza"
SAMPLES, QUICK_SAMPLES = 256, 32
RAYS = 4
# Our bakes, by the core's knobs, all with RAYS rays per form factor (as the sweep's Sponza rows,
# docs/results/tradeoffs.md, unless swept): progressive refinement stopped after 300 shots, the rest
# as the ambient term (the best of 100, 300 and 1,000 shots in the run before Monte Carlo), then the
# emitters' shots with the rest carried by Monte Carlo at 64, 256 and 1,024 final-gather rays per vertex
BAKES = {"300 shots, ambient term": {"max_shots": 300, "monte_carlo_rays": 0},
         **{f"Monte Carlo {n}": {"monte_carlo_rays": n} for n in (64, 256, 1024)}}
QUICK_BAKES = {"Monte Carlo 16": {"monte_carlo_rays": 16}}


def label(bake: str) -> str:
    return f"ours {bake}"


def measure(samples: int, quick: bool) -> dict:
    """Our bakes, then Cycles at each sample count with each seed; every case's result, with the
    run's header."""
    blend = scenes.blend(STUDY)
    common = blend.case()
    ours = [(label(name), {"kind": "ours", "settings": {"preset": "CUSTOM", "rays_per_form_factor": RAYS} | settings}
             | common) for name, settings in (QUICK_BAKES if quick else BAKES).items()]
    cycles = comparison.cycles_cases(comparison.ladder(samples), common)
    return comparison.measure(ours + cycles, {"scene built": blend.description})


def report(data: dict) -> str:
    """The Markdown report of a run's results."""
    results, samples, quick = data["results"], data["samples"], data["quick"]
    answer = CyclesAnswer(comparison.cycles_runs(results, samples))
    cycles_noise, cycles_seconds, cycles_rows = [], [], []
    for step in cycles_steps(results, comparison.ladder(samples)):
        noise = seed_noise(*step.colours, answer.scale)
        cycles_noise.append(noise)
        cycles_seconds.append(step.seconds)
        cycles_rows.append([f"Cycles {step.samples} samples, seeds 1 and 2", f"{step.seconds:.1f}", pct(noise)])
    our_rows, speedups, estimates = [], [], []
    bakes = list(QUICK_BAKES if quick else BAKES)
    for name in bakes:
        result = results[label(name)]
        ours = Corners.of(result).colours
        error = without_noise(nrmse(ours, answer.colours), answer.noise)
        cycles_time, how = seconds_at(error, cycles_noise, cycles_seconds)
        speedups.append((name, cycles_time / result["wall"], error, result["wall"]))
        estimates.append(result["counts"]["error_estimate"]["total"] / error)
        counts, stages = result["counts"], result["stages"]
        our_rows.append([name, f"{result['wall']:.0f}", f"{counts['shots']:,}", f"{counts['unshot_fraction']:.2f}",
                         pct(error), f"{float(np.mean(ours)) / answer.scale:.3f}",
                         f"{cycles_time:.3g}" + (" (extrapolated)" if how else ""),
                         f"{cycles_time / result['wall']:.3g}", pct(counts["error_estimate"]["total"]),
                         ", ".join(f"{name} {seconds:.0f}" for name, seconds in stages.items())])
    first = results[label(bakes[0])]["counts"]
    about = (f"Options: `--samples N` (Cycles' highest samples, default {SAMPLES}; the bakes go from "
             f"{comparison.FIRST_SAMPLES} samples up to it, x 4 at each step, two seeds each), `--quick`, "
             "`--from-results JSON`. The machine is shared and noisy: compare within one run.")
    lines = [
        *markdown.opening("Our bake against Cycles on Sponza (the medium scene)", STUDY, " ".join(data["argv"]),
                          data["minutes"], quick, about, data["header"]),
        "",
        "## Scene and yardstick",
        "",
        f"- {scenes.DESCRIPTIONS['sponza']}; built as a .blend by bench/scenes.py (+Z up, one mesh per material, "
        f"purely diffuse Principled BSDFs, the quad a plain Emission shader, no world light): "
        f"{data['header']['scene built'].split(': ')[-1]}. {len(answer.colours):,} corners on the meshes but the quad "
        f"(`{scenes.SKY}`), all compared. Ours bakes every surface two-sided (the panel's "
        f"default), as Cycles reflects and emits: {first['triangles']:,} triangles, {first['patches']:,} patches, "
        f"{first['nodes']:,} nodes.",
        f"- The yardstick is **Cycles' answer**: the mean of its two {samples}-sample seeds, whose own noise is "
        f"{pct(answer.noise)} (RMS(seed 1 - seed 2) / 2 over the mean); every NRMSE below (RMS over every corner "
        "and channel, over the mean) has it removed in quadrature. No bake of ours converges here in minutes, so "
        "none is a reference; path tracing is the other yardstick (docs/results/path_traced.md, and the sweep's "
        "Sponza rows in docs/results/tradeoffs.md).",
        "",
        "## Ours",
        "",
        table(["bake", "wall s", "shots", "unshot fraction at the last shot", "NRMSE vs Cycles' answer",
               "mean brightness ours / Cycles", "Cycles s at that NRMSE", "x", "own error estimate", "stages (s)"],
              our_rows),
        "",
        f"Progressive refinement (raycast, {RAYS} rays per form factor, the rest at their defaults: patches of an "
        "eighth of the extent, never larger than a triangle). \"ambient term\": stopped after that many shots, "
        "the light not yet shot spread evenly as the ambient term. \"Monte Carlo N\": the emitters' patches "
        "shoot (no limit on the shots), then what they left unshot goes, with all its bounces, by particles from "
        f"the patches (N / {round(1 / montecarlo.PARTICLES_PER_RAY)} per patch, at least "
        f"{montecarlo.MIN_PARTICLES_PER_PATCH}; half sent where the final gather reads) and a final gather of N "
        "rays at each vertex (core/solve/montecarlo.py). "
        "\"Cycles s\": a Cycles bake's time at the same NRMSE, along its noise (below) interpolated in log-log "
        "between its sample counts (extrapolated beyond them along the nearest segment). \"x\": that over ours.",
        "",
        "## Cycles",
        "",
        table(["bake", "wall s", "own noise per seed"], cycles_rows),
        "",
        "## Reading",
        "",
    ]
    best = max(speedups, key=lambda item: item[1])
    carried = [item for item in speedups if item[0].startswith("Monte Carlo")]
    lines += [
        f"- **At least {TARGET_SPEEDUP:g} x faster than Cycles at equal error on this scene: "
        + ("met" if best[1] >= TARGET_SPEEDUP else "not met") + f"**: the best of ours is {best[0]} "
        f"({pct(best[2])} in {best[3]:.0f} s), {best[1]:.3g} x; a speed-up below 1 means Cycles is faster.",
        "- Every shot visits every receiver (patches and vertices), so shooting to convergence costs about "
        "patches x (patches + vertices) form factors, here hundreds of thousands of shots; stopped after a few "
        "hundred, the ambient term, which spreads the light not yet shot evenly over every surface, cannot stand "
        "for it in a scene this open and this partitioned (its mean brightness). Monte Carlo carries that light "
        "where it goes, at a cost that grows with the patches and vertices, not their product.",
    ]
    if carried:
        stages = results[label(carried[0][0])]["stages"]
        fixed = sum(stages.get(name, 0.0) for name in ("discretise", "setup", "near_field"))
        lines += [
            f"- Monte Carlo: {', '.join(f'{pct(error)} in {wall:.0f} s' for _, _, error, wall in carried)} "
            f"({', '.join(name.split()[-1] for name, *_ in carried)} rays). Of the {carried[0][3]:.0f} s of the "
            f"first, {fixed:.0f} s are the stages around the solve (discretise: contact cuts; setup: the rays' "
            "scene and the buried-patch probes; near field), "
            f"{stages.get('solve', 0.0):.0f} s the emitters' shots and {stages.get('monte_carlo', 0.0):.0f} s "
            "Monte Carlo. What is left of the error is mostly not noise: see docs/methods.md, \"Large scenes\".",
            "- Cycles' answer is not exact either: `python -m bench path_traced`, run after this, scores these "
            "bakes and Cycles' against path tracing at random corners (docs/results/path_traced.md).",
        ]
    lines += [
        f"- The core's own error estimate {'bounds' if min(estimates) >= 1 else 'does not bound'} the measured "
        f"error of every bake here ({min(estimates):.2g} to {max(estimates):.2g} times it). It estimates the "
        "distance to our own converged answer, not to Cycles'.",
    ]
    return "\n".join(lines) + "\n"


def main(argv: list[str]) -> int:
    parser = comparison.options(STUDY, __doc__.split("\n\n")[0], SAMPLES, QUICK_SAMPLES)
    data = comparison.measured_or_saved(STUDY, parser.parse_args(argv), argv, SAMPLES, QUICK_SAMPLES, measure)
    markdown.write(report(data), reports(data["quick"]) / f"{STUDY}.md")
    return 0
