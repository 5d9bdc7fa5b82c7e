"""Speed against accuracy of bake(): each knob swept one at a time around the defaults, for each
method with each solver, plus the presets of core.settings (tradeoffs_plan.py), on scenes with an
exact answer (bench/exact.py) and on the benchmark scenes (bench/scenes.py) against a converged
reference, or where no bake of ours converges (Sponza) against path tracing at random corners
(bench/corner_answer.py); writes docs/results/tradeoffs.md and tradeoffs_*.png and prints each
scene's Pareto front.

``--quick`` runs a small sweep in about a minute, and it and ``--only`` write into
build/bench-quick/; ``--replot`` writes the report and figures again from the last run's records.
The references and those records are kept in build/bench/tradeoffs_cache/ (the references under
the digest of core/ at the start of the run that made them).

Every bake runs in a fresh process (bench/runner.py), so it starts without the thread pool or
Embree scene of an earlier bake: it loads its scene, bakes REPEATS times (once if the first bake
took over LONG_BAKE seconds) and the fastest counts; its memory is the growth of its peak resident
set (VmHWM, started again at its resident size just before the first bake) over that size: NumPy
arrays, Embree's BVH and the threads' stacks alike.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import pickle
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from bench import exact, machine, scenes
from bench.corner_answer import CornerAnswer, path_traced_corners, tracer_digest
from bench.metrics import nrmse, without_noise, worst_share
from bench.paths import BUILD, QUICK, RESULTS
from bench.runner import cpu_seconds, in_fresh_process, peak_resident, reset_peak, resident
from bench.studies import tradeoffs_plots, tradeoffs_report
from bench.studies.tradeoffs_plan import (
    FULL, QUICK as QUICK_SWEEPS, QUICK_REFERENCES, REFERENCES, PathTraced, Reference, Sweep, plan, print_plan,
    scene_of,
)
from bench.studies.tradeoffs_records import Answer, Case, Record, Run, pareto_front
from core import Scene, bake
from core.settings import AUTO_PATCH_DIVISIONS

STUDY = "tradeoffs"
CACHE = BUILD / "tradeoffs_cache"
REPEATS = 2
LONG_BAKE = 60.0  # seconds: a bake this long is timed once
WORST_SHARE = 0.05  # the records say how much of the squared error this fraction of the corners carries


@dataclass
class Target:
    """A scene and what its bakes are measured against: ``truth`` (T, 3, 3) values of the
    BakeResult array ``quantity`` at the corners ``compared`` (an index into the (T, 3) corners:
    a (T,) mask of triangles, all their corners, or a pair of (n,) arrays, triangles and corners);
    for a benchmark scene also ``truth_means`` (T, 3), the reference's triangle means
    (BakeResult.triangle_radiosity), and ``reference``, what the truth is: the reference bake's
    record, or the path-traced answer's summary (without triangle means), None where the truth is
    exact; ``truth_noise``: the truth's own noise (relative RMS), removed from every error in
    quadrature."""

    scene: Scene
    quantity: str
    compared: np.ndarray | tuple[np.ndarray, np.ndarray]
    truth: np.ndarray | None = None
    truth_means: np.ndarray | None = None
    reference: Record | Answer | None = None
    truth_noise: float = 0.0


# Running a bake.

def bake_case(case: Case, quantity: str, repeats: int) -> dict:
    """In a fresh process: bake ``case`` up to ``repeats`` times (once if the first took over
    LONG_BAKE s); the wall and CPU seconds of each, the peak memory growth (bytes), the stats of
    the last bake, its corner values of ``quantity`` (a BakeResult array) and its triangle means."""
    scene = scene_of(case.scene)
    before = resident()
    reset_peak()
    walls, cpus = [], []
    for _ in range(repeats):
        cpu, start = cpu_seconds(), time.perf_counter()
        result = bake(scene, case.method, case.solver, **dict(case.knobs))
        walls.append(time.perf_counter() - start)
        cpus.append(cpu_seconds() - cpu)
        if walls[0] > LONG_BAKE:
            break
    return {"walls": tuple(walls), "cpu": cpus[int(np.argmin(walls))], "peak": peak_resident() - before,
            "stats": result.stats, "values": getattr(result, quantity), "means": result.triangle_radiosity}


def measure_case(case: Case, quantity: str, repeats: int, timeout: float) -> tuple[Record, dict | None]:
    """Measure ``case`` in a fresh process: its record, and what ``bake_case`` returned (None if it failed)."""
    outcome = in_fresh_process(bake_case, case, quantity, repeats, timeout=timeout)
    if not outcome.ok:
        return Record(case, status=outcome.status), None
    answer = outcome.value
    return Record(case, walls=answer["walls"], cpu=answer["cpu"], peak=answer["peak"], stats=answer["stats"]), answer


def score(record: Record, answer: dict, target: Target) -> None:
    """Set the record's errors: NRMSE (bench/metrics.py: RMS of the difference over the mean of
    the truth, its noise removed in quadrature) over R, G and B of every compared corner, the share
    of its square that the worst WORST_SHARE of those corners carry, and, against a reference, the
    NRMSE of the compared triangles' means."""
    compared = target.compared
    values, truth = answer["values"][compared], target.truth[compared]
    record.error = without_noise(nrmse(values, truth), target.truth_noise)
    squares = ((values - truth) ** 2).sum(axis=-1)
    record.worst_share = worst_share(squares, max(1, round(WORST_SHARE * squares.size)))
    if target.truth_means is not None:
        record.mean_error = nrmse(answer["means"][compared], target.truth_means[compared])


