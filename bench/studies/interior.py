"""Our bake against Cycles' on an interior: the breakfast room (269,538 triangles) lit by a uniform
sky through its windows, both scored against path tracing at random corners. Writes
docs/results/interior.md.

The breakfast study times the core's bake of the OBJ; this one bakes the room as a user would, in
Blender (the scene built as a .blend by bench/scenes.py, its sky the world's background, every
surface two-sided as Cycles shades it), beside Cycles' COMBINED vertex bakes at increasing samples
(../shared/CYCLES.md's recipe), each in a process of its own (bench/in_blender.py). Cycles' bakes
are too noisy here to be the yardstick (sponza.md's), so path tracing is (bench/corner_answer.py,
at each chosen corner's node on the scene the add-on reads from the .blend), its noise removed from
every error in quadrature, and Cycles' time at our error is read off its own errors against it.
The errors are given at every corner and "where seen": without the corners whose node lies inside
a solid (``inside_solids``), whose light, two-sided, is what leaks into the solid.
"""

from __future__ import annotations

import dataclasses
import math
import sys
import time

import numpy as np

from bench import comparison, markdown, scenes
from bench.comparison import TARGET_SPEEDUP, cycles_runs, seconds_at
from bench.corner_answer import CornerAnswer
from bench.markdown import pct, table
from bench.metrics import seed_noise
from bench.paths import raw_results, reports
from bench.studies.path_traced import CyclesScores, Gap, Traced, traced
from core import BakeSettings, Scene
from core.mesh.discretize import discretised
from core.rays.visibility import Visibility
from core.transport import receivers

STUDY = "interior"
SAMPLES, QUICK_SAMPLES = 256, 32
CORNERS, PATHS = 1_000, 40_000  # the breakfast study's: about 3 % of noise
QUICK_CORNERS, QUICK_PATHS = 100, 500
# Ours by the panel's settings: its defaults (the Preview preset, Monte Carlo by Auto: 64 rays), and
# four times the final gather's rays
BAKES = {"defaults": {}, "Monte Carlo 256": {"monte_carlo_rays": 256}}
QUICK_BAKES = {"defaults": {}}


def label(bake: str) -> str:
    return f"ours {bake}"


def measure(samples: int, quick: bool) -> dict:
    """Our bakes, then Cycles at each sample count with each seed; every case's result, with the
    run's header."""
    blend = scenes.blend("breakfast")
    common = blend.case()
    ours = [(label(name), {"kind": "ours", "settings": settings} | common)
            for name, settings in (QUICK_BAKES if quick else BAKES).items()]
    cycles = comparison.cycles_cases(comparison.ladder(samples), common)
    return comparison.measure(ours + cycles, {"scene built": blend.description})


def inside_solids(scene: Scene, patch_size: float, answer: CornerAnswer) -> np.ndarray:
    """(n,) bool: whether the node of each of the ``answer``'s corners lies inside a solid: on the
    scene taken one-sided, every probe ray from it meets the back of a triangle first
    (``receivers.buried``, as the bake finds the buried parts of patches)."""
    one_sided = dataclasses.replace(scene, two_sided=np.zeros(len(scene.triangles), dtype=bool))
    mesh, _ = discretised(one_sided, patch_size, math.radians(BakeSettings().crease_angle), True)
    visibility = Visibility(mesh.patch_corners, owners=mesh.patch_triangle)
    nodes = mesh.corner_node[answer.triangles, answer.corners]
    return receivers.buried(mesh.node_points[nodes][:, None], mesh.node_normals[nodes], visibility)[:, 0]


