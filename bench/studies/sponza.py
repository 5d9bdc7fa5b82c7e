"""Our bake against Cycles' on Sponza, the medium scene (../shared/scenes/dabrovic_sponza with the
sky quad of bench/scenes.py): no converged bake of ours exists there, so the yardstick is Cycles'
own answer, the mean of its two highest-sample seeds with that mean's noise removed in quadrature.
Built as a .blend by bench/sponza_blend.py into build/sponza/ (not committed); every bake runs in a
process of its own (bench/cycles_worker.py), timed around the bake call.

Ours are ``bpy.ops.radiosity.bake()``: progressive refinement stopped after a number of shots with the
rest as the ambient term (no bake reaches a tolerance here in minutes), and the emitters' shots with
the rest carried by Monte Carlo ("Monte Carlo" in the panel's Advanced settings).

Run from the repository root: ``.venv/bin/python bench/sponza.py [--samples 256] [--quick]``; writes
docs/sponza.md (``--quick``: build/sponza/sponza.md) and the raw results, build/sponza/results.json
(``--quick``: results-quick.json; ``--from-results`` reports them again without baking).
"""

from __future__ import annotations

import json
import math
import statistics
import subprocess
import sys
import time
from pathlib import Path

import machine
import numpy as np
from cycles import driver_parser, ladder, run, save_results, write_report
from cycles_headline import seconds_at
from cycles_metrics import nrmse, pct, seed_noise, table, without_noise
from cycles_worker import REPO

sys.path.insert(0, str(REPO))  # bench/scenes.py reads the scene with the core
from scenes import DESCRIPTIONS  # noqa: E402

COMMAND = ".venv/bin/python bench/sponza.py"
WORK = REPO / "build" / "sponza"
BLEND = WORK / "sponza.blend"
RESULTS, QUICK_RESULTS = WORK / "results.json", WORK / "results-quick.json"
REPORT, QUICK_REPORT = REPO / "docs" / "sponza.md", WORK / "sponza.md"
SAMPLES, QUICK_SAMPLES = 256, 64
SEEDS = (1, 2)
EMITTERS = ["sky"]  # bench/sponza_blend.py's emitting quad: left out of every comparison
# Our bakes, by the panel's settings, all with 4 rays per form factor (as the sweep's Sponza rows,
# docs/tradeoffs.md, unless swept): progressive refinement stopped after 300 shots, the rest as the ambient term (the
# best of 100, 300 and 1,000 shots in the run before Monte Carlo), then the emitters' shots with the rest
# carried by Monte Carlo at 64, 256 and 1,024 final-gather rays per vertex
BAKES = {"300 shots, ambient term": {"max_shots": 300, "monte_carlo_rays": "0"},
         **{f"Monte Carlo {n}": {"monte_carlo_rays": str(n)} for n in (64, 256, 1024)}}
QUICK_BAKES = {"Monte Carlo 16": {"monte_carlo_rays": "16"}}
RAYS = 4
TARGET_SPEEDUP = 100.0


def build() -> dict:
    """The .blend, built afresh (bpy 5.0.1 of this venv)."""
    process = subprocess.run([sys.executable, str(REPO / "bench" / "sponza_blend.py"), str(BLEND)],
                             cwd=REPO, capture_output=True, text=True, check=True)
    return {"built": process.stdout.strip().splitlines()[-1]}


def label(bake: str) -> str:
    return f"ours {bake}"


def cases(quick: bool, samples: int) -> list[tuple[str, dict]]:
    """Our bakes, then Cycles at each sample count with each seed."""
    common = {"blend": str(BLEND), "emitters": EMITTERS}
    ours = [(label(name), {"kind": "ours", "settings": {"preset": "CUSTOM", "rays": str(RAYS)} | settings} | common)
            for name, settings in (QUICK_BAKES if quick else BAKES).items()]
    cycles = [(f"cycles {n} seed {seed}", {"kind": "cycles", "samples": n, "seed": seed} | common)
              for n in ladder(samples) for seed in SEEDS]
    return ours + cycles


def measure(quick: bool, samples: int) -> dict:
    """Every case's result, with the run's header."""
    start = time.perf_counter()
    header = machine.machine() | {"core/*.py SHA-1": machine.core_digest()} | machine.load("start") | build()
    print(", ".join(f"{k}: {v}" for k, v in header.items()), flush=True)
    results = run(cases(quick, samples), start)
    header |= machine.load("end") | {"core/*.py SHA-1 at the end": machine.core_digest()}
    if header["core/*.py SHA-1 at the end"] != header["core/*.py SHA-1"]:
        print("warning: core/ changed during the run: its bakes may mix two cores", file=sys.stderr)
    return {"quick": quick, "samples": samples, "header": header, "results": results,
            "minutes": (time.perf_counter() - start) / 60}


def colours(result: dict) -> np.ndarray:
    """(M, 3) corner colours of the compared meshes, in the order of their names."""
    objects = result["objects"]
    return np.concatenate([np.array(objects[name]["colours"], dtype=np.float64) for name in sorted(objects)])


