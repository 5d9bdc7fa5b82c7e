"""Every bake of the last sponza run against a third answer: path tracing at random vertices of
Sponza (bench/pathtrace.py), independent of Cycles and of our patches' radiosity. Writes
docs/results/path_traced.md.

Cycles' answer (docs/results/sponza.md) has its own ways: one colour per corner at the vertex
itself, its own ray offsets. Path tracing here evaluates each chosen corner where our bake reads it
(its node: NODE_INSET in from the vertex, facing the corner's normal), on the scene the add-on reads
from the .blend the bakes ran on, with next-event estimation and bounces weighted by the power
heuristic; its noise (the standard errors of the paths) is removed from every error in quadrature.

The answer itself is checked where Cycles converges: on the sample Cornell box, path tracing at
random corners against the highest-sample Cycles answer of the last versus_cycles run, when there
is one.
"""

from __future__ import annotations

import argparse
import dataclasses
import time
from typing import NamedTuple

import numpy as np

from bench import comparison, machine, markdown, scenes
from bench.comparison import at_corners, cycles_runs, cycles_steps, seconds_at
from bench.corner_answer import CornerAnswer, path_traced_corners
from bench.markdown import pct, rgb, table
from bench.metrics import nrmse, seed_noise, without_noise, worst_share
from bench.paths import raw_results, reports, shown
from bench.runner import value_in_fresh_process
from core.settings import AUTO_PATCH_DIVISIONS

STUDY = "path_traced"
CORNERS, PATHS = 1_000, 40_000  # the 1,000 corners (issue 21), about 0.9 % of noise on Sponza
QUICK_CORNERS, QUICK_PATHS = 100, 4_000
CORNELL_CORNERS, CORNELL_PATHS = 800, 40_000  # about 0.9 % noise, against Cycles' 0.4 %, in under a minute
WORST = 10  # corners: how much of the gap between Cycles' answer and this one the worst of them carry


class Gap(NamedTuple):
    """Cycles' answer (the mean of two seeds) against path tracing at the same corners: the RMS
    gap over the answer's mean with both noises removed in quadrature, the noise of Cycles' mean,
    the mean of Cycles' answer over path tracing's, and the shares of the squared gap and of the
    squared difference of the seeds that the WORST corners by gap carry."""

    error: float
    cycles_noise: float
    ratio: float
    worst_share: float
    worst_seed_share: float
    worst: np.ndarray  # their indices, the worst first

    @classmethod
    def of(cls, answer: np.ndarray, answer_noise: float, first: np.ndarray, second: np.ndarray) -> Gap:
        """From the path-traced ``answer`` (n, 3), its relative noise and the seeds' values (n, 3)."""
        scale = float(answer.mean())
        mean = (first + second) / 2
        cycles_noise = seed_noise(first, second, scale) / np.sqrt(2)  # the mean's
        gap, seeds = ((mean - answer) ** 2).sum(axis=1), ((first - second) ** 2).sum(axis=1)
        worst = np.argsort(-gap)[:WORST]
        return cls(without_noise(without_noise(nrmse(mean, answer), answer_noise), cycles_noise), cycles_noise,
                   float(mean.mean() / scale), worst_share(gap, WORST),
                   float(seeds[worst].sum() / max(seeds.sum(), np.finfo(float).tiny)), worst)


class Traced(NamedTuple):
    """The path-traced answer at random corners of a .blend's scene, and the (object, loop) each
    corner is written to, (n,) each."""

    answer: CornerAnswer
    owner: np.ndarray
    loop: np.ndarray

    def colours(self, result: dict) -> np.ndarray:
        """(n, 3) a bake's colours (a result of bench/in_blender.py) at these corners."""
        return at_corners(result, self.owner, self.loop)

    def error(self, result: dict) -> float:
        """A bake's NRMSE against this answer, the answer's noise removed in quadrature."""
        return without_noise(nrmse(self.colours(result), self.answer.radiosity), self.answer.noise)

    def subset(self, chosen: np.ndarray) -> Traced:
        """The answer at the ``chosen`` (n,) bool corners alone."""
        answer = dataclasses.replace(self.answer, **{name: getattr(self.answer, name)[chosen] for name in
                                                     ("triangles", "corners", "radiosity", "standard_error")})
        return Traced(answer, self.owner[chosen], self.loop[chosen])


