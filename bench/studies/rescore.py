"""Score a core bake of the sample Cornell box against the Cycles answer saved by the last
versus_cycles run, without baking Cycles again: a quick check of a core change between full runs
(the Cycles bakes are most of that study's minutes). Prints; writes nothing.

    python -m bench rescore [--quick] [knob=value ...]      e.g. near_field=False

The scene is sample_blends/cornell_box.blend as the add-on reads it (two-sided surfaces, as the
panel's default); the bake runs in a process of its own, timed around the core call. Printed:
NRMSE against the mean of Cycles' two highest-sample seeds (the noise of that mean removed in
quadrature, as in docs/results/versus_cycles.md), on every corner, on the corners where two
surfaces meet and on the others.
"""

from __future__ import annotations

import argparse
import ast
import time

import numpy as np

from bench import comparison, markdown, scenes
from bench.comparison import CyclesAnswer, cycles_runs
from bench.metrics import rms, without_noise
from bench.paths import raw_results, shown
from bench.runner import value_in_fresh_process
from bench.studies.versus_cycles_closer import touching
from core import KNOBS, Scene, bake

STUDY = "rescore"


def timed_bake(scene: Scene, knobs: dict) -> tuple[np.ndarray, dict, float]:
    """(corner colours (T, 3, 3), stats, seconds) of ``bake(scene, **knobs)``, timed around the call."""
    start = time.perf_counter()
    result = bake(scene, **knobs)
    return result.corner_colors, result.stats, time.perf_counter() - start


def knob(text: str) -> tuple[str, object]:
    """A knob=value argument: the name of a core knob and its value as a Python literal."""
    name, _, value = text.partition("=")
    if name not in {knob.name for knob in KNOBS}:
        raise argparse.ArgumentTypeError(f"no knob {name!r}: one of {', '.join(knob.name for knob in KNOBS)}")
    return name, ast.literal_eval(value)


def main(argv: list[str]) -> int:
    parser = argparse.ArgumentParser(prog=f"python -m bench {STUDY}", description=__doc__.split("\n\n")[0])
    parser.add_argument("knobs", nargs="*", type=knob, metavar="KNOB=VALUE", help="core knobs, as Python literals")
    parser.add_argument("--quick", action="store_true", help="against the last `versus_cycles --quick` run")
    options = parser.parse_args(argv)
    saved = raw_results("versus_cycles", options.quick)
    if not saved.exists():
        parser.error(f"no {shown(saved)}: run `{markdown.command('versus_cycles', '--quick' if options.quick else '')}`"
                     " first")
    data = comparison.load(saved)
    results = data["results"]
    knobs = dict(options.knobs)
    scene, owner, loop = scenes.extracted(scenes.SAMPLE_BLEND)
    colours, stats, seconds = value_in_fresh_process(timed_bake, scene, knobs)
    runs = cycles_runs(results, data["samples"])
    answer = CyclesAnswer(runs)
    ours = np.concatenate([_object_colours(colours, owner, loop, name, len(mesh["colours"]))
                           for name, mesh in runs[0]["objects"].items()])
    where = touching(next(result for label, result in results.items() if label.startswith("ours PREVIEW"))["objects"])

    def bias(mask: np.ndarray) -> float:
        return without_noise(rms(ours[mask] - answer.colours[mask]) / answer.scale, answer.noise)

    every = np.ones(len(ours), dtype=bool)
    print(f"knobs {knobs or 'defaults'}: {stats['patches']:,} patches, core {seconds:.2f} s "
          f"({', '.join(f'{k} {v:.2f}' for k, v in stats['seconds'].items() if k != 'total')})")
    print(f"NRMSE against Cycles {data['samples']} samples (noise {100 * answer.noise:.2f} % removed): "
          f"{100 * bias(every):.2f} %; where surfaces meet {100 * bias(where):.2f} %; "
          f"elsewhere {100 * bias(~where):.2f} %; estimate {stats['error_estimate']}")
    return 0


def _object_colours(colours: np.ndarray, owner: np.ndarray, loop: np.ndarray, name: str, loops: int) -> np.ndarray:
    """(loops, 3) the colours of object ``name``'s loops from the corner colours (T, 3, 3) of a bake."""
    mine = owner == name
    out = np.zeros((loops, 3))
    out[loop[mine]] = colours[mine]
    return out