def report(data: dict) -> str:
    """The Markdown report of a run's results."""
    results, samples, quick = data["results"], data["samples"], data["quick"]
    top = [colours(results[f"cycles {samples} seed {s}"]) for s in SEEDS]
    answer = 0.5 * (top[0] + top[1])
    scale = float(np.mean(answer))
    answer_noise = seed_noise(top[0], top[1], scale) / math.sqrt(2)
    cycles_noise, cycles_seconds, cycles_rows = [], [], []
    for n in ladder(samples):
        seeds = [colours(results[f"cycles {n} seed {s}"]) for s in SEEDS]
        noise = seed_noise(seeds[0], seeds[1], scale)
        wall = statistics.mean(results[f"cycles {n} seed {s}"]["wall"] for s in SEEDS)
        cycles_noise.append(noise)
        cycles_seconds.append(wall)
        cycles_rows.append([f"Cycles {n} samples, seeds 1 and 2", f"{wall:.1f}", pct(noise)])
    our_rows, speedups, estimates = [], [], []
    bakes = list(QUICK_BAKES if quick else BAKES)
    for name in bakes:
        result = results[label(name)]
        ours = colours(result)
        error = without_noise(nrmse(ours, answer), answer_noise)
        cycles_time, how = seconds_at(error, cycles_noise, cycles_seconds)
        speedups.append((name, cycles_time / result["wall"], error, result["wall"]))
        estimates.append(result["counts"]["error_estimate"]["total"] / error)
        counts, stages = result["counts"], result["stages"]
        our_rows.append([name, f"{result['wall']:.0f}", f"{counts['shots']:,}", f"{counts['unshot_fraction']:.2f}",
                         pct(error), f"{float(np.mean(ours)) / scale:.3f}",
                         f"{cycles_time:.3g}" + (" (extrapolated)" if how else ""),
                         f"{cycles_time / result['wall']:.3g}", pct(counts["error_estimate"]["total"]),
                         ", ".join(f"{name} {seconds:.0f}" for name, seconds in stages.items())])
    first = results[label(bakes[0])]["counts"]
    lines = [
        "# Our bake against Cycles on Sponza (the medium scene)",
        "",
        f"Generated by `{COMMAND}` (from the repository root) in {data['minutes']:.1f} minutes"
        + (" (`--quick`: not to quote)" if quick else "") + ". Options: `--samples N` (Cycles' highest samples, "
        f"default {SAMPLES}; the bakes go from 16 samples up to it, x 4 at each step, two seeds each), `--quick`, "
        "`--from-results JSON`. The machine is shared and noisy: compare within one run.",
        "",
        *(f"- {key}: {value}" for key, value in data["header"].items()),
        "",
        "## Scene and yardstick",
        "",
        f"- {DESCRIPTIONS['sponza']}; built as a .blend by `bench/sponza_blend.py` (+Z up, one mesh per material, "
        f"purely diffuse Principled BSDFs, the quad a plain Emission shader, no world light): "
        f"{data['header']['built'].split(': ')[-1]}. {len(answer):,} corners on the meshes but the quad "
        f"(`{', '.join(EMITTERS)}`), all compared. Ours bakes every surface two-sided (the panel's default), as "
        f"Cycles reflects and emits: {first['triangles']:,} triangles, {first['patches']:,} patches, "
        f"{first['nodes']:,} nodes.",
        f"- The yardstick is **Cycles' answer**: the mean of its two {samples}-sample seeds, whose own noise is "
        f"{pct(answer_noise)} (RMS(seed 1 - seed 2) / 2 over the mean); every NRMSE below (RMS over every corner "
        "and channel, over the mean) has it removed in quadrature. No bake of ours converges here in minutes, so "
        "none is a reference; path tracing is the other yardstick (docs/path_traced.md, and the sweep's Sponza rows "
        "in docs/tradeoffs.md).",
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
        "shoot (Max Shots 0), then what they left unshot goes, with all its bounces, by particles from the "
        "patches (N / 16 per patch) and a final gather of N rays at each vertex (core/montecarlo.py). "
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
            "- Cycles' answer is not exact either: `bench/path_traced.py`, run after this, scores these bakes and "
            "Cycles' against path tracing at random corners (docs/path_traced.md).",
        ]
    lines += [
        f"- The core's own error estimate {'bounds' if min(estimates) >= 1 else 'does not bound'} the measured "
        f"error of every bake here ({min(estimates):.2g} to {max(estimates):.2g} times it). It estimates the "
        "distance to our own converged answer, not to Cycles'.",
    ]
    return "\n".join(lines) + "\n"


def main(argv: list[str]) -> int:
    parser = driver_parser(__doc__, SAMPLES, QUICK_SAMPLES)
    options = parser.parse_args(argv)
    if options.from_results:
        data = json.loads(options.from_results.read_text())
    else:
        data = measure(options.quick, options.samples or (QUICK_SAMPLES if options.quick else SAMPLES))
        save_results(data, QUICK_RESULTS if options.quick else RESULTS)
    write_report(report(data), QUICK_REPORT if data["quick"] else REPORT)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
