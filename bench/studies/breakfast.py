"""The breakfast room (269,538 triangles) under a uniform sky, baked by the core with its defaults,
against path tracing at random corners: writes docs/results/breakfast.md.

The targets (issue 21): at most 60 s and 4 GiB of peak resident memory, at most 3 % from path
tracing at 1,000 random corners, a progress call at least every 0.2 s, a cancel honoured within
0.5 s (the bake cancelled at CANCEL_AT shares of its time, each in a fresh process: from the moment
the caller decides to stop to the bake's return, the wait for its next progress call included).
The bake runs in a fresh process (its peak is that process's, reading the OBJ included); the
answer is path-traced at each chosen corner's node (bench/corner_answer.py) in a process of its
own, kept in build/ for the next run while core/ is unchanged (the tradeoffs study's cache), its
noise removed from the error in quadrature. Times are one run's on a shared machine.
"""

from __future__ import annotations

import argparse
import sys
import time

from bench import machine, markdown, scenes
from bench.markdown import MIB, pct, table
from bench.metrics import nrmse, without_noise
from bench.paths import reports
from bench.runner import in_fresh_process
from bench.studies.tradeoffs import cached_answer
from bench.studies.tradeoffs_plan import PathTraced
from core import bake
from core.util.progress import REPORT_INTERVAL, BakeCancelled

STUDY = "breakfast"
CORNERS, PATHS = 1_000, 40_000  # about 3 % of noise: the room is dark but near its windows
QUICK_CORNERS, QUICK_PATHS = 100, 500
TRACING_TIMEOUT = 3 * 3600.0
TARGET_SECONDS, TARGET_PEAK, TARGET_ERROR = 60.0, 4 << 30, 0.03
PROMISED_GAP = 0.2  # s: the longest a bake may leave its caller without a progress call
PROMISED_CANCEL = 0.5  # s: the longest from a cancel to the bake's return
CANCEL_AT = (0.1, 0.35, 0.6, 0.85)  # shares of the bake's time at which it is cancelled, one bake each


def measure_bake() -> dict:
    """In a fresh process: the default bake of the breakfast room, timed, with the longest wait
    between its progress calls and the stage it ended in."""
    scene = scenes.load("breakfast")
    gaps = {"longest": 0.0, "stage": "", "last": time.perf_counter()}

    def progress(_fraction: float, message: str) -> bool:
        now = time.perf_counter()
        if now - gaps["last"] > gaps["longest"]:
            gaps["longest"], gaps["stage"] = now - gaps["last"], message
        gaps["last"] = now
        return True

    start = time.perf_counter()
    result = bake(scene, progress=progress)
    seconds = time.perf_counter() - start
    stats = result.stats
    return {"seconds": seconds, "stages": stats["seconds"], "longest_gap": gaps["longest"], "gap_stage": gaps["stage"],
            "counts": {key: stats[key] for key in ("triangles", "patches", "nodes", "rays_cast")},
            "solver": stats["solver"], "estimate": stats["error_estimate"]["total"],
            "near_field": stats["near_field"], "corner_colors": result.corner_colors}


def measure_cancel(after: float) -> dict:
    """In a fresh process: the default bake of the breakfast room, cancelled ``after`` seconds
    into it (its progress callback returns False from then on): how long from that moment until
    ``bake`` raised BakeCancelled, and the stage it was in."""
    scene = scenes.load("breakfast")
    start = time.perf_counter()
    deadline = start + after
    stage = {"message": ""}

    def progress(_fraction: float, message: str) -> bool:
        if time.perf_counter() < deadline:
            stage["message"] = message
            return True
        return False

    try:
        bake(scene, progress=progress)
    except BakeCancelled:
        return {"after": after, "latency": time.perf_counter() - deadline, "stage": stage["message"]}
    return {"after": after, "latency": None, "stage": "finished before the cancel"}


