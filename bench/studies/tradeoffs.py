"""Speed against accuracy of bake(): each knob swept one at a time around the defaults, for each
method with each solver, plus the presets of core.settings, on scenes with an exact answer
(bench/exact.py) and on the benchmark scenes (bench/scenes.py) against a converged reference, or
where no bake of ours converges (Sponza) against path tracing at random corners (bench/corner_answer.py);
writes docs/tradeoffs.md and docs/tradeoffs_*.png and prints each scene's Pareto front.

Run from the repository root: ``.venv/bin/python bench/sweep.py`` (``make bench`` runs it after
bench/run.py); ``--quick`` runs a small sweep in under a minute, and it and ``--only`` write to
build/tradeoffs_dev/ instead of docs/; ``--replot`` writes the report and figures again from the
last run's records. The references and those records are kept in build/tradeoffs_cache/ (the
references under a digest of core/*.py).

Every bake runs in a child forked from this process after the scenes are loaded (the parent never
bakes, so the child starts without a thread pool or Embree scene of an earlier bake): the child
bakes REPEATS times (once if the first bake took over LONG_BAKE seconds) and the fastest counts;
its memory is the growth of the child's peak resident set (ru_maxrss, which Linux starts at the
child's resident size at the fork) over its resident size before the first bake: NumPy arrays,
Embree's BVH and the threads' stacks alike. All bakes of a run use the core/ that was imported
when the run started, even if the files change meanwhile.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import multiprocessing
import os
import pickle
import resource
import sys
import time
import traceback
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))

import exact  # noqa: E402  (bench/ is the script's directory, so its modules import by name)
import machine  # noqa: E402
import plots  # noqa: E402
import report  # noqa: E402
import scenes  # noqa: E402
import tradeoff_doc  # noqa: E402
from corner_answer import CornerAnswer, path_traced_corners  # noqa: E402
from cycles_metrics import without_noise  # noqa: E402
from records import COMBOS, Answer, Case, Record, Run, pareto_front  # noqa: E402

from core import BakeSettings, Scene, bake  # noqa: E402
from core.bake import AUTO_PATCH_DIVISIONS  # noqa: E402
from core.mesh.discretize import discretize  # noqa: E402
from core.settings import (  # noqa: E402
    LARGE_SCENE_MONTE_CARLO_RAYS, LARGE_SCENE_TRIANGLES, PRESETS, preset_knobs,
)

CORE = machine.core_digest()  # the core this run imported
DOCS = REPO / "docs"
DEV_OUTPUT = REPO / "build" / "tradeoffs_dev"  # where --quick and --only write
CACHE = REPO / "build" / "tradeoffs_cache"
REPEATS = 2
LONG_BAKE = 60.0  # seconds: a bake this long is timed once
WORST_SHARE = 0.05  # the records say how much of the squared error this fraction of the corners carries
ONLY_FOR = {"hemicube_resolution": "hemicube", "rays_per_form_factor": "raycast"}  # knobs of one method


@dataclass(frozen=True)
class Sweep:
    """How one scene is swept: the values of each knob (``divisions``: patch size = extent / d),
    each varied alone from the defaults; the method/solver pairs; the solvers that only sweep the
    tolerance (Gauss-Seidel's form factors are Jacobi's, so its other curves would repeat
    Jacobi's); the presets; knobs every bake of the scene gets (``base``); the most patches an
    explicit solver (a P x P matrix) is given; the seconds after which a bake is stopped; and what
    the report should say about the choices."""

    divisions: tuple[int, ...] = (4, 8, 12, 16)
    values: dict = field(default_factory=lambda: {
        "hemicube_resolution": (16, 32, 64, 128),
        "rays_per_form_factor": (1, 4, 16, 64),
        "tolerance": (1e-1, 1e-2, 1e-3, 1e-4),
        "refinement_levels": (1, 2, 3),
        "merge_flat": (False,),
    })
    combos: tuple[tuple[str, str], ...] = COMBOS
    tolerance_only: tuple[str, ...] = ("gauss_seidel",)
    presets: tuple[str, ...] = ("DRAFT", "PREVIEW", "PRODUCTION", "REFERENCE")
    base: tuple[tuple[str, float], ...] = ()
    explicit_patches: int = 4000
    timeout: float = 300.0
    note: str = ""


@dataclass(frozen=True)
class Reference:
    """The converged reference of a benchmark scene: the project itself at extreme settings."""

    method: str
    solver: str
    divisions: int
    knobs: tuple[tuple[str, float], ...]
    timeout: float = 1200.0


@dataclass(frozen=True)
class PathTraced:
    """The answer of a benchmark scene where no bake of ours converges in minutes: path tracing at
    ``corners`` random corners, ``paths`` paths each (bench/corner_answer.py)."""

    corners: int
    paths: int
    timeout: float = 1200.0


FULL = {
    "furnace": Sweep(
        divisions=(2, 4, 8), values={"hemicube_resolution": (16, 32, 64, 128), "tolerance": (1e-1, 1e-2, 1e-3, 1e-4)},
        presets=("DRAFT", "PREVIEW", "PRODUCTION"),
        note="Not swept: the rays (nothing occludes, so every visibility is 1 whatever the rays) and refinement "
        "(the radiosity is uniform, so no patch is split); the REFERENCE preset (tens of seconds a bake) is left out."),
    "parallel_squares": Sweep(
        divisions=(2, 4, 8, 16), values={"hemicube_resolution": (16, 32, 64, 128), "tolerance": (1e-1, 1e-2, 1e-3, 1e-4)},
        note="Not swept: the rays (nothing occludes) and refinement."),
    "cie_room": Sweep(
        divisions=(2, 4, 8), values={"hemicube_resolution": (16, 32, 64, 128), "refinement_levels": (1, 2)},
        presets=("DRAFT", "PREVIEW", "PRODUCTION"),
        note="Not swept: the rays (nothing occludes) and the tolerance (black walls: all light is shot in the "
        "source's first shots); the REFERENCE preset (a minute a bake) is left out."),
    "cornell": Sweep(presets=("DRAFT", "PREVIEW", "PRODUCTION"), explicit_patches=2500,
                     note="The REFERENCE preset (patches of extent / 16) is the `patch extent / 16` bake with a "
                     "tolerance of 1e-4 instead of 1e-3 (which the tolerance rows show does not matter here), so it "
                     "is not baked again. Explicit "
                     "solvers stop at patch size extent / 12 (2,318 patches before refinement)."),
    "sponza": Sweep(
        divisions=(4, 16), values={"monte_carlo_rays": (16, 256, 1024), "rays_per_form_factor": (1, 16),
                                   "max_shots": (300,), "near_field": (False,)},
        combos=(("raycast", "progressive"),), presets=(),
        base=(("monte_carlo_rays", LARGE_SCENE_MONTE_CARLO_RAYS), ("rays_per_form_factor", 4)), timeout=900.0,
        note="Sponza is large for these methods: shooting to convergence takes about a shot per patch, each to "
        "every patch and vertex, hours here. So every bake is what the add-on does by default from "
        f"{LARGE_SCENE_TRIANGLES:,} triangles on (Monte Carlo \"Auto\", core/presets.py): the emitters shoot, "
        "and the light they leave goes on by Monte Carlo (particles from the patches, then a final gather at the "
        f"vertices: core/montecarlo.py) with {LARGE_SCENE_MONTE_CARLO_RAYS} gather rays per vertex unless swept, "
        "and 4 rays per form factor unless swept (as docs/sponza.md). `max_shots`: the brightest patches shoot "
        "too, this many shots in all, before Monte Carlo takes the rest. `near_field` off: every patch is read "
        "as its mean. The patch size changes only the largest triangles (patches are never larger than the "
        "input triangles and their pieces). Left out: Jacobi and Gauss-Seidel (a P x P matrix, hundreds of GB); "
        "the hemicube, whose gather at the vertices alone takes minutes here (dense rows, O(vertices x "
        "patches)); the presets, whose tolerances no bake reaches in minutes. The yardstick is not a bake of "
        "ours but path tracing at random corners (above), so these errors are against the scene's light, as "
        "docs/path_traced.md measures Cycles' bakes and ours."),
}
QUICK = {
    "parallel_squares": Sweep(divisions=(2, 4), values={"hemicube_resolution": (16,), "rays_per_form_factor": (4,),
                                                        "tolerance": (1e-2,)},
                              combos=(("raycast", "progressive"), ("hemicube", "jacobi")), presets=("DRAFT",)),
    "furnace": Sweep(divisions=(4,), values={"tolerance": (1e-2,)},
                     combos=(("raycast", "progressive"), ("raycast", "jacobi")), presets=()),
    "cornell": Sweep(divisions=(4,), values={"tolerance": (1e-2,)}, combos=(("raycast", "progressive"),),
                     presets=("DRAFT",)),
}
REFERENCES = {
    "cornell": Reference("raycast", "jacobi", 24, (("probe_rays", False), ("rays_per_form_factor", 16),
                                                   ("tolerance", 1e-6))),
    # no bake of ours converges on Sponza: 32,000 paths at 1,000 corners cost what 80,000 at 400 do
    # (0.56 % of noise in about 100 s: docs/path_traced.md), for 0.56 x sqrt(80 / 32) = 0.9 % of noise
    # over 2.5 times the corners
    "sponza": PathTraced(corners=1000, paths=32_000),
}
QUICK_REFERENCES = {
    "cornell": Reference("raycast", "jacobi", 4, (("rays_per_form_factor", 16), ("tolerance", 1e-6))),
}


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


TARGETS: dict[str, Target] = {}  # filled before any fork, so the children inherit the scenes


# The plan.

def uses(method: str, knob: str) -> bool:
    """Whether bakes by ``method`` depend on ``knob`` (in scenes without lights or sky)."""
    return ONLY_FOR.get(knob, method) == method


def make_case(name: str, scene: Scene, method: str, solver: str, divisions: int, knobs: dict,
              sweep: Sweep, tag: str) -> Case:
    """A case with the patch size extent / ``divisions``, the scene's base knobs and ``knobs``,
    less those at bake()'s defaults (so that the same bake is one case, whatever it is called)."""
    settings = BakeSettings()
    chosen = {key: value for key, value in (dict(sweep.base) | knobs).items() if getattr(settings, key) != value}
    every = chosen | {"patch_size": scene.extent / divisions}
    return Case(name, method, solver, tuple(sorted(every.items())), divisions, (tag,))


def variations(method: str, solver: str, sweep: Sweep) -> list[tuple[str, int, dict]]:
    """(tag, divisions, knobs) of the defaults, of each knob varied alone, and of each preset."""
    tolerance_only = solver in sweep.tolerance_only
    result = [("default", AUTO_PATCH_DIVISIONS, {})]
    if not tolerance_only:
        result += [("patch_size", divisions, {}) for divisions in sweep.divisions]
    for knob, values in sweep.values.items():
        if uses(method, knob) and (knob == "tolerance" or not tolerance_only):
            result += [(knob, AUTO_PATCH_DIVISIONS, {knob: value}) for value in values]
    for name in sweep.presets:
        knobs = {key: value for key, value in preset_knobs(name, 1.0).items()
                 if key != "patch_size" and uses(method, key)}
        result.append((f"preset:{name}", PRESETS[name].patch_divisions, knobs))
    return result


def plan(name: str, scene: Scene, sweep: Sweep) -> tuple[list[Case], list[Record]]:
    """The scene's cases, each bake once with all its tags; and the explicit-solver cases left out
    because their matrix would have more than ``sweep.explicit_patches`` rows."""
    cases: dict[tuple, Case] = {}
    patches: dict[int, int] = {}
    skipped = []
    for method, solver in sweep.combos:
        for tag, divisions, knobs in variations(method, solver, sweep):
            case = make_case(name, scene, method, solver, divisions, knobs, sweep, tag)
            if case.key in cases:
                previous = cases[case.key]
                cases[case.key] = Case(*case.key, divisions, previous.tags + (tag,) * (tag not in previous.tags))
                continue
            if solver != "progressive":
                count = patches.setdefault(divisions, discretize(scene, scene.extent / divisions).patch_count)
                if count > sweep.explicit_patches:
                    skipped.append(Record(case, status=f"skipped: a {count:,} x {count:,} matrix"))
                    continue
            cases[case.key] = case
    return list(cases.values()), skipped


# Running a bake in a forked child.

def in_child(function: Callable, args: tuple, timeout: float) -> tuple[str, object]:
    """("ok", function(*args)) computed in a child forked from this process; ("failed: ...",
    None) if it raised, ("timed out", None) if it took over ``timeout`` seconds (it is killed)."""
    context = multiprocessing.get_context("fork")
    receiver, sender = context.Pipe(duplex=False)
    child = context.Process(target=_answer, args=(sender, function, args), daemon=True)
    child.start()
    sender.close()
    try:
        if not receiver.poll(timeout):
            child.kill()
            return "timed out", None
        return receiver.recv()
    except EOFError:
        child.join()
        return f"failed: the bake process died (exit code {child.exitcode})", None
    finally:
        child.join()
        receiver.close()


def _answer(sender, function: Callable, args: tuple) -> None:
    """Send back ("ok", the result) or ("failed: <last line of the traceback>", None)."""
    try:
        answer = ("ok", function(*args))
    except BaseException:  # noqa: BLE001 (reported to the parent, which carries on)
        answer = ("failed: " + traceback.format_exc().strip().splitlines()[-1], None)
    sender.send(answer)
    sender.close()


def measure(case: Case, repeats: int) -> dict:
    """In the child: bake ``case`` up to ``repeats`` times (once if the first took over
    LONG_BAKE s); the wall and CPU seconds of each, the peak memory growth (bytes), the stats of
    the last bake, its corner values of the target's quantity and its triangle means."""
    target = TARGETS[case.scene]
    before = _resident()
    walls, cpus = [], []
    for _ in range(repeats):
        cpu, start = _cpu_seconds(), time.perf_counter()
        result = bake(target.scene, case.method, case.solver, **dict(case.knobs))
        walls.append(time.perf_counter() - start)
        cpus.append(_cpu_seconds() - cpu)
        if walls[0] > LONG_BAKE:
            break
    return {"walls": tuple(walls), "cpu": cpus[int(np.argmin(walls))], "peak": _max_resident() - before,
            "stats": result.stats, "values": getattr(result, target.quantity), "means": result.triangle_radiosity}


def _resident() -> int:
    """This process's resident set size now, in bytes."""
    return int(Path("/proc/self/statm").read_text().split()[1]) * os.sysconf("SC_PAGE_SIZE")


def _max_resident() -> int:
    """This process's peak resident set size so far, in bytes (Linux reports KiB)."""
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024


def _cpu_seconds() -> float:
    """User plus system CPU time of this process, all threads."""
    usage = resource.getrusage(resource.RUSAGE_SELF)
    return usage.ru_utime + usage.ru_stime


def run(case: Case, repeats: int, timeout: float) -> tuple[Record, dict | None]:
    """Measure ``case`` in a child: its record, and what ``measure`` returned (None if it failed)."""
    status, answer = in_child(measure, (case, repeats), timeout)
    if answer is None:
        return Record(case, status=status), None
    return Record(case, walls=answer["walls"], cpu=answer["cpu"], peak=answer["peak"], stats=answer["stats"]), answer


def score(record: Record, answer: dict, target: Target) -> None:
    """Set the record's errors: NRMSE (report.nrmse: RMS of the difference over the mean of the
    truth, its noise removed in quadrature) over R, G and B of every compared corner, the share of its square
    that the worst WORST_SHARE of those corners carry, and, against a reference, the NRMSE of the
    compared triangles' means."""
    compared = target.compared
    values, truth = answer["values"][compared], target.truth[compared]
    record.error = without_noise(report.nrmse(values, truth, scale="mean"), target.truth_noise)
    squares = np.sort(((values - truth) ** 2).sum(axis=-1).ravel())[::-1]
    worst = max(1, round(WORST_SHARE * len(squares)))
    record.worst_share = float(squares[:worst].sum() / squares.sum()) if squares.sum() > 0 else 0.0
    if target.truth_means is not None:
        record.mean_error = report.nrmse(answer["means"][compared], target.truth_means[compared], scale="mean")


# References.

def reference_case(name: str, scene: Scene, reference: Reference) -> Case:
    """The reference bake as a case."""
    knobs = dict(reference.knobs) | {"patch_size": scene.extent / reference.divisions}
    return Case(name, reference.method, reference.solver, tuple(sorted(knobs.items())), reference.divisions,
                ("reference",))


def cache_path(scene: str, what: object) -> Path:
    """Where this core's truth of ``scene`` made as ``what`` (a repr-able description) is kept;
    the truths of other cores are deleted."""
    for stale in CACHE.glob(f"{scene}-*.npz"):
        if f"-{CORE}-" not in stale.name:
            stale.unlink()
    return CACHE / f"{scene}-{CORE}-{hashlib.sha1(repr(what).encode()).hexdigest()[:12]}.npz"


def cached_reference(case: Case, timeout: float) -> tuple[Record, dict]:
    """The reference bake's record and its corner values and triangle means, from CACHE if this
    core baked it before (the record's status then says "cached")."""
    path = cache_path(case.scene, case.key)
    if path.exists():
        with np.load(path) as stored:
            saved = json.loads(str(stored["record"]))
            record = Record(case, walls=tuple(saved["walls"]), cpu=saved["cpu"], peak=saved["peak"],
                            stats=saved["stats"], status="cached")
            return record, {"values": stored["values"], "means": stored["means"]}
    record, answer = run(case, 1, timeout)
    if answer is None:
        raise RuntimeError(f"the {case.scene} reference bake {record.status}")
    CACHE.mkdir(parents=True, exist_ok=True)
    saved = {"walls": record.walls, "cpu": record.cpu, "peak": record.peak, "stats": record.stats}
    np.savez_compressed(path, values=answer["values"], means=answer["means"],
                        record=json.dumps(saved, default=_plain))
    return record, answer


def cached_answer(name: str, traced: PathTraced) -> CornerAnswer:
    """The path-traced answer at random corners of scene ``name`` (at the default patch size's
    nodes), from CACHE if this core traced it before, else traced in a child (which, as a bake's,
    starts without the thread pool or Embree scene of the parent)."""
    path = cache_path(name, traced)
    if path.exists():
        with np.load(path) as stored:
            return CornerAnswer(**{key: stored[key] for key in stored.files if key != "seconds"},
                                seconds=float(stored["seconds"]))
    scene = TARGETS[name].scene
    status, answer = in_child(path_traced_corners, (scene, scene.extent / AUTO_PATCH_DIVISIONS, traced.corners,
                                                    traced.paths), traced.timeout)
    if answer is None:
        raise RuntimeError(f"the {name} path tracing {status}")
    CACHE.mkdir(parents=True, exist_ok=True)
    np.savez_compressed(path, **vars(answer))
    return answer


def _plain(value):
    """NumPy scalars and arrays as Python numbers and lists, for JSON."""
    return value.tolist() if hasattr(value, "tolist") else str(value)


# Targets.

def load_targets(sweeps: dict[str, Sweep]) -> None:
    """Fill TARGETS with the scenes of ``sweeps``: the exact problems with their truth, the
    benchmark scenes comparing corner colours of their non-emitting triangles (truth to come)."""
    for name in sweeps:
        if name in exact.PROBLEMS:
            problem = exact.PROBLEMS[name]()
            TARGETS[name] = Target(problem.scene, problem.quantity, problem.compared, problem.truth)
        else:
            scene = scenes.LOADERS[name]()
            TARGETS[name] = Target(scene, "corner_colors", ~(scene.emission > 0).any(axis=1))


# The run.

def sweep_scene(name: str, sweep: Sweep, repeats: int, clock: float) -> list[Record]:
    """Measure every case of the scene's plan, printing a line per bake."""
    target = TARGETS[name]
    cases, skipped = plan(name, target.scene, sweep)
    records = []
    for number, case in enumerate(cases, 1):
        record, answer = run(case, repeats, sweep.timeout)
        if answer is not None:
            score(record, answer, target)
        records.append(record)
        outcome = f"{record.wall:.2f} s, error {record.error:.3g}" if record.ok else record.status
        print(f"  [{number}/{len(cases)}] {case.combo} {', '.join(case.tags)}: {outcome} "
              f"({time.perf_counter() - clock:.0f} s so far)", flush=True)
    return records + skipped


def print_plan(sweeps: dict[str, Sweep]) -> None:
    """The cases of every scene, and those left out."""
    for name, sweep in sweeps.items():
        cases, skipped = plan(name, TARGETS[name].scene, sweep)
        print(f"{name}: {len(cases)} bakes, {len(skipped)} left out")
        for case in cases:
            print(f"  {case.combo}: " + ", ".join(f"{key} {value:g}" for key, value in case.knobs) + f" [{', '.join(case.tags)}]")
        for record in skipped:
            print(f"  {record.case.combo} {', '.join(record.case.tags)}: {record.status}")


def print_fronts(results: dict[str, list[Record]]) -> None:
    """Each scene's Pareto front, fastest first."""
    for name, records in results.items():
        print(f"Pareto front, {name} (wall s, error, settings):")
        for record in pareto_front(records):
            print(f"  {record.wall:8.3f}  {record.error:.3g}  {tradeoff_doc.settings(record)}")


def measure_all(sweeps: dict[str, Sweep], references: dict[str, Reference], quick: bool) -> Run:
    """Bake every scene's references and cases (TARGETS loaded), printing as it goes."""
    clock = time.perf_counter()
    header = machine.machine() | tradeoff_doc.load("start", not quick)
    print(", ".join(f"{key}: {value}" for key, value in header.items()), flush=True)
    for name, reference in references.items():
        if name not in TARGETS:
            continue
        target = TARGETS[name]
        if isinstance(reference, PathTraced):
            print(f"{name}: path tracing at {reference.corners:,} corners ...", flush=True)
            traced = cached_answer(name, reference)
            target.compared = traced.triangles, traced.corners
            target.truth = np.zeros((len(target.scene.triangles), 3, traced.radiosity.shape[1]))
            target.truth[target.compared] = traced.radiosity
            target.truth_noise = traced.noise
            target.reference = Answer(reference.corners, reference.paths, traced.noise, traced.seconds)
            continue
        print(f"{name}: reference bake ...", flush=True)
        record, answer = cached_reference(reference_case(name, target.scene, reference), reference.timeout)
        target.truth, target.truth_means, target.reference = answer["values"], answer["means"], record
    results = {}
    for name, sweep in sweeps.items():
        print(f"{name}: {tradeoff_doc.describe(name)}", flush=True)
        results[name] = sweep_scene(name, sweep, 1 if quick else REPEATS, clock)
    header |= tradeoff_doc.load("end", not quick) | {"core/*.py SHA-1 of the files at the end": machine.core_digest()}
    return Run(results, {name: t.reference for name, t in TARGETS.items() if t.reference is not None},
               {name: TARGETS[name].quantity for name in sweeps}, header, CORE, (time.perf_counter() - clock) / 60,
               quick)


def write(run: Run, output: Path) -> None:
    """docs/tradeoffs.md (or its development twin) and its figures, into ``output``; the notes on
    each scene's sweep come from this code (QUICK or FULL)."""
    output.mkdir(parents=True, exist_ok=True)
    figures = plots.write_all(run.results, output, estimated=tradeoff_doc.estimated_scenes(run))
    notes = {name: sweep.note for name, sweep in (QUICK if run.quick else FULL).items()}
    (output / "tradeoffs.md").write_text(tradeoff_doc.markdown(run, notes, figures))
    print_fronts(run.results)
    print(f"wrote {output / 'tradeoffs.md'} and {len(figures)} figures; the run took {run.minutes:.1f} minutes")


def main(argv: list[str] | None = None) -> int:
    """Sweep every scene (or re-draw the last sweep), write the tables and plots, print the Pareto
    fronts."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="a small sweep (< 1 min) into build/tradeoffs_dev/")
    parser.add_argument("--only", nargs="+", metavar="SCENE", help="sweep only these scenes, into build/tradeoffs_dev/")
    parser.add_argument("--list", action="store_true", help="print the bakes the sweep would measure, and stop")
    parser.add_argument("--replot", action="store_true",
                        help="write the report and figures again from the last run's records, baking nothing")
    args = parser.parse_args(argv)
    development = args.quick or bool(args.only)
    output = DEV_OUTPUT if development else DOCS
    saved = CACHE / f"last_run_{'dev' if development else 'docs'}.pkl"
    if args.replot:
        write(pickle.loads(saved.read_bytes()), output)
        return 0
    if not scenes.SCENES.is_dir():
        print(f"error: no scenes at {scenes.SCENES.resolve()} (shared/ must sit beside the repository)", file=sys.stderr)
        return 2
    sweeps, references = (QUICK, QUICK_REFERENCES) if args.quick else (FULL, REFERENCES)
    sweeps = {name: sweep for name, sweep in sweeps.items() if not args.only or name in args.only}
    load_targets(sweeps)
    if args.list:
        print_plan(sweeps)
        return 0
    run = measure_all(sweeps, references, args.quick)
    CACHE.mkdir(parents=True, exist_ok=True)
    saved.write_bytes(pickle.dumps(run))
    write(run, output)
    return 0


if __name__ == "__main__":
    sys.exit(main())
