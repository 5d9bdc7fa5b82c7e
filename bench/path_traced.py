"""Every bake of bench/sponza.py's last run against a third answer: path tracing at random
vertices of Sponza (core/pathtrace.py), independent of Cycles and of our patches' radiosity.

Cycles' answer (docs/sponza.md) has its own ways: one colour per corner at the vertex itself,
its own ray offsets. Path tracing here evaluates each chosen corner where our bake reads it (its
node: NODE_INSET in from the vertex, facing the corner's normal), from the .blend the bakes ran on,
with next-event estimation and bounces weighted by the power heuristic; its noise (the standard
errors of the paths) is removed from every error in quadrature.

Run from the repository root after bench/sponza.py: ``.venv/bin/python bench/path_traced.py
[--corners 400] [--paths 80000]``; writes docs/path_traced.md and build/sponza/path_traced.npz.
"""

from __future__ import annotations

import argparse
import json
import pickle
import statistics
import subprocess
import sys
import time

import machine
import numpy as np
from cycles_headline import seconds_at
from cycles_metrics import pct, table, without_noise
from cycles import ladder
from cycles_worker import REPO
from sponza import BAKES, BLEND, RESULTS, SAMPLES, SEEDS, WORK, label

sys.path.insert(0, str(REPO))
from core import Scene  # noqa: E402
from core.bake import BakeSettings, discretised  # noqa: E402
from core.pathtrace import path_traced  # noqa: E402
from core.visibility import Visibility  # noqa: E402

COMMAND = ".venv/bin/python bench/path_traced.py"
REPORT = REPO / "docs" / "path_traced.md"
TRUTH = WORK / "path_traced.npz"
EXTRACTED = WORK / "path_traced_scene.pkl"


def scene_and_corners():
    """The scene of the .blend the bakes ran on, and each triangle corner's (object, loop), from
    bench/sponza_scene.py."""
    subprocess.run([sys.executable, str(REPO / "bench" / "sponza_scene.py"), str(BLEND), str(EXTRACTED)],
                   cwd=REPO, check=True, capture_output=True)
    fields, owner, loop = pickle.loads(EXTRACTED.read_bytes())
    return Scene(**fields), owner, loop


def truth(corners: int, paths: int, patch_size: float) -> dict:
    """B at ``corners`` random corners of non-emitting triangles, path-traced at their nodes."""
    scene, owner, loop = scene_and_corners()
    mesh, _ = discretised(scene, BakeSettings(patch_size=patch_size))
    front = mesh.front_patch_count
    visibility = Visibility(mesh.patch_corners[:front], two_sided=mesh.back_of_front >= 0,
                            owners=mesh.patch_triangle[:front])
    candidates = np.argwhere((mesh.corner_node >= 0) & ~scene.emission.any(axis=1)[:, None])
    chosen = candidates[np.random.default_rng(7).choice(len(candidates), corners, replace=False)]
    nodes = mesh.corner_node[chosen[:, 0], chosen[:, 1]]
    start = time.perf_counter()
    found = path_traced(mesh, visibility, mesh.node_points[nodes], mesh.node_normals[nodes], paths, seed=1)
    reflectance = mesh.node_reflectance[nodes]
    return {"owner": owner[chosen[:, 0], chosen[:, 1]].astype(str), "loop": loop[chosen[:, 0], chosen[:, 1]],
            "radiosity": mesh.node_emission[nodes] + reflectance * found.light,
            "standard_error": reflectance * found.standard_error, "seconds": time.perf_counter() - start}


def at_corners(result: dict, owner: np.ndarray, loop: np.ndarray) -> np.ndarray:
    """(n, 3) a bake's colours at the chosen corners."""
    objects = result["objects"]
    return np.array([objects[name]["colours"][index] for name, index in zip(owner, loop)], dtype=np.float64)