class CyclesScores(NamedTuple):
    """Cycles' bakes of a run at each sample count of its ladder (``steps``), each seed's error
    against a path-traced answer (``errors``, one list per step), their means and the steps' seconds."""

    steps: list[comparison.CyclesStep]
    errors: list[list[float]]

    @classmethod
    def of(cls, found: Traced, results: dict, samples: int) -> CyclesScores:
        steps = cycles_steps(results, comparison.ladder(samples))
        return cls(steps, [[found.error(run) for run in step.runs] for step in steps])

    @property
    def means(self) -> list[float]:
        return [float(np.mean(errors)) for errors in self.errors]

    @property
    def seconds(self) -> list[float]:
        return [step.seconds for step in self.steps]


def traced(extracted: scenes.Extracted, patch_size: float | None, corners: int, paths: int) -> Traced:
    """B at ``corners`` random corners of non-emitting triangles of a .blend's scene, path-traced
    at their nodes (bench/corner_answer.py) in a process of its own, on patches of ``patch_size``
    (None: the default bake's, the scene's extent / AUTO_PATCH_DIVISIONS)."""
    scene = extracted.scene
    patch_size = patch_size or scene.extent / AUTO_PATCH_DIVISIONS
    answer = value_in_fresh_process(path_traced_corners, scene, patch_size, corners, paths)
    chosen = answer.triangles, answer.corners
    return Traced(answer, extracted.owner[chosen].astype(str), extracted.loop[chosen])


def cornell_check(quick: bool) -> list[str]:
    """The answer where Cycles converges: path tracing at random corners of the sample Cornell
    box against the highest-sample answer of the last versus_cycles run, as Markdown lines."""
    saved = raw_results("versus_cycles", quick)
    if not saved.exists():
        return [f"Not checked: run `{markdown.command('versus_cycles', '--quick' if quick else '')}` first (it saves "
                f"Cycles' bakes of the sample Cornell box in {shown(saved)})."]
    data = comparison.load(saved)
    blend = scenes.blend("cornell_box")
    corners, paths = (QUICK_CORNERS, QUICK_PATHS) if quick else (CORNELL_CORNERS, CORNELL_PATHS)
    found = traced(scenes.extracted(blend.path), None, corners, paths)
    first, second = (found.colours(run) for run in cycles_runs(data["results"], data["samples"]))
    gap = Gap.of(found.answer.radiosity, found.answer.noise, first, second)
    return [
        f"On `{blend.description}`, where Cycles converges (docs/results/versus_cycles.md), path tracing at "
        f"{corners} random corners of the non-emitting meshes, {paths:,} paths each "
        f"({found.answer.seconds:.0f} s; noise {pct(found.answer.noise)}), against the mean of Cycles' two "
        f"{data['samples']}-sample seeds of the versus_cycles run of {data['header'].get('date', '?')} (noise "
        f"{pct(gap.cycles_noise)}): **{pct(gap.error)} apart** with both noises removed in quadrature; Cycles' mean "
        f"over path tracing's {gap.ratio:.4f}. "
        + ("That is within the two answers' own noise: they compute the same light."
           if gap.error <= max(found.answer.noise, gap.cycles_noise) else
           "That is more than the two answers' own noise."),
    ]


