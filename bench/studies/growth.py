"""How a bake's time and peak memory grow with the scene: the Cornell box with a hole in its ceiling
(bench/scenes.py "cornell") tiled k x k, each copy its own closed room with its own light, baked
with the defaults (which shoot to the tolerance or go by Monte Carlo as the estimated cost of
shooting decides), with the large scenes' path (Monte Carlo, 64 gather rays) at every size and with
hierarchical radiosity, the patch size always one box's default (the automatic one grows with the
scene's extent).
Writes docs/results/growth.md and growth.png.

The target (issue 21): the log-log slope of time and of peak memory against the triangle count at
most 1.15. Copies are independent, so a solver whose cost follows the light grows linearly here.
Each bake runs in a fresh process (its peak is the process's, the interpreter and scene included);
times are the bake call's, one run on a shared machine.
"""

from __future__ import annotations

import argparse
import sys
import time

import numpy as np

from bench import machine, markdown, scenes
from bench.markdown import MIB, table
from bench.paths import reports, shown
from bench.runner import in_fresh_process
from core import BakeSettings, Scene, bake
from core.settings import AUTO_PATCH_DIVISIONS, LARGE_SCENE_SHOOTING, MAX_REFINEMENT

STUDY = "growth"
TARGET_SLOPE = 1.15
SPACING = 1.1  # copies this many box widths apart: walls never touch
SERIES = {"defaults": {}, "Monte Carlo 64": {"monte_carlo_rays": 64}, "hierarchical": {"solver": "hierarchical"}}
TILES = {"defaults": (1, 2, 4, 8), "Monte Carlo 64": (1, 2, 4, 8), "hierarchical": (1, 2, 4, 8)}
QUICK_TILES = (1, 2)
TIMEOUT = 1800.0


def tiled(scene: Scene, side: int) -> Scene:
    """``scene`` (triangles, colours, materials and sides only) copied side x side times on a grid
    across x and z."""
    width = float(np.ptp(scene.vertices, axis=0).max()) * SPACING
    offsets = [np.array([i * width, 0.0, j * width]) for i in range(side) for j in range(side)]
    count, copies = len(scene.vertices), len(offsets)
    return Scene(np.concatenate([scene.vertices + offset for offset in offsets]),
                 np.concatenate([scene.triangles + k * count for k in range(copies)]),
                 np.tile(scene.reflectance, (copies, 1)), np.tile(scene.emission, (copies, 1)),
                 material=np.tile(scene.material, copies), two_sided=np.tile(scene.two_sided, copies))


def measure(side: int, knobs: dict) -> dict:
    """In a fresh process: the bake of the box tiled side x side, timed."""
    one = scenes.load("cornell")
    scene = tiled(one, side)
    start = time.perf_counter()
    result = bake(scene, patch_size=one.extent / AUTO_PATCH_DIVISIONS, **knobs)
    return {"seconds": time.perf_counter() - start, "triangles": len(scene.triangles),
            "patches": result.stats["patches"], "nodes": result.stats["nodes"], "stages": result.stats["seconds"],
            "monte_carlo_rays": result.stats["settings"]["monte_carlo_rays"] if result.stats["solver"] == "progressive"
            else 0}


def slope(counts: list[float], values: list[float]) -> float:
    """The least-squares slope of log(values) against log(counts)."""
    return float(np.polyfit(np.log(counts), np.log(values), 1)[0])


def slopes(counts: list[float], values: list[float]) -> tuple[float, float]:
    """The fitted ``slope`` over every size, and the slope of the last step, between the two
    largest sizes (where a series that changes its course, as the defaults do when they go by
    Monte Carlo, shows how it grows from there on)."""
    return slope(counts, values), slope(counts[-2:], values[-2:])