def report(data: dict, reference: dict, header: dict) -> str:
    """The Markdown report: each bake's error against the path-traced answer, and Cycles' time at it."""
    results = data["results"]
    answer = reference["radiosity"]
    scale = float(answer.mean())
    noise = float(np.sqrt((reference["standard_error"] ** 2).mean()) / scale)

    def error(result: dict) -> float:
        values = at_corners(result, reference["owner"], reference["loop"])
        return without_noise(float(np.sqrt(((values - answer) ** 2).mean()) / scale), noise)

    cycles_errors, cycles_seconds, cycles_rows = [], [], []
    for n in ladder(SAMPLES):
        runs = [results[f"cycles {n} seed {s}"] for s in SEEDS]
        errors = [error(run) for run in runs]
        wall = statistics.mean(run["wall"] for run in runs)
        cycles_errors.append(statistics.mean(errors))
        cycles_seconds.append(wall)
        cycles_rows.append([f"Cycles {n} samples", f"{wall:.1f}", " / ".join(pct(e) for e in errors)])
    our_rows, best = [], None
    for name in BAKES:
        result = results[label(name)]
        ours = error(result)
        seconds, how = seconds_at(ours, cycles_errors, cycles_seconds)
        values = at_corners(result, reference["owner"], reference["loop"])
        our_rows.append([name, f"{result['wall']:.0f}", pct(ours), f"{values.mean() / scale:.3f}",
                         f"{seconds:.3g}" + (" (extrapolated)" if how else ""), f"{seconds / result['wall']:.3g}"])
        if best is None or seconds / result["wall"] > best[1]:
            best = (name, seconds / result["wall"], ours, result["wall"])
    top = [at_corners(results[f"cycles {SAMPLES} seed {s}"], reference["owner"], reference["loop"]) for s in SEEDS]
    answer_noise = float(np.sqrt(((top[0] - top[1]) ** 2).mean() / 4) / scale)  # the mean's: 1 / sqrt(2) of a seed's
    error_of_mean = without_noise(without_noise(float(np.sqrt((((top[0] + top[1]) / 2 - answer) ** 2).mean()) / scale),
                                                noise), answer_noise)
    corners = len(answer)
    return "\n".join([
        "# Sponza's bakes against path tracing",
        "",
        f"Generated by `{COMMAND}` (from the repository root) after `.venv/bin/python bench/sponza.py`, from the "
        f"bakes of that run (build/sponza/results.json, {data['header'].get('date', '?')}, core "
        f"{data['header'].get('core/*.py SHA-1', '?')}). The bakes' times are that run's.",
        "",
        *[f"- {key}: {value}" for key, value in header.items()],
        "",
        f"- The answer: path tracing (core/pathtrace.py) at {corners} random corners of non-emitting triangles, "
        f"each where our bake reads it (its node), {header['paths']:,} paths each, in {reference['seconds']:.0f} s; "
        f"its noise, {pct(noise)} of the mean radiosity ({scale:.4f}) in RMS, is removed from every error below "
        "in quadrature.",
        "- Error: RMS over those corners and R, G, B of (bake - answer), over the answer's mean.",
        "",
        table(["Cycles", "seconds (mean of the seeds)", "error, seed 1 / seed 2"], cycles_rows),
        "",
        table(["ours", "seconds", "error", "mean / answer's", "Cycles' seconds at that error (mean of the seeds)",
               "speed-up"], our_rows),
        "",
        f"- Best speed-up against this answer: {best[0]}, {pct(best[2])} in {best[3]:.0f} s, {best[1]:.3g} x "
        "Cycles (the target, 100 x, is not met).",
        f"- Cycles' own answer of docs/sponza.md (the mean of its two {SAMPLES}-sample seeds) is "
        f"{pct(error_of_mean)} from this one, its noise ({pct(answer_noise)}) removed too: it reads each corner at the "
        "vertex itself, with its own ray offsets.",
        "",
    ])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--corners", type=int, default=400)
    parser.add_argument("--paths", type=int, default=80_000)
    arguments = parser.parse_args()
    data = json.loads(RESULTS.read_text())
    patch_size = data["results"][label(next(iter(BAKES)))]["counts"]["patch_size"]
    header = machine.machine() | {"core/*.py SHA-1": machine.core_digest()} | machine.load("start")
    reference = truth(arguments.corners, arguments.paths, patch_size)
    np.savez(TRUTH, **reference)
    header |= {"corners": arguments.corners, "paths": arguments.paths, "patch size of the bakes": f"{patch_size:.4g}"}
    REPORT.write_text(report(data, reference, header))
    print(f"wrote {REPORT.relative_to(REPO)}")


if __name__ == "__main__":
    main()