# References.

def reference_case(name: str, scene: Scene, reference: Reference) -> Case:
    """The reference bake as a case."""
    knobs = dict(reference.knobs) | {"patch_size": scene.extent / reference.divisions}
    return Case(name, reference.method, reference.solver, tuple(sorted(knobs.items())), reference.divisions,
                ("reference",))


def cache_path(scene: str, what: object, core: str) -> Path:
    """Where the truth of ``scene`` made as ``what`` (a repr-able description) by the core of
    digest ``core`` is kept; the truths of other cores are deleted."""
    for stale in CACHE.glob(f"{scene}-*.npz"):
        if f"-{core}-" not in stale.name:
            stale.unlink()
    return CACHE / f"{scene}-{core}-{hashlib.sha1(repr(what).encode()).hexdigest()[:12]}.npz"


def cached_reference(case: Case, target: Target, timeout: float, core: str) -> tuple[Record, dict]:
    """The reference bake's record and its corner values and triangle means, from CACHE if this
    core baked it before (the record's status then says "cached")."""
    path = cache_path(case.scene, case.key, core)
    if path.exists():
        with np.load(path) as stored:
            saved = json.loads(str(stored["record"]))
            record = Record(case, walls=tuple(saved["walls"]), cpu=saved["cpu"], peak=saved["peak"],
                            stats=saved["stats"], status="cached")
            return record, {"values": stored["values"], "means": stored["means"]}
    record, answer = measure_case(case, target.quantity, 1, timeout)
    if answer is None:
        raise RuntimeError(f"the {case.scene} reference bake {record.status}")
    CACHE.mkdir(parents=True, exist_ok=True)
    saved = {"walls": record.walls, "cpu": record.cpu, "peak": record.peak, "stats": record.stats}
    np.savez_compressed(path, values=answer["values"], means=answer["means"],
                        record=json.dumps(saved, default=_plain))
    return record, answer


def cached_answer(name: str, scene: Scene, traced: PathTraced, core: str) -> CornerAnswer:
    """The path-traced answer at random corners of scene ``name`` (at the default patch size's
    nodes), from CACHE if this core and this path tracer traced it before, else traced in a fresh
    process."""
    path = cache_path(name, (traced, tracer_digest()), core)
    if path.exists():
        with np.load(path) as stored:
            return CornerAnswer(**{key: stored[key] for key in stored.files if key != "seconds"},
                                seconds=float(stored["seconds"]))
    outcome = in_fresh_process(path_traced_corners, scene, scene.extent / AUTO_PATCH_DIVISIONS, traced.corners,
                               traced.paths, timeout=traced.timeout)
    if not outcome.ok:
        raise RuntimeError(f"the {name} path tracing {outcome.status}")
    CACHE.mkdir(parents=True, exist_ok=True)
    np.savez_compressed(path, **vars(outcome.value))
    return outcome.value


def _plain(value):
    """NumPy scalars and arrays as Python numbers and lists, for JSON."""
    return value.tolist() if hasattr(value, "tolist") else str(value)


# The run.

def load_targets(sweeps: dict[str, Sweep]) -> dict[str, Target]:
    """The scenes of ``sweeps``: the exact problems with their truth, the benchmark scenes
    comparing corner colours of their non-emitting triangles (truth to come)."""
    targets = {}
    for name in sweeps:
        if name in exact.PROBLEMS:
            problem = exact.PROBLEMS[name]()
            targets[name] = Target(problem.scene, problem.quantity, problem.compared, problem.truth)
        else:
            scene = scenes.load(name)
            targets[name] = Target(scene, "corner_colors", ~(scene.emission > 0).any(axis=1))
    return targets