def report(baked: dict, wall: float, peak: int, answer, header: dict, minutes: float, quick: bool,
           cancels: list[dict]) -> str:
    """The Markdown report."""
    values = baked["corner_colors"][answer.triangles, answer.corners]
    error = without_noise(nrmse(values, answer.radiosity), answer.noise)
    stages = ", ".join(f"{stage} {seconds:.1f}" for stage, seconds in baked["stages"].items() if stage != "total")
    counts = baked["counts"]

    def verdict(met: bool) -> str:
        return "met" if met else "**not met**"

    rows = [
        ["bake (`core.bake`, defaults)", f"{baked['seconds']:.1f} s", f"<= {TARGET_SECONDS:g} s",
         verdict(baked["seconds"] <= TARGET_SECONDS)],
        ["the process (reading the OBJ, the bake)", f"{wall:.1f} s", "", ""],
        ["peak resident memory of the process", f"{peak / MIB:,.0f} MiB", f"<= {TARGET_PEAK / MIB:,.0f} MiB",
         verdict(peak <= TARGET_PEAK)],
        [f"error at {len(values)} corners (RMS over the answer's mean, its noise removed)", pct(error),
         f"<= {pct(TARGET_ERROR)}", verdict(error <= TARGET_ERROR)],
        ["the bake's own error estimate", pct(baked["estimate"]), f">= the error ({pct(error)})",
         verdict(baked["estimate"] >= error)],
        ["longest wait for a progress call", f"{baked['longest_gap']:.2f} s (ending in '{baked['gap_stage']}')",
         f"<= {PROMISED_GAP:g} s", verdict(baked["longest_gap"] <= PROMISED_GAP)],
    ]
    heard = [cancel for cancel in cancels if cancel["latency"] is not None]
    if cancels:
        slowest = max(heard, key=lambda cancel: cancel["latency"]) if heard else None
        moments = ", ".join(f"{cancel['after']:.0f}" for cancel in cancels)
        rows.append([f"longest from a cancel to the bake's return ({len(cancels)} bakes cancelled at {moments} s)",
                     f"{slowest['latency']:.2f} s (in '{slowest['stage']}')" if slowest else "none heard",
                     f"<= {PROMISED_CANCEL:g} s",
                     verdict(len(heard) == len(cancels) and slowest["latency"] <= PROMISED_CANCEL)])
    about = (f"Options: `--corners N` (default {CORNERS:,}), `--paths N` (default {PATHS:,}), `--quick`. "
             f"The bake works on a thread of its own and its caller's thread passes on what it last reported "
             f"every {REPORT_INTERVAL:g} s, also inside one long step (`progress.relayed`).")
    return "\n".join([
        *markdown.opening("The breakfast room under a sky", STUDY, "--quick" if quick else "", minutes, quick, about,
                          header),
        "",
        f"- The scene: {scenes.DESCRIPTIONS['breakfast']}. {counts['triangles']:,} triangles, "
        f"{counts['patches']:,} patches, {counts['nodes']:,} nodes, {counts['rays_cast']:,} rays; solver "
        f"{baked['solver']}.",
        f"- The answer: path tracing (bench/pathtrace.py, the sky added where a bounce leaves the scene) at "
        f"{len(values)} random corners of the room, each at its node, {header['paths']:,} paths each, in "
        f"{answer.seconds:.0f} s (when it was traced); its noise, {pct(answer.noise)} of the mean radiosity "
        f"({answer.radiosity.mean():.4f}) in RMS. Our mean over the answer's: "
        f"{values.mean() / answer.radiosity.mean():.3f}.",
        "",
        table(["measure", "value", "target", ""], rows),
        "",
        f"Stages of the bake (s): {stages}.",
        "",
        f"Near field: {baked['near_field']}." if baked["near_field"] else "",
        "",
    ])


def main(argv: list[str]) -> int:
    parser = argparse.ArgumentParser(prog=f"python -m bench {STUDY}", description=__doc__.split("\n\n")[0])
    parser.add_argument("--corners", type=int, help=f"corners path-traced (default {CORNERS:,}; {QUICK_CORNERS} "
                        "with --quick)")
    parser.add_argument("--paths", type=int, help=f"paths at each corner (default {PATHS:,}; {QUICK_PATHS:,} with "
                        "--quick)")
    parser.add_argument("--quick", action="store_true", help="fewer corners and paths; writes into "
                        "build/bench-quick/")
    options = parser.parse_args(argv)
    if scenes.missing():
        print(f"error: {scenes.missing()}", file=sys.stderr)
        return 2
    corners = options.corners or (QUICK_CORNERS if options.quick else CORNERS)
    paths = options.paths or (QUICK_PATHS if options.quick else PATHS)
    start = time.perf_counter()
    header = machine.opening()
    print("bake ...", flush=True)
    outcome = in_fresh_process(measure_bake)
    if not outcome.ok:
        print(f"error: the bake {outcome.status}", file=sys.stderr)
        return 1
    print(f"  {outcome.value['seconds']:.1f} s; the answer: {corners} corners x {paths:,} paths ...", flush=True)
    answer = cached_answer(STUDY, scenes.load("breakfast"), PathTraced(corners, paths, TRACING_TIMEOUT),
                           machine.core_digest())
    cancels = []
    for share in CANCEL_AT[1:3] if options.quick else CANCEL_AT:
        print(f"cancelled at {share:.0%} of the bake ...", flush=True)
        cancelled = in_fresh_process(measure_cancel, share * outcome.value["seconds"])
        if not cancelled.ok:
            print(f"error: the cancelled bake {cancelled.status}", file=sys.stderr)
            return 1
        cancels.append(cancelled.value)
    header |= machine.closing(header) | {"corners": corners, "paths": paths}
    minutes = (time.perf_counter() - start) / 60
    text = report(outcome.value, outcome.wall, outcome.peak, answer, header, minutes, options.quick, cancels)
    markdown.write(text, reports(options.quick) / f"{STUDY}.md")
    return 0
