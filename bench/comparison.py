"""What the studies against Cycles share: Cycles' ladder of sample counts with two seeds each,
running labelled bakes of a .blend one by one in fresh processes (bench/in_blender.py), saving a
run's raw results to report them again, the corners of a bake, and Cycles' time at an error.

Cycles' time at an error comes from its bakes at increasing samples: interpolated in log-log
between the sample counts measured, extrapolated beyond them (below its lowest error along
noise's law, time x 1 / error^2, as its noise falls as 1 / sqrt(samples)).
"""

from __future__ import annotations

import argparse
import json
import math
import statistics
import time
from dataclasses import dataclass
from itertools import zip_longest
from pathlib import Path
from typing import Callable

import numpy as np

from bench import machine
from bench.in_blender import measure as measure_in_blender
from bench.metrics import seed_noise
from bench.paths import raw_results, shown
from bench.runner import value_in_fresh_process

SEEDS = (1, 2)  # scene.cycles.seed: two Cycles bakes at every sample count, for their noise
FIRST_SAMPLES = 16  # Cycles' samples run from this up to a study's highest, x 4 at each step
TARGET_SPEEDUP = 100.0  # the project's target: at least this many times faster than Cycles at equal error
# The anchor for Cycles, quoted (not measured here): a Cornell box with 40 x 40 walls, 2 cores,
# Blender 5.0.1 Cycles CPU, COMBINED vertex bake; samples -> (seconds, NRMSE).
ANCHOR = {16: (1.4, 0.19), 64: (5.7, 0.088), 256: (28.0, 0.042), 1024: (146.0, 0.021)}
Labelled = list[tuple[str, dict]]  # (label, case of bench/in_blender.py) in the order they run


def ladder(top: int) -> tuple[int, ...]:
    """Cycles' sample counts: FIRST_SAMPLES x 4^k below ``top``, then ``top``."""
    counts = [FIRST_SAMPLES]
    while counts[-1] * 4 < top:
        counts.append(counts[-1] * 4)
    return tuple(n for n in counts if n < top) + (top,)


def cycles_label(samples: int, seed: int) -> str:
    return f"cycles {samples} seed {seed}"


def cycles_cases(counts: tuple[int, ...], common: dict) -> Labelled:
    """Cycles' bakes at each of ``counts`` samples with each seed; ``common`` names the file."""
    return [(cycles_label(n, seed), {"kind": "cycles", "samples": n, "seed": seed} | common)
            for n in counts for seed in SEEDS]


def cycles_runs(results: dict[str, dict], samples: int) -> list[dict]:
    """Cycles' bakes at ``samples``, one per seed."""
    return [results[cycles_label(samples, seed)] for seed in SEEDS]


@dataclass
class CyclesStep:
    """Cycles' bakes at one sample count of the ladder: one result and its corner colours (M, 3)
    per seed, and their mean wall seconds."""

    samples: int
    runs: list[dict]
    colours: list[np.ndarray]
    seconds: float


def cycles_steps(results: dict[str, dict], counts: tuple[int, ...]) -> list[CyclesStep]:
    """Cycles' bakes of a run at each of ``counts`` samples."""
    steps = []
    for samples in counts:
        runs = cycles_runs(results, samples)
        steps.append(CyclesStep(samples, runs, [Corners.of(run).colours for run in runs],
                                statistics.mean(run["wall"] for run in runs)))
    return steps


class CyclesAnswer:
    """Cycles' answer from its bakes ``runs`` of one sample count, one per seed (``cycles_runs``):
    the mean of their corner colours (M, 3), the mean value ``scale`` of that, and the noise of
    one seed (``seed_noise``) and of their mean (``noise``, 1 / sqrt(2) of it), relative to ``scale``."""

    def __init__(self, runs: list[dict]) -> None:
        self.seeds = tuple(Corners.of(result) for result in runs)
        first, second = (corners.colours for corners in self.seeds)
        self.colours = (first + second) / 2
        self.scale = float(np.mean(self.colours))
        self.seed_noise = seed_noise(first, second, self.scale)
        self.noise = self.seed_noise / math.sqrt(2)


def alternate(ours: Labelled, cycles: Labelled) -> Labelled:
    """Ours and Cycles' bakes taken in turn, so that both see the machine's load of the same minutes."""
    return [case for pair in zip_longest(ours, cycles) for case in pair if case is not None]


def settings_text(settings: dict) -> str:
    """scene.radiosity settings as the reports show them."""
    return ", ".join(f"{name} {value:g}" if isinstance(value, float) else f"{name} {value}"
                     for name, value in settings.items())


def options(study: str, description: str, samples: int, quick_samples: int) -> argparse.ArgumentParser:
    """The options every study against Cycles takes: --samples, --quick, --from-results."""
    parser = argparse.ArgumentParser(prog=f"python -m bench {study}", description=description)
    parser.add_argument("--samples", type=int, help=f"Cycles' highest samples (default {samples}; "
                        f"{quick_samples} with --quick); the bakes go from {FIRST_SAMPLES} up to it, x 4 at each step")
    parser.add_argument("--quick", action="store_true", help="fewer and cheaper bakes, to try the study in a few "
                        "minutes; writes into build/bench-quick/")
    parser.add_argument("--from-results", type=Path, metavar="JSON", help="no bakes: the report again from the raw "
                        f"results a run saved ({shown(raw_results(study, False))}, or under build/bench-quick/)")
    return parser