def report(data: dict, found: Traced, inside: np.ndarray, minutes: float) -> str:
    """The Markdown report: Cycles' bakes and ours against the path-traced answer ``found``
    (``path_traced.Traced``), at every corner and at those not ``inside`` (n,) a solid, and
    Cycles' time at each of our errors."""
    results, samples, quick = data["results"], data["samples"], data["quick"]
    answer, noise = found.answer.radiosity, found.answer.noise
    cycles = CyclesScores.of(found, results, samples)
    cycles_rows = [[f"Cycles {step.samples} samples", f"{step.seconds:.1f}", " / ".join(map(pct, errors)),
                    pct(seed_noise(*map(found.colours, step.runs), answer.mean()))]
                   for step, errors in zip(cycles.steps, cycles.errors)]
    seen = found.subset(~inside)
    cycles_seen = CyclesScores.of(seen, results, samples)
    for row, errors in zip(cycles_rows, cycles_seen.errors):
        row.append(" / ".join(map(pct, errors)))
    our_rows, speedups = [], {"at every corner": [], "where seen": []}
    for name in QUICK_BAKES if quick else BAKES:
        result = results[label(name)]
        row = [name, f"{result['wall']:.0f}"]
        for where, answered, curve in zip(speedups, (found, seen), (cycles, cycles_seen)):
            ours = answered.error(result)
            seconds, how = seconds_at(ours, curve.means, curve.seconds)
            row += [pct(ours), f"{seconds:.3g}" + (" (extrapolated)" if how else ""), f"{seconds / result['wall']:.3g}"]
            speedups[where].append((seconds / result["wall"], name, ours, result["wall"]))
        counts, stages = result["counts"], result["stages"]
        our_rows.append(row + [f"{found.colours(result).mean() / answer.mean():.3f}",
                               pct(counts["error_estimate"]["total"]),
                               ", ".join(f"{stage} {value:.0f}" for stage, value in stages.items())])
    first, second = (found.colours(run) for run in cycles_runs(results, samples))
    gap = Gap.of(answer, noise, first, second)
    counts = results[label("defaults")]["counts"]
    about = (f"Options: `--samples N` (Cycles' highest samples, default {SAMPLES}; the bakes go from "
             f"{comparison.FIRST_SAMPLES} samples up to it, x 4 at each step, two seeds each), `--corners N` "
             f"(default {CORNERS:,}), `--paths N` (default {PATHS:,}), `--quick`, `--from-results JSON` (the bakes "
             "of a run again, the answer traced afresh). The machine is shared and noisy: compare within one run.")
    return "\n".join([
        *markdown.opening("Our bake against Cycles in an interior (the breakfast room)", STUDY,
                          " ".join(data["argv"]), minutes, quick, about, data["header"]),
        "",
        "## Scene and yardstick",
        "",
        f"- The scene: {scenes.DESCRIPTIONS['breakfast']}; built as a .blend by bench/scenes.py (+Z up, one mesh "
        "per material, purely diffuse Principled BSDFs, the sky the world's uniform background): "
        f"{data['header']['scene built'].split(': ')[-1]}. Ours bakes every surface two-sided (the panel's default), "
        f"as Cycles shades them: {counts['triangles']:,} triangles, {counts['patches']:,} patches, "
        f"{counts['nodes']:,} nodes.",
        f"- The answer: path tracing (bench/pathtrace.py, the sky added where a path leaves the scene) at "
        f"{len(answer):,} random corners of the scene the add-on reads from the .blend, each where our bake reads "
        f"it (its node), {data['header'].get('paths', PATHS):,} paths each, in {found.answer.seconds:.0f} s; its "
        f"noise, {pct(noise)} of the mean radiosity ({answer.mean():.4f}) in RMS, is removed from every error "
        f"below in quadrature. {int(inside.sum())} of them have their node inside a solid (taken one-sided, every "
        "probe ray from it meets the back of a triangle first: core/transport/receivers.py `buried`), where no "
        f"viewer in the room looks; the errors \"where seen\" are over the other {len(seen.answer.radiosity):,}.",
        "- Error: RMS over those corners and R, G, B of (bake - answer), over the answer's mean. \"Cycles' "
        "seconds\": a Cycles bake's time at the same error, interpolated in log-log between its sample counts "
        "(beyond them along noise's law, time x 1 / error^2, or the first segment). \"x\": that over ours.",
        "",
        table(["Cycles", "seconds (mean of the seeds)", "error, seed 1 / seed 2", "own noise per seed",
               "error where seen, seed 1 / seed 2"], cycles_rows),
        "",
        table(["ours", "seconds", "error", "Cycles' seconds at that error", "speed-up", "error where seen",
               "Cycles' seconds at that error", "speed-up", "mean / answer's", "own error estimate", "stages (s)"],
              our_rows),
        "",
        "## Reading",
        "",
        *(f"- Best speed-up {where}: {name}, {pct(error)} in {wall:.0f} s, {speedup:.3g} x Cycles (the project's "
          f"target, {TARGET_SPEEDUP:g} x, is {'met' if speedup >= TARGET_SPEEDUP else 'not met'})."
          for where, (speedup, name, error, wall) in ((where, max(items)) for where, items in speedups.items())),
        f"- Cycles' {samples}-sample answer (the mean of its two seeds) is {pct(gap.error)} from path tracing once "
        f"its own noise ({pct(gap.cycles_noise)}) is removed too, its mean over path tracing's {gap.ratio:.3f}: "
        + ("its error is its noise, so its time at a lower error follows noise's law, time x 1 / error^2."
           if gap.error <= gap.cycles_noise else
           "its error is not all noise, so its time at a lower error is at least what noise's law gives, time x "
           "1 / error^2, and the speed-ups above are lower bounds."),
        "",
    ])


def main(argv: list[str]) -> int:
    parser = comparison.options(STUDY, __doc__.split("\n\n")[0], SAMPLES, QUICK_SAMPLES)
    parser.add_argument("--corners", type=int, help=f"corners path-traced (default {CORNERS:,}; {QUICK_CORNERS} "
                        "with --quick)")
    parser.add_argument("--paths", type=int, help=f"paths at each corner (default {PATHS:,}; {QUICK_PATHS:,} with "
                        "--quick)")
    options = parser.parse_args(argv)
    if scenes.missing():
        print(f"error: {scenes.missing()}", file=sys.stderr)
        return 2
    data = comparison.measured_or_saved(STUDY, options, argv, SAMPLES, QUICK_SAMPLES, measure)
    quick = data["quick"]
    corners = options.corners or (QUICK_CORNERS if quick else CORNERS)
    paths = options.paths or (QUICK_PATHS if quick else PATHS)
    patch_size = data["results"][label("defaults")]["counts"]["patch_size"]
    print(f"the answer: {corners:,} corners x {paths:,} paths ...", flush=True)
    start = time.perf_counter()
    extracted = scenes.extracted(scenes.blend("breakfast").path)
    found = traced(extracted, patch_size, corners, paths)
    inside = inside_solids(extracted.scene, patch_size, found.answer)
    np.savez(raw_results(STUDY, quick).with_name(f"{STUDY}.npz"), owner=found.owner, loop=found.loop,
             **vars(found.answer))
    data["header"] |= {"corners": corners, "paths": paths}
    minutes = data["minutes"] + (time.perf_counter() - start) / 60
    markdown.write(report(data, found, inside, minutes), reports(quick) / f"{STUDY}.md")
    return 0