def report(data: dict, found: Traced, header: dict, minutes: float, quick: bool, check: list[str]) -> str:
    """The Markdown report: each bake's error against the path-traced answer, and Cycles' time at it."""
    results, samples = data["results"], data["samples"]
    answer, noise = found.answer.radiosity, found.answer.noise
    cycles = CyclesScores.of(found, results, samples)
    cycles_rows = [[f"Cycles {step.samples} samples", f"{step.seconds:.1f}", " / ".join(map(pct, errors))]
                   for step, errors in zip(cycles.steps, cycles.errors)]
    our_rows, best = [], None
    for label in (label for label in results if label.startswith("ours ")):
        result = results[label]
        ours = found.error(result)
        seconds, how = seconds_at(ours, cycles.means, cycles.seconds)
        values = found.colours(result)
        our_rows.append([label.removeprefix("ours "), f"{result['wall']:.0f}", pct(ours),
                         f"{values.mean() / answer.mean():.3f}", f"{seconds:.3g}" + (" (extrapolated)" if how else ""),
                         f"{seconds / result['wall']:.3g}"])
        if best is None or seconds / result["wall"] > best[1]:
            best = (label.removeprefix("ours "), seconds / result["wall"], ours, result["wall"])
    first, second = (found.colours(run) for run in cycles_runs(results, samples))
    gap = Gap.of(answer, noise, first, second)
    worst_rows = [[f"{found.owner[k]} loop {found.loop[k]}", rgb(answer[k]), rgb(first[k]), rgb(second[k])]
                  for k in gap.worst[:5]]
    about = (f"Run after `{markdown.command('sponza', '--quick' if quick else '')}`, from the bakes of that run "
             f"({shown(raw_results('sponza', quick))}, {data['header'].get('date', '?')}); the bakes' times are that "
             f"run's. Options: `--corners N` (default {CORNERS}), `--paths N` (default {PATHS:,}), `--quick`.")
    return "\n".join([
        *markdown.opening("Sponza's bakes against path tracing", STUDY, "--quick" if quick else "", minutes, quick,
                          about, header),
        "",
        f"- The answer: path tracing (bench/pathtrace.py) at {len(answer)} random corners of non-emitting "
        f"triangles, each where our bake reads it (its node), {header['paths']:,} paths each, in "
        f"{found.answer.seconds:.0f} s; its noise, {pct(noise)} of the mean radiosity ({answer.mean():.4f}) in RMS, "
        "is removed from every error below in quadrature.",
        "- Error: RMS over those corners and R, G, B of (bake - answer), over the answer's mean.",
        "",
        table(["Cycles", "seconds (mean of the seeds)", "error, seed 1 / seed 2"], cycles_rows),
        "",
        table(["ours", "seconds", "error", "mean / answer's", "Cycles' seconds at that error (mean of the seeds)",
               "speed-up"], our_rows),
        "",
        f"- Best speed-up against this answer: {best[0]}, {pct(best[2])} in {best[3]:.0f} s, {best[1]:.3g} x "
        f"Cycles (the target, {comparison.TARGET_SPEEDUP:g} x, is "
        f"{'met' if best[1] >= comparison.TARGET_SPEEDUP else 'not met'}).",
        f"- Cycles' own answer of docs/results/sponza.md (the mean of its two {samples}-sample seeds) is "
        f"{pct(gap.error)} from this one, its noise ({pct(gap.cycles_noise)}) removed too. The {WORST} corners where "
        f"they differ most carry {100 * gap.worst_share:.0f} % of that gap's square but "
        f"{100 * gap.worst_seed_share:.0f} % of the square of the difference between Cycles' seeds: where they carry "
        "most of it, the gap is not noise but sits at a few corners (the worst five below), which Cycles' vertex "
        "bake reads about 1e-4 x their coordinates into their own face, with its own ray offsets, and path tracing "
        "at our node (core/mesh/nodes.py NODE_INSET). docs/methods.md (Large scenes) has what was measured there.",
        "",
        table(["corner (the worst 5)", "path tracing at the node", "Cycles, seed 1", "Cycles, seed 2"], worst_rows),
        "",
        "## The answer checked against Cycles on the Cornell box",
        "",
        *check,
        "",
    ])


def main(argv: list[str]) -> int:
    parser = argparse.ArgumentParser(prog=f"python -m bench {STUDY}", description=__doc__.split("\n\n")[0])
    parser.add_argument("--corners", type=int, help=f"corners path-traced on Sponza (default {CORNERS}; "
                        f"{QUICK_CORNERS} with --quick)")
    parser.add_argument("--paths", type=int, help=f"paths at each corner (default {PATHS:,}; {QUICK_PATHS:,} with "
                        "--quick)")
    parser.add_argument("--quick", action="store_true", help="fewer corners and paths, from the last "
                        "`sponza --quick` run; writes into build/bench-quick/")
    options = parser.parse_args(argv)
    corners = options.corners or (QUICK_CORNERS if options.quick else CORNERS)
    paths = options.paths or (QUICK_PATHS if options.quick else PATHS)
    saved = raw_results("sponza", options.quick)
    if not saved.exists():
        parser.error(f"no {shown(saved)}: run `{markdown.command('sponza', '--quick' if options.quick else '')}` first")
    data = comparison.load(saved)
    ours = next(result for label, result in data["results"].items() if label.startswith("ours "))
    patch_size = ours["counts"]["patch_size"]
    start = time.perf_counter()
    header = machine.opening()
    found = traced(scenes.extracted(scenes.blend("sponza").path), patch_size, corners, paths)
    np.savez(saved.with_name(f"{STUDY}.npz"), owner=found.owner, loop=found.loop, **vars(found.answer))
    check = cornell_check(options.quick)
    header |= machine.closing(header) | {"corners": corners, "paths": paths,
                                         "patch size of the bakes": f"{patch_size:.4g}"}
    minutes = (time.perf_counter() - start) / 60
    markdown.write(report(data, found, header, minutes, options.quick, check), reports(options.quick) / f"{STUDY}.md")
    return 0