def measured_or_saved(study: str, options: argparse.Namespace, argv: list[str], samples: int, quick_samples: int,
                      measure_run: Callable[[int, bool], dict]) -> dict:
    """A run's raw results: with --from-results those a run saved, else ``measure_run(samples,
    quick)`` (``measure``'s answer) with the options, saved for --from-results."""
    if options.from_results is not None:
        return load(options.from_results)
    chosen = options.samples or (quick_samples if options.quick else samples)
    if chosen <= FIRST_SAMPLES:
        raise SystemExit(f"--samples must be more than {FIRST_SAMPLES} (Cycles' time at an error needs two sample "
                         f"counts), got {chosen}")
    data = measure_run(chosen, options.quick) | {"samples": chosen, "quick": options.quick, "argv": argv}
    save(data, raw_results(study, options.quick))
    return data


def measure(labelled: Labelled, header: dict[str, str]) -> dict:
    """Every case's result (with the case's samples and settings), the run's header (``header``,
    the machine's, then its state at the end) and minutes, printing progress."""
    start = time.perf_counter()
    header = machine.opening() | header
    print(", ".join(f"{key}: {value}" for key, value in header.items()), flush=True)
    results = {}
    for number, (label, case) in enumerate(labelled, 1):
        print(f"[{number}/{len(labelled)}] {label} ...", end=" ", flush=True)
        results[label] = value_in_fresh_process(measure_in_blender, case) | {
            "samples": case.get("samples"), "case_settings": case.get("settings", {})}
        timing = results[label].get("wall", results[label].get("seconds"))
        print(f"{timing} ; {time.perf_counter() - start:.0f} s so far", flush=True)
    header |= machine.closing(header)
    return {"header": header, "results": results, "minutes": (time.perf_counter() - start) / 60}


def save(data: dict, path: Path) -> None:
    """A run's raw results as JSON at ``path``, for ``--from-results``."""
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(data))
    print(f"wrote {shown(path)}")


def load(path: Path) -> dict:
    """The raw results a run saved at ``path``."""
    return json.loads(path.read_text())


@dataclass
class Corners:
    """The corner colours of a bake's compared meshes, stacked in the order the bake listed them."""

    colours: np.ndarray  # (M, 3)
    weights: np.ndarray  # (M,) the corner's share of its polygon's area
    surface: np.ndarray  # (M,) index of its mesh in that order

    @classmethod
    def of(cls, result: dict) -> Corners:
        """The corners of a result of bench/in_blender.py (its "objects")."""
        objects = list(result["objects"].values())
        return cls(np.concatenate([np.array(mesh["colours"], dtype=np.float64) for mesh in objects]),
                   np.concatenate([np.array(mesh["weights"], dtype=np.float64) for mesh in objects]),
                   np.concatenate([np.full(len(mesh["weights"]), k) for k, mesh in enumerate(objects)]))

    def surface_means(self) -> np.ndarray:
        """(S, 3) area-weighted mean colour of each mesh."""
        return np.array([np.average(self.colours[self.surface == k], axis=0, weights=self.weights[self.surface == k])
                         for k in range(self.surface.max() + 1)])


def at_corners(result: dict, owner: np.ndarray, loop: np.ndarray) -> np.ndarray:
    """(n, 3) a bake's colours at the corners given by object name ``owner`` (n,) and loop (n,)."""
    objects = result["objects"]
    return np.array([objects[name]["colours"][index] for name, index in zip(owner, loop)], dtype=np.float64)


def seconds_at(error: float, errors: list[float], seconds: list[float]) -> tuple[float, str]:
    """Seconds at NRMSE ``error`` on Cycles' curve (``errors`` falling, ``seconds`` rising with
    its samples), and how: "" inside the curve, interpolated in log-log; "extrapolated" beyond
    it, along the first segment above, below along noise's law (time x 1 / error^2)."""
    if error <= 0:
        return math.inf, "no error left to match"
    if error > errors[0]:
        return _log_line(errors[0], seconds[0], errors[1], seconds[1], error), "extrapolated"
    for k in range(len(errors) - 1):
        if errors[k] >= error >= errors[k + 1]:
            return _log_line(errors[k], seconds[k], errors[k + 1], seconds[k + 1], error), ""
    best = int(np.argmin(errors))
    return seconds[best] * (errors[best] / error) ** 2, "extrapolated"


def _log_line(x0: float, y0: float, x1: float, y1: float, x: float) -> float:
    """y at x on the straight line through (x0, y0) and (x1, y1) in log-log."""
    if x0 == x1:
        return math.sqrt(y0 * y1)
    slope = math.log(y1 / y0) / math.log(x1 / x0)
    return y0 * (x / x0) ** slope