def figure(results: dict[str, list[dict]], path) -> None:
    """Time and peak memory against triangles, log-log, one line per series."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(9, 3.8))
    for name, rows in results.items():
        triangles = [row["triangles"] for row in rows]
        axes[0].loglog(triangles, [row["seconds"] for row in rows], "o-", label=name)
        axes[1].loglog(triangles, [row["peak"] / MIB for row in rows], "o-", label=name)
    for ax, label in zip(axes, ("bake seconds", "peak resident MiB")):
        ax.set_xlabel("triangles")
        ax.set_ylabel(label)
        ax.grid(True, which="both", alpha=0.3)
    reference = np.array([min(row["triangles"] for rows in results.values() for row in rows),
                          max(row["triangles"] for rows in results.values() for row in rows)], float)
    first = next(iter(results.values()))[0]
    axes[0].loglog(reference, first["seconds"] * (reference / reference[0]) ** TARGET_SLOPE, "k:",
                   label=f"slope {TARGET_SLOPE:g}")
    axes[0].legend()
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def report(results: dict[str, list[dict]], header: dict, minutes: float, quick: bool, picture: str,
           stopped: dict[str, str]) -> str:
    """The report; ``stopped``: per series that stopped before its largest size, at which and why."""
    rows, verdicts = [], []
    for name, found in results.items():
        for row in found:
            stages = ", ".join(f"{stage} {seconds:.1f}" for stage, seconds in row["stages"].items() if stage != "total")
            rows.append([name, f"{row['copies']}", f"{row['triangles']:,}", f"{row['patches']:,}",
                         f"{row['nodes']:,}", f"{row['monte_carlo_rays']}", f"{row['seconds']:.2f}",
                         f"{row['peak'] / MIB:,.0f}", stages])
        if len(found) > 1:
            triangles = [row["triangles"] for row in found]
            time_slopes = slopes(triangles, [row["seconds"] for row in found])
            memory_slopes = slopes(triangles, [row["peak"] for row in found])
            verdicts.append(f"- {name}: time slope **{time_slopes[0]:.2f}** ({time_slopes[1]:.2f} at the last step), "
                            f"peak memory slope **{memory_slopes[0]:.2f}** ({memory_slopes[1]:.2f} at the last step) "
                            f"(target at most {TARGET_SLOPE:g}, fitted and at the last step: "
                            f"{'met' if max(*time_slopes, *memory_slopes) <= TARGET_SLOPE else 'not met'}).")
        if name in stopped:
            verdicts.append(f"- {name} stopped: {stopped[name]}.")
    about = ("Options: `--quick`. The slope is the least-squares fit of log(value) against log(triangles) over "
             "a series' sizes; the last step's, between its two largest sizes.")
    return "\n".join([
        *markdown.opening("Growth with the scene", STUDY, "--quick" if quick else "", minutes, quick, about, header),
        "",
        f"- The scene family: {scenes.DESCRIPTIONS['cornell']}, copied k x k, {SPACING:g} box widths apart.",
        f"- The defaults shoot to the tolerance below {LARGE_SCENE_SHOOTING:,} form factors per round of shots, "
        f"patches x (patches + nodes), times up to {MAX_REFINEMENT:g} for patches finer than the scene's extent / "
        f"{AUTO_PATCH_DIVISIONS} (here every copy has the patches of one box), and go by Monte Carlo from there on "
        "(`core.settings.auto_monte_carlo_rays`): the column \"Monte Carlo rays\" says which.",
        "- hierarchical: `solver=\"hierarchical\"` at its own defaults (link tolerance "
        f"{BakeSettings().link_tolerance:g}), never chosen automatically: docs/methods.md says where it stands.",
        "",
        *verdicts,
        "",
        f"![time and peak memory against triangles]({picture})",
        "",
        table(["series", "copies", "triangles", "patches", "nodes", "Monte Carlo rays", "bake s", "peak MiB",
               "stages (s)"], rows),
        "",
    ])


def main(argv: list[str]) -> int:
    parser = argparse.ArgumentParser(prog=f"python -m bench {STUDY}", description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="1 and 4 copies; writes into build/bench-quick/")
    options = parser.parse_args(argv)
    if scenes.missing():
        print(f"error: {scenes.missing()}", file=sys.stderr)
        return 2
    start = time.perf_counter()
    header = machine.opening()
    results, stopped = {}, {}
    for name, knobs in SERIES.items():
        results[name] = []
        for side in QUICK_TILES if options.quick else TILES[name]:
            print(f"{name}: {side * side} copies ...", flush=True)
            outcome = in_fresh_process(measure, side, knobs, timeout=TIMEOUT)
            if not outcome.ok:
                print(f"  {outcome.status}: the series stops here", flush=True)
                stopped[name] = f"at {side * side} copies, {outcome.status}"
                break
            results[name].append(outcome.value | {"copies": side * side, "peak": outcome.peak})
            print(f"  {outcome.value['seconds']:.1f} s, {outcome.peak / MIB:.0f} MiB", flush=True)
    header |= machine.closing(header)
    folder = reports(options.quick)
    figure(results, folder / f"{STUDY}.png")
    text = report(results, header, (time.perf_counter() - start) / 60, options.quick, f"{STUDY}.png", stopped)
    markdown.write(text, folder / f"{STUDY}.md")
    print(f"wrote {shown(folder / f'{STUDY}.png')}")
    return 0
