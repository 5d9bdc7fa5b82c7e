"""Speed, accuracy and memory of bake() on the shared scenes (the Cornell box and Sponza), and the
rays of its bakes against raw Embree throughput; writes docs/results/benchmarks.md.

Each case runs in a fresh process (bench/runner.py), so its peak memory and thread pool are its
own: a timed bake, the same bake again under tracemalloc (which slows NumPy-heavy code, so it never
times), and the raw Embree throughput on the bake's own patches (bench/raw_embree.py), sampled
before and after the rerun. The machine is shared and noisy: compare the ratios of one run, not
absolute figures across runs.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
import tracemalloc
from dataclasses import dataclass, field

import numpy as np

from bench import machine, markdown, scenes
from bench.markdown import MIB, table
from bench.metrics import nrmse
from bench.paths import reports
from bench.raw_embree import RAW_RAYS, RAW_REPEATS, SHOOTERS, RawEmbree
from bench.runner import cpu_seconds, peak_resident, value_in_fresh_process
from core import bake

STUDY = "benchmarks"
RAY_STAGES = ("form_factors", "solve", "gather")  # the stages of bake() that cast rays
DEFAULT_CASE = ("cornell", "default", "raycast")  # the bake the wall-time target is about
WALL_TARGET = 2.0  # seconds for DEFAULT_CASE on 2 cores
RAY_RATIO_TARGET = 0.5  # bake rays per second over raw Embree rays per second


@dataclass(frozen=True)
class Case:
    """A bake to measure: ``knobs`` go to bake() as they are; the errors of a scene's other bakes
    are measured against its ``reference`` bake."""

    scene: str
    setting: str
    method: str = "raycast"
    knobs: dict = field(default_factory=dict)
    reference: bool = False

    @property
    def label(self) -> str:
        """The scene and setting, and the method unless it is the default, ray casting."""
        return f"{self.scene} {self.setting}" + ("" if self.method == "raycast" else f" {self.method}")


CASES = [
    Case("cornell", "draft", knobs={"rays_per_form_factor": 4, "tolerance": 1e-2}),
    Case("cornell", "default"),
    Case("cornell", "default", method="hemicube"),
    # patch_size 80 mm is extent / 12, finer than the default (core.settings.AUTO_PATCH_DIVISIONS)
    Case("cornell", "high", knobs={"rays_per_form_factor": 64, "patch_size": 80.0, "tolerance": 1e-4},
         reference=True),
    # Sponza is large for a point-to-patch method: both stop at max_shots, far above their tolerance
    Case("sponza", "draft", knobs={"rays_per_form_factor": 4, "tolerance": 0.05, "max_shots": 200}),
    Case("sponza", "longer", knobs={"rays_per_form_factor": 4, "tolerance": 0.02, "max_shots": 500},
         reference=True),
]
QUICK_CASES = [  # the Cornell box alone, against a cheaper reference
    *CASES[:2],
    Case("cornell", "reference", knobs={"rays_per_form_factor": 16, "patch_size": 160.0, "tolerance": 1e-4},
         reference=True),
]


@dataclass
class Measurement:
    """What one case measured; sizes in bytes, times in seconds, rates in rays per second."""

    case: Case
    stats: dict  # BakeResult.stats of the timed bake
    wall: float
    cpu: float  # CPU seconds of the process (all threads) during the timed bake
    bake_rays_per_second: float  # rays_cast over the seconds of the RAY_STAGES
    raw_query: str
    raw_rays_per_second: float
    raw_rays_per_cpu_second: float
    traced_peak: int  # tracemalloc peak of the rerun
    peak_before: int  # the process's peak resident set with the scene loaded, before baking
    peak_after: int  # the same after the timed bake (before anything else)
    repeatable: bool  # the rerun gave identical corner colours
    emitting: np.ndarray  # (T,) bool, the triangles with non-zero emission
    corner_colors: np.ndarray
    triangle_radiosity: np.ndarray

    @property
    def ratio(self) -> float:
        """Bake rays per second over raw Embree rays per second."""
        return self.bake_rays_per_second / self.raw_rays_per_second

    @property
    def cpu_ratio(self) -> float:
        """The same per CPU second (the whole bake's): what the ratio would be if other processes
        took no CPU from either measurement, and both used the cores equally well."""
        return self.stats["rays_cast"] / self.cpu / self.raw_rays_per_cpu_second


def measure(case: Case) -> Measurement:
    """In a fresh process: load the case's scene, bake it timed, then bake it again traced
    between two samples of raw Embree throughput (so the raw figure sees the machine's load at
    two moments)."""
    scene = scenes.load(case.scene)
    peak_before = peak_resident()
    cpu, wall = cpu_seconds(), time.perf_counter()
    result = bake(scene, case.method, **case.knobs)
    wall, cpu = time.perf_counter() - wall, cpu_seconds() - cpu
    peak_after = peak_resident()
    stats = result.stats
    raw = RawEmbree(scene, stats["settings"], case.method)
    samples = [raw.sample()]
    tracemalloc.start()
    rerun = bake(scene, case.method, **case.knobs)
    traced_peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    samples.append(raw.sample())
    ray_seconds = sum(stats["seconds"].get(stage, 0.0) for stage in RAY_STAGES)
    return Measurement(
        case=case, stats=stats, wall=wall, cpu=cpu,
        bake_rays_per_second=stats["rays_cast"] / ray_seconds,
        raw_query=raw.query,
        raw_rays_per_second=RAW_RAYS / statistics.mean(seconds for seconds, _cpu in samples),
        raw_rays_per_cpu_second=RAW_RAYS * RAW_REPEATS / statistics.mean(cpu for _seconds, cpu in samples),
        traced_peak=traced_peak, peak_before=peak_before, peak_after=peak_after,
        repeatable=bool(np.array_equal(result.corner_colors, rerun.corner_colors)),
        emitting=(scene.emission > 0).any(axis=1),
        corner_colors=result.corner_colors,
        triangle_radiosity=result.triangle_radiosity,
    )


def errors(measurements: list[Measurement]) -> list[tuple[float, ...] | None]:
    """NRMSE of each bake against the reference bake of the same scene (None for the references):
    over the corners and the triangle means, of all triangles and of the non-emitting ones (an
    emitter's corners carry its emission, which can dominate the reference)."""
    references = {m.case.scene: m for m in measurements if m.case.reference}
    result: list[tuple[float, ...] | None] = []
    for m in measurements:
        reference = references[m.case.scene]
        lit = ~m.emitting
        result.append(None if m is reference else (
            nrmse(m.corner_colors, reference.corner_colors),
            nrmse(m.triangle_radiosity, reference.triangle_radiosity),
            nrmse(m.corner_colors[lit], reference.corner_colors[lit]),
            nrmse(m.triangle_radiosity[lit], reference.triangle_radiosity[lit]),
        ))
    return result


def _knobs(m: Measurement) -> str:
    """The method and the knobs the case gave bake()."""
    knobs = ", ".join(f"{key}={value:g}" if isinstance(value, float) else f"{key}={value}"
                      for key, value in m.case.knobs.items())
    return f"{m.case.method}" + (f", {knobs}" if knobs else " (defaults)")


def quality_table(measurements: list[Measurement]) -> str:
    """Settings, size of the discretisation, convergence and errors per bake."""
    rows = []
    for m, error in zip(measurements, errors(measurements)):
        s = m.stats
        rows.append([
            m.case.label, _knobs(m), f"{s['settings']['patch_size']:.4g}",
            f"{s['triangles']:,}", f"{s['patches']:,}", f"{s['nodes']:,}", f"{s['shots']:,}",
            f"{100 * s['unshot_fraction']:.3g} %",
            *(["reference"] * 4 if error is None else [f"{value:.4f}" for value in error]),
        ])
    return table(["bake", "method, knobs", "patch size", "triangles", "patches", "nodes", "shots", "unshot",
                  "NRMSE corners", "NRMSE triangle means", "NRMSE corners, non-emitting",
                  "NRMSE triangle means, non-emitting"], rows)


def speed_table(measurements: list[Measurement]) -> str:
    """Seconds per stage, wall and CPU time, and bake against raw Embree ray throughput."""
    rows = [[
        m.case.label, ", ".join(f"{stage} {seconds:.2f}" for stage, seconds in m.stats["seconds"].items()
                                if stage != "total"),
        f"{m.wall:.2f}", f"{m.cpu / m.wall:.2f}", f"{m.stats['rays_cast']:,}", f"{m.bake_rays_per_second / 1e6:.2f}",
        f"{m.raw_rays_per_second / 1e6:.2f} ({m.raw_query})", f"{100 * m.ratio:.0f} %", f"{100 * m.cpu_ratio:.0f} %",
    ] for m in measurements]
    return table(["bake", "seconds per stage", "wall s", "CPU s / wall s", "rays cast",
                  "bake Mrays/s", "raw Embree Mrays/s", "bake / raw", "bake / raw per CPU s"], rows)


def memory_table(measurements: list[Measurement]) -> str:
    """tracemalloc peak, the process's peak resident set, and the bake's own estimate, in MiB."""
    rows = [[
        m.case.label, f"{m.traced_peak / MIB:.1f}", f"{m.peak_after / MIB:.0f}",
        f"{(m.peak_after - m.peak_before) / MIB:+.0f}", f"{m.stats['peak_memory_estimate'] / MIB:.1f}",
        "yes" if m.repeatable else "NO",
    ] for m in measurements]
    return table(["bake", "tracemalloc peak MiB", "peak resident MiB", "peak resident over the loaded scene MiB",
                  "peak_memory_estimate MiB", "rerun identical"], rows)


def target_lines(measurements: list[Measurement], header: dict[str, str]) -> list[str]:
    """The project's stated targets, one pass/fail line each (per bake for the ray throughput)."""
    default = next(m for m in measurements if (m.case.scene, m.case.setting, m.case.method) == DEFAULT_CASE)
    free = " / ".join(value for key, value in header.items() if key.startswith("cores free"))
    lines = [
        f"- {_verdict(default.wall <= WALL_TARGET)} Cornell box at default quality in <= {WALL_TARGET:g} s wall "
        f"on 2 cores: {default.wall:.2f} s on {header['nproc']} cores ({free} free at the start / end, "
        f"CPU s / wall s {default.cpu / default.wall:.2f})"
    ]
    lines += [f"- {_verdict(m.ratio >= RAY_RATIO_TARGET)} ray casting inside the bake at "
              f">= {100 * RAY_RATIO_TARGET:.0f} % of raw Embree throughput: {m.case.label}: {100 * m.ratio:.0f} %"
              for m in measurements]
    return lines


def _verdict(passed: bool) -> str:
    return "PASS" if passed else "FAIL"


def report(measurements: list[Measurement], header: dict[str, str], minutes: float, quick: bool) -> str:
    """The whole report; ``header`` describes the machine and its load."""
    references = ", ".join(m.case.label for m in measurements if m.case.reference)
    about = ("`make bench` runs it too; `--quick` measures the Cornell box alone against a cheaper reference, into "
             "build/bench-quick/. The machine is shared and noisy: compare the ratios within one run, not absolute "
             "figures across runs.")
    return "\n".join([
        *markdown.opening("Benchmarks", STUDY, "--quick" if quick else "", minutes, quick, about, header),
        "",
        "## Scenes",
        "",
        *(f"- `{name}`: {text}." for name, text in scenes.DESCRIPTIONS.items()
          if any(m.case.scene == name for m in measurements)),
        "",
        "## How it is measured",
        "",
        "- Each bake runs in a fresh process: the scene is loaded, baked once timed (wall and process CPU time), "
        "then baked again under `tracemalloc` for the memory peak (tracing slows NumPy code, so it never times); "
        "the rerun must give identical corner colours.",
        f"- Errors are NRMSE (RMS of the difference / mean of the reference, bench/metrics.py) over every corner "
        f"colour (R, G, B of each corner of each input triangle) and over the triangle means, against the reference "
        f"bakes ({references}); again over the non-emitting triangles only, since an emitter's corners carry its "
        "emission, which can dominate the reference (the Cornell light: 17, 12, 4 against ~0.1 elsewhere). "
        "The Sponza reference is not converged (see its unshot fraction): its figures only say how much the "
        "longer bake moved the colours.",
        "- Bake Mrays/s: `stats[\"rays_cast\"]` over the seconds of the stages that cast rays (`form_factors`, "
        "`solve`, `gather`); those seconds include everything else the stages do (analytic form factors, the "
        "solver).",
        f"- Raw Embree Mrays/s: `core.rays.visibility.Visibility` built on the bake's own front patches, tracing one "
        f"batch of {RAW_RAYS:,} rays split across the bake's thread pool (`core.util.parallel`); the median of "
        f"{RAW_REPEATS} traces right after the timed bake and again after the rerun, averaged. Ray-cast bakes: "
        "OCCLUDED segments through `Visibility.occluded_unit`, built as `core.transport.raycast` builds them "
        f"(groups of {SHOOTERS} source patches drawn by area times random receiver patches, random points on both, "
        "facing pairs only, offset by RAY_EPSILON). Hemicube bakes: INTERSECT rays through `Visibility.nearest` "
        "from random points on patches into their hemisphere.",
        "- Bake / raw per CPU s: the same ratio from rays per CPU second (the whole bake's CPU time, all threads; "
        "the raw traces' CPU time). Other processes on the machine move it less than the wall-clock ratio, but it "
        "hides a bake that leaves a core idle (see CPU s / wall s, at most the number of cores).",
        "- Memory: `tracemalloc` peak of the rerun (NumPy arrays are traced; Embree's BVH is not); the process's "
        "peak resident set (VmHWM) after the timed bake, and its growth over the loaded scene; the bake's own "
        "`stats[\"peak_memory_estimate\"]`.",
        "",
        "## Quality",
        "",
        quality_table(measurements),
        "",
        "## Speed",
        "",
        speed_table(measurements),
        "",
        "## Memory",
        "",
        memory_table(measurements),
        "",
        "## Targets",
        "",
        *target_lines(measurements, header),
        "",
    ])


def main(argv: list[str]) -> int:
    """Measure every case and write the report."""
    parser = argparse.ArgumentParser(prog=f"python -m bench {STUDY}", description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="the Cornell box alone against a cheaper reference "
                        "(about a minute); writes into build/bench-quick/")
    options = parser.parse_args(argv)
    if scenes.missing():
        print(f"error: {scenes.missing()}", file=sys.stderr)
        return 2
    start = time.perf_counter()
    header = machine.opening()
    print(", ".join(f"{key}: {value}" for key, value in header.items()), flush=True)
    cases = QUICK_CASES if options.quick else CASES
    measurements = []
    for number, case in enumerate(cases, 1):
        print(f"[{number}/{len(cases)}] {case.label} ...", end=" ", flush=True)
        measurements.append(value_in_fresh_process(measure, case))
        print(f"bake {measurements[-1].wall:.2f} s; {time.perf_counter() - start:.0f} s so far", flush=True)
    header |= machine.closing(header)
    text = report(measurements, header, (time.perf_counter() - start) / 60, options.quick)
    markdown.write(text, reports(options.quick) / f"{STUDY}.md")
    return 0