def find_truth(name: str, target: Target, reference: Reference | PathTraced, core: str) -> None:
    """Set a benchmark scene's truth: its converged reference bake, or path tracing at random corners."""
    if isinstance(reference, PathTraced):
        print(f"{name}: path tracing at {reference.corners:,} corners ...", flush=True)
        traced = cached_answer(name, target.scene, reference, core)
        target.compared = traced.triangles, traced.corners
        target.truth = np.zeros((len(target.scene.triangles), 3, traced.radiosity.shape[1]))
        target.truth[target.compared] = traced.radiosity
        target.truth_noise = traced.noise
        target.reference = Answer(reference.corners, reference.paths, traced.noise, traced.seconds)
        return
    print(f"{name}: reference bake ...", flush=True)
    record, answer = cached_reference(reference_case(name, target.scene, reference), target, reference.timeout, core)
    target.truth, target.truth_means, target.reference = answer["values"], answer["means"], record


def sweep_scene(name: str, sweep: Sweep, target: Target, repeats: int, clock: float) -> list[Record]:
    """Measure every case of the scene's plan, printing a line per bake."""
    cases, skipped = plan(name, target.scene, sweep)
    records = []
    for number, case in enumerate(cases, 1):
        record, answer = measure_case(case, target.quantity, repeats, sweep.timeout)
        if answer is not None:
            score(record, answer, target)
        records.append(record)
        outcome = f"{record.wall:.2f} s, error {record.error:.3g}" if record.ok else record.status
        print(f"  [{number}/{len(cases)}] {case.combo} {', '.join(case.tags)}: {outcome} "
              f"({time.perf_counter() - clock:.0f} s so far)", flush=True)
    return records + skipped


def measure_all(sweeps: dict[str, Sweep], targets: dict[str, Target], references: dict, quick: bool) -> Run:
    """Bake every scene's references and cases, printing as it goes."""
    clock = time.perf_counter()
    header = machine.opening()
    core = header[machine.CORE_LINE.format(moment="start")]
    print(", ".join(f"{key}: {value}" for key, value in header.items()), flush=True)
    for name, reference in references.items():
        if name in targets:
            find_truth(name, targets[name], reference, core)
    results = {}
    for name, sweep in sweeps.items():
        print(f"{name}: {tradeoffs_report.describe(name)}", flush=True)
        results[name] = sweep_scene(name, sweep, targets[name], 1 if quick else REPEATS, clock)
    header |= machine.closing(header)
    return Run(results, {name: t.reference for name, t in targets.items() if t.reference is not None},
               {name: targets[name].quantity for name in sweeps}, header, (time.perf_counter() - clock) / 60, quick)


def write(run: Run, output: Path) -> None:
    """The report and its figures, into ``output``; the notes on each scene's sweep come from
    the plan (QUICK or FULL)."""
    output.mkdir(parents=True, exist_ok=True)
    figures = tradeoffs_plots.write_all(run.results, output, estimated=tradeoffs_report.estimated_scenes(run))
    notes = {name: sweep.note for name, sweep in (QUICK_SWEEPS if run.quick else FULL).items()}
    (output / f"{STUDY}.md").write_text(tradeoffs_report.markdown(run, notes, figures))
    for name, records in run.results.items():
        print(f"Pareto front, {name} (wall s, error, settings):")
        for record in pareto_front(records):
            print(f"  {record.wall:8.3f}  {record.error:.3g}  {tradeoffs_report.settings(record)}")
    print(f"wrote {output / f'{STUDY}.md'} and {len(figures)} figures; the run took {run.minutes:.1f} minutes")


def main(argv: list[str]) -> int:
    """Sweep every scene (or re-draw the last sweep), write the report and figures, print the
    Pareto fronts."""
    parser = argparse.ArgumentParser(prog=f"python -m bench {STUDY}", description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="a small sweep (about a minute) into build/bench-quick/")
    parser.add_argument("--only", nargs="+", metavar="SCENE", help="sweep only these scenes, into build/bench-quick/")
    parser.add_argument("--list", action="store_true", help="print the bakes the sweep would measure, and stop")
    parser.add_argument("--replot", action="store_true",
                        help="write the report and figures again from the last run's records, baking nothing")
    args = parser.parse_args(argv)
    development = args.quick or bool(args.only)
    output = QUICK if development else RESULTS
    saved = CACHE / f"last_run_{'quick' if development else 'results'}.pkl"
    if args.replot:
        write(pickle.loads(saved.read_bytes()), output)
        return 0
    if scenes.missing():
        print(f"error: {scenes.missing()}", file=sys.stderr)
        return 2
    sweeps, references = (QUICK_SWEEPS, QUICK_REFERENCES) if args.quick else (FULL, REFERENCES)
    sweeps = {name: sweep for name, sweep in sweeps.items() if not args.only or name in args.only}
    targets = load_targets(sweeps)
    if args.list:
        print_plan(sweeps, {name: target.scene for name, target in targets.items()})
        return 0
    run = measure_all(sweeps, targets, references, args.quick)
    CACHE.mkdir(parents=True, exist_ok=True)
    saved.write_bytes(pickle.dumps(run))
    write(run, output)
    return 0
