"""Score a core bake of the sample Cornell box against the Cycles answer saved by the last full
run of bench/cycles.py (build/cycles_results.json), without baking Cycles again: a quick check
of a core change between full runs (minutes saved: the Cycles bakes take 15 of them).

    .venv/bin/python bench/cycles_rescore.py [knob=value ...]     e.g. near_field=False

The scene is read from sample_blends/cornell_box.blend through the add-on's extraction (two-sided
surfaces, as the panel's default); the bake runs in this process, timed around the core call.
Printed: NRMSE against the mean of Cycles' two highest-sample seeds (the noise of that mean
removed in quadrature, as docs/cycles.md), on every corner, on the corners where two surfaces
meet and on the others.
"""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))

import cycles_metrics as metrics  # noqa: E402  (bench/ is on the path as the script's directory)
from cycles_worker import BLEND, SURFACES  # noqa: E402

RESULTS = HERE.parent / "build" / "cycles_results.json"


def _parse(arguments: list[str]) -> dict:
    knobs = {}
    for argument in arguments:
        name, value = argument.split("=", 1)
        knobs[name] = json.loads(value.replace("True", "true").replace("False", "false").replace("None", "null"))
    return knobs


def _scene_and_targets():
    here = str(HERE)
    sys.path[:] = [entry for entry in sys.path if entry != here]  # bench/cycles.py would shadow Blender's add-on
    sys.modules.pop("cycles", None)
    from tools.source_extension import blender_with_extension

    bpy, package = blender_with_extension()
    sys.path.insert(0, here)
    bpy.ops.wm.open_mainfile(filepath=str(BLEND), load_ui=False)
    extraction = package.radiosity_addon.extract.extract(bpy.context.evaluated_depsgraph_get(), two_sided=True)
    return package, extraction


def main(arguments: list[str]) -> None:
    saved = json.loads(RESULTS.read_text())
    results, samples = saved["results"], saved["samples"]
    package, extraction = _scene_and_targets()
    knobs = _parse(arguments)
    start = time.perf_counter()
    result = package.core.bake(extraction.scene, **knobs)
    seconds = time.perf_counter() - start
    by_object = {}
    for target in extraction.targets:
        colours = np.zeros((target.loop_count, 3))
        colours[target.loops.ravel()] = result.corner_colors[target.start:target.stop].reshape(-1, 3)
        by_object[target.object_name] = colours
    ours = np.concatenate([by_object[name] for name in SURFACES])
    first, second = (metrics.Corners.of(results[f"cycles {samples} seed {seed}"]).colours for seed in (1, 2))
    reference = (first + second) / 2
    noise = metrics.seed_noise(first, second, np.mean(reference)) / np.sqrt(2)
    touching = metrics.touching(next(r for k, r in results.items() if k.startswith("ours PREVIEW"))["objects"])

    def bias(mask: np.ndarray) -> float:
        error = np.sqrt(np.mean((ours[mask] - reference[mask]) ** 2)) / np.mean(reference)
        return metrics.without_noise(error, noise)

    every = np.ones(len(ours), dtype=bool)
    print(f"knobs {knobs or 'defaults'}: {result.stats['patches']:,} patches, core {seconds:.2f} s "
          f"({', '.join(f'{k} {v:.2f}' for k, v in result.stats['seconds'].items() if k != 'total')})")
    print(f"NRMSE against Cycles {samples} samples (noise {100 * noise:.2f} % removed): "
          f"{100 * bias(every):.2f} %; where surfaces meet {100 * bias(touching):.2f} %; "
          f"elsewhere {100 * bias(~touching):.2f} %; estimate {result.stats['error_estimate']}")


if __name__ == "__main__":
    main(sys.argv[1:])
