"""Re-solves after colour changes (``core.BakeSession``) against the first bake of the same scene,
and against a fresh bake of the changed scene, and Live's updates in Blender on the sample Cornell
box: writes docs/results/resolve.md.

Each scene runs in a fresh process: a first bake in a session, then for each change a re-solve in
that session (timed) and a fresh ``bake`` of the changed scene (its truth; not in the session).
The targets (issues 21 and 22): a re-solve takes at most 10 % of the first bake and matches the
fresh bake within the fresh bake's own error estimate; a Live update of the sample Cornell box
(reading the scene, re-solving, writing the colours) takes at most LIVE_TARGET. Ratios of one run;
the machine is shared and noisy.
"""

from __future__ import annotations

import argparse
import dataclasses
import statistics
import sys
import time
from dataclasses import dataclass

from bench import in_blender, machine, markdown, scenes
from bench.markdown import MIB, table
from bench.metrics import nrmse
from bench.paths import reports
from bench.runner import value_in_fresh_process
from core import BakeSession, Scene, bake

STUDY = "resolve"
TARGET = 0.10  # re-solve seconds over first-bake seconds
LIVE_TARGET = 0.1  # seconds per Live update on the sample Cornell box
LIVE_UPDATES = 10

def red_wall_blue(scene: Scene) -> Scene:
    """The reddest surfaces (red above 0.3 and twice green) turn blue."""
    reflectance = scene.reflectance.copy()
    red = (reflectance[:, 0] > 0.3) & (reflectance[:, 0] > 2 * reflectance[:, 1])
    reflectance[red] = reflectance[red][:, [2, 1, 0]]
    return dataclasses.replace(scene, reflectance=reflectance, material=scene.material)

def duller(scene: Scene) -> Scene:
    """Every surface reflects 80 % of what it did."""
    return dataclasses.replace(scene, reflectance=scene.reflectance * 0.8, material=scene.material)

def warmer_light(scene: Scene) -> Scene:
    """The emitters' light warmer and dimmer: x (1, 0.8, 0.6)."""
    return dataclasses.replace(scene, emission=scene.emission * [1.0, 0.8, 0.6], material=scene.material)

CHANGES = {"red wall blue": red_wall_blue, "surfaces 80 %": duller, "light warmer": warmer_light}
SCENES = {"cornell": ("red wall blue", "light warmer"), "sponza": ("surfaces 80 %", "light warmer")}

@dataclass
class Measurement:
    scene: str
    first_seconds: float
    first_stages: dict
    kept_bytes: int
    changes: list[dict]  # per change: name, seconds, stages, resolved, nrmse to fresh, fresh estimate

def measure(name: str) -> Measurement:
    """In a fresh process: the first bake of scene ``name`` in a session, then each change re-solved
    and baked afresh."""
    scene = scenes.load(name)
    session = BakeSession()
    start = time.perf_counter()
    first = session.bake(scene)
    first_seconds = time.perf_counter() - start
    changes = []
    for change in SCENES[name]:
        changed = CHANGES[change](scene)
        start = time.perf_counter()
        again = session.bake(changed)
        seconds = time.perf_counter() - start
        fresh = bake(changed)
        changes.append({"name": change, "seconds": seconds, "stages": again.stats["seconds"],
                        "resolved": again.stats["resolved"],
                        "nrmse": nrmse(again.corner_colors, fresh.corner_colors),
                        "estimate": fresh.stats["error_estimate"]["total"],
                        "moved": nrmse(first.corner_colors, fresh.corner_colors)})
        print(f"  {change}: {seconds:.2f} s", flush=True)
    return Measurement(name, first_seconds, first.stats["seconds"], session.kept_bytes, changes)

def report(measurements: list[Measurement], live: dict, header: dict, minutes: float) -> str:
    resolved = sum(status.startswith("Live: re-solved") for status in live["statuses"])
    rows = []
    for m in measurements:
        for change in m.changes:
            ratio = change["seconds"] / m.first_seconds
            stages = ", ".join(f"{stage} {seconds:.2f}" for stage, seconds in change["stages"].items()
                               if stage != "total")
            rows.append([m.scene, change["name"], f"{m.first_seconds:.2f}", f"{change['seconds']:.3f}",
                         f"{100 * ratio:.1f} %" + ("" if ratio <= TARGET else " (over 10 %)"),
                         "yes" if change["resolved"] else "no", markdown.pct(change["moved"]),
                         f"{100 * change['nrmse']:.2g} %", markdown.pct(change["estimate"]),
                         f"{m.kept_bytes / MIB:.0f}", stages])
    firsts = [[m.scene, f"{m.first_seconds:.2f}", ", ".join(f"{stage} {seconds:.2f}" for stage, seconds
                                                             in m.first_stages.items() if stage != "total")]
              for m in measurements]
    lines = markdown.opening(
        "Re-solves after colour changes", STUDY, "", minutes, False,
        "A session's first bake, then each change re-solved in it (`core.BakeSession`) and baked afresh "
        "(`core.bake`, the truth). Target: a re-solve at most 10 % of the first bake, within the fresh bake's "
        "error estimate of it. The machine is shared and noisy: compare within one run.", header)
    lines += ["", "## First bakes", "", table(["scene", "wall s", "stages (s)"], firsts), "",
              "## Re-solves", "",
              table(["scene", "change", "first bake s", "re-solve s", "re-solve / first", "re-solved",
                     "change moved the colours (NRMSE)", "re-solve vs fresh bake (NRMSE)", "fresh bake's estimate",
                     "kept MiB", "re-solve stages (s)"], rows), "",
              "NRMSE over all corners, as in benchmarks.md. \"kept MiB\": what the session holds for re-solves "
              "(its patches, rays' factors, form-factor columns, near-field pairs and rows).", "",
              "## Live in Blender (sample Cornell box)", "",
              f"The bake as the panel's button runs it: {live['first']:.2f} s. Then {len(live['updates'])} changes of "
              f"the base colour of material '{live['material']}', each followed by Live's update (reading the scene "
              f"as a render does, the re-solve, writing the colour attributes): median "
              f"{1000 * statistics.median(live['updates']):.0f} ms, slowest {1000 * max(live['updates']):.0f} ms "
              f"(target {1000 * LIVE_TARGET:.0f} ms); {resolved} of them re-solved.", ""]
    return "\n".join(lines)


def main(argv: list[str]) -> int:
    """Measure each scene and write the report."""
    parser = argparse.ArgumentParser(prog=f"python -m bench {STUDY}", description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="the Cornell box alone; writes into build/bench-quick/")
    options = parser.parse_args(argv)
    if scenes.missing():
        print(f"error: {scenes.missing()}", file=sys.stderr)
        return 2
    start = time.perf_counter()
    header = machine.opening()
    names = ["cornell"] if options.quick else list(SCENES)
    measurements = []
    for name in names:
        print(f"{name} ...", flush=True)
        measurements.append(value_in_fresh_process(measure, name))
    print("live (sample Cornell box in Blender) ...", flush=True)
    live = value_in_fresh_process(in_blender.measure, {"kind": "live", "blend": str(scenes.SAMPLE_BLEND),
                                                       "updates": LIVE_UPDATES})
    header |= machine.closing(header)
    text = report(measurements, live, header, (time.perf_counter() - start) / 60)
    markdown.write(text, reports(options.quick) / f"{STUDY}.md")
    return 0
