"""Our bakes of sample_blends/cornell_box.blend against Cycles' COMBINED vertex bake of the same
file, in one run: the headline (error against time for our presets, methods x solvers and Cycles
at increasing samples, against our converged reference, cross-checked with Cycles:
versus_cycles_headline.py) and a closer look at the default bake against Cycles' highest-sample
bake (versus_cycles_closer.py). Writes docs/results/versus_cycles.md, headline.png and two
pictures for the README (cornell_box_radiosity.png, cornell_box_cycles.png).

Every bake runs in a process of its own (bench/in_blender.py). The Cycles bake follows
../shared/CYCLES.md (CPU, no adaptive sampling, no clamping, light threshold 0, 64 bounces, a
FLOAT_COLOR CORNER attribute made active, COMBINED into VERTEX_COLORS).
"""

from __future__ import annotations

import sys
from pathlib import Path

from bench import comparison, markdown, scenes
from bench.in_blender import VARIANTS
from bench.paths import raw_results, reports, shown
from bench.studies import versus_cycles_headline as headline
from bench.studies.versus_cycles_closer import CYCLES_PICTURE, OUR_PICTURE, Analysis, sections
from core.mesh.nodes import NODE_INSET

STUDY = "versus_cycles"
SAMPLES = 16384  # Cycles' highest samples per corner: the cross-check and the closer look
QUICK_SAMPLES = 256
VARIANT_SAMPLES = 1024  # Cycles bakes of a changed scene (and their unchanged twin) take this many
QUICK_VARIANT_SAMPLES = 64
CHECK_SAMPLES = 16  # per-object and all-at-once bakes compared at this many samples
PICTURE_SAMPLES = 256  # the Cycles render for the README
QUICK_PICTURE_SAMPLES = 16
PICTURE_LIMIT = 300_000  # bytes per PNG
NODE_INSETS = (NODE_INSET / 10, NODE_INSET * 10)  # our node placement, moved either way from core's
HEADLINE_PICTURE = "headline.png"


def variants(variant_samples: int) -> dict[str, tuple[str, str, dict]]:
    """Bakes of a changed scene or core: label -> (kind, what changed, the case but its file)."""
    out = {"ours one-sided": ("ours", "two-sided surfaces off", {"kind": "ours", "settings": {"two_sided": False}})}
    out |= {f"ours inset {inset:g}": ("ours", f"nodes {inset:g} of the way to their faces' centre",
                                      {"kind": "ours", "node_inset": inset}) for inset in NODE_INSETS}
    out |= {f"cycles {name}": ("cycles", change, {"kind": "cycles", "samples": variant_samples,
                                                  "seed": comparison.SEEDS[0], "variant": name})
            for name, (change, _apply) in VARIANTS.items()}
    return out


def cases(samples: int, quick: bool, docs: Path, common: dict) -> comparison.Labelled:
    """Every case of a run, labelled, in the order they run (ours and Cycles' in turn). The
    pictures go to ``docs``."""
    counts = comparison.ladder(samples)
    variant_samples = variant_samples_of(samples, quick)
    cycles = comparison.cycles_cases(counts, common)
    if variant_samples not in counts:
        cycles += comparison.cycles_cases((variant_samples,), common)[:1]
    return [("check", {"kind": "check", "samples": CHECK_SAMPLES, "seed": comparison.SEEDS[0]} | common),
            *comparison.alternate(headline.our_cases(quick, str(docs / OUR_PICTURE), common), cycles),
            *((label, case | common) for label, (_kind, _change, case) in variants(variant_samples).items()),
            ("render", {"kind": "render", "samples": QUICK_PICTURE_SAMPLES if quick else PICTURE_SAMPLES,
                        "path": str(docs / CYCLES_PICTURE)} | common)]


def variant_samples_of(samples: int, quick: bool) -> int:
    """The samples of Cycles' bakes of a changed scene in a run up to ``samples``."""
    return min(QUICK_VARIANT_SAMPLES if quick else VARIANT_SAMPLES, samples)


def measure(samples: int, quick: bool) -> dict:
    """Every case's result, with the run's header and minutes (JSON-ready)."""
    return comparison.measure(cases(samples, quick, reports(quick), scenes.blend("cornell_box").case()), {})


def report(data: dict, docs: Path) -> str:
    """Analyse a run's results; write the headline plot into ``docs``; the report."""
    samples, quick, results = data["samples"], data["quick"], data["results"]
    top = headline.Headline(results, comparison.ladder(samples), quick)
    headline.plot(top, docs / HEADLINE_PICTURE, data["header"])
    variant_samples = variant_samples_of(samples, quick)
    analysis = Analysis(
        samples=samples,
        ours=[results[headline.preset_label(headline.DEFAULT_PRESET, k)] for k in range(headline.DEFAULT_RUNS)],
        seeds=comparison.cycles_runs(results, samples),
        check=results["check"] | {"samples": CHECK_SAMPLES},
        pictures={"render": results["render"]},
        presets={name: results[headline.preset_label(name)] for name in headline.presets(quick)
                 if name != headline.DEFAULT_PRESET},
        variants={label: (kind, change, results[label])
                  for label, (kind, change, _case) in variants(variant_samples).items()},
        twin=results[comparison.cycles_label(variant_samples, comparison.SEEDS[0])],
    )
    about = (
        "Rerunning overwrites this file, the headline plot and the two pictures. Options: `--samples N` "
        f"(Cycles' highest sample count, default {SAMPLES}: the bakes go from {comparison.FIRST_SAMPLES} samples up "
        f"to it, x 4 at each step, two seeds each), `--quick` (up to {QUICK_SAMPLES} samples, fewer and cheaper "
        "bakes: a few minutes; writes into build/bench-quick/ instead), `--from-results JSON` (the report and plot "
        f"again, without baking, from the raw results every run saves: {shown(raw_results(STUDY, False))}). "
        "Every bake runs in a fresh process (bench/in_blender.py) and is timed around the bake call alone "
        "(Blender's start-up and the file load excluded). The machine is shared and noisy: compare within one run, "
        "not absolute figures across runs.")
    opening = markdown.opening("Our bake against Cycles: the Cornell box", STUDY, " ".join(data["argv"]),
                               data["minutes"], quick, about, data["header"])
    parts = [opening, headline.markdown(top, HEADLINE_PICTURE), *sections(analysis)]
    return "\n".join(line for part in parts for line in [*part, ""])


def main(argv: list[str]) -> int:
    parser = comparison.options(STUDY, __doc__.split("\n\n")[0], SAMPLES, QUICK_SAMPLES)
    data = comparison.measured_or_saved(STUDY, parser.parse_args(argv), argv, SAMPLES, QUICK_SAMPLES, measure)
    docs = reports(data["quick"])
    markdown.write(report(data, docs), docs / f"{STUDY}.md")
    for name in (HEADLINE_PICTURE, OUR_PICTURE, CYCLES_PICTURE):
        size = (docs / name).stat().st_size
        if size > PICTURE_LIMIT:
            print(f"warning: {name} is {size / 1000:.0f} kB, above {PICTURE_LIMIT / 1000:.0f} kB", file=sys.stderr)
    return 0
