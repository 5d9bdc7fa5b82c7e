"""The trade-off sweep's report (docs/results/tradeoffs.md): what it measured, as Markdown."""

from __future__ import annotations

from pathlib import Path

from bench import exact, markdown as md, scenes
from bench.markdown import MIB, pct, table
from bench.studies.tradeoffs_records import Answer, Record, Run, pareto_front
from core.settings import AUTO_PATCH_DIVISIONS

BASELINE = ("raycast", "progressive")  # times are also given as ratios to this method's default bake
BUDGETS = (1.0, 10.0)  # seconds: the best error within each
GOOD = 0.01  # the fastest bake with an error at most this is named


def varied(record: Record) -> str:
    """What the case changed from the defaults: "defaults", "patch extent / 8", "tolerance 0.01",
    "preset DRAFT" (several when one bake lies on several curves)."""
    case, parts = record.case, []
    for tag in case.tags:
        if tag in ("default", "reference"):
            parts.append("defaults" if tag == "default" else tag)
        elif tag == "patch_size":
            parts.append(f"patch extent / {case.divisions}")
        elif tag.startswith("preset:"):
            parts.append(f"preset {tag[7:]}")
        else:
            parts.append(f"{tag} {case.knob(tag):g}")
    return ", ".join(parts)


def settings(record: Record) -> str:
    """Method, solver and every knob of the bake, short."""
    case = record.case
    knobs = [f"patch extent/{case.divisions}"]
    knobs += [f"{name} {value:g}" for name, value in case.knobs if name != "patch_size"]
    return f"{case.combo}: " + ", ".join(knobs) + f" [{varied(record)}]"


def baseline(records: list[Record]) -> Record | None:
    """The scene's default bake with the BASELINE method and solver, if it ran."""
    return next((r for r in records if r.ok and "default" in r.case.tags
                 and (r.case.method, r.case.solver) == BASELINE), None)


def _number(value: float | None, digits: int = 3) -> str:
    return "" if value is None else f"{value:.{digits}g}"


def estimated_scenes(run: Run) -> list[str]:
    """The scenes whose compared quantity is what the core's error estimate is about: the corner
    colours (not the CIE room's lighting, under black walls whose colours are all 0)."""
    return [name for name in run.results if run.quantities[name] == "corner_colors"]


def scene_table(records: list[Record], estimated: bool = True) -> str:
    """One row per bake, in the order of the plan (the estimate left blank unless ``estimated``)."""
    base = baseline(records)
    rows = []
    front = {id(r) for r in pareto_front(records)}
    for r in records:
        if not r.ok:
            rows.append([r.case.combo, varied(r), "", "", "", "", "", "", r.status, "", "", "", ""])
            continue
        rows.append([
            r.case.combo, varied(r), f"{r.stats['patches']:,}", r.work, f"{r.wall:.3g}",
            "" if base is None else f"{r.wall / base.wall:.2f}", f"{r.cpu / r.wall:.2f}" if r.wall > 0 else "",
            f"{r.peak / MIB:.0f}", f"{r.error:.3g}", f"{100 * r.worst_share:.0f} %", _number(r.mean_error),
            _number(r.estimate) if estimated else "", "yes" if id(r) in front else "",
        ])
    return table(
        ["method / solver", "varied", "patches", "work", "wall s", "x default", "CPU s / wall s", "peak MiB",
         "NRMSE corners", "worst 5 % share", "NRMSE triangle means", "estimate", "Pareto"], rows)


def front_lines(records: list[Record]) -> list[str]:
    """The Pareto front, fastest first, one line per bake."""
    return [f"{n}. {r.wall:.3g} s, NRMSE {r.error:.3g}: {settings(r)}" for n, r in enumerate(pareto_front(records), 1)]


def best_within(records: list[Record], seconds: float) -> str:
    """The lowest error of a bake no slower than ``seconds``."""
    done = [r for r in records if r.ok and r.wall <= seconds]
    if not done:
        return "none this fast"
    best = min(done, key=lambda r: r.error)
    return f"{best.error:.3g} ({best.wall:.2g} s; {settings(best)})"


def fastest_good(records: list[Record]) -> str:
    """The fastest bake with an error of at most GOOD."""
    done = [r for r in records if r.ok and r.error <= GOOD]
    if not done:
        return f"none reaches {GOOD:g}"
    fastest = min(done, key=lambda r: r.wall)
    return f"{fastest.wall:.3g} s (NRMSE {fastest.error:.3g}; {settings(fastest)})"


def summary(results: dict[str, list[Record]]) -> list[str]:
    """Per scene: the default bake, the best errors within the BUDGETS, the fastest good bake."""
    lines = []
    for name, records in results.items():
        base = baseline(records)
        default = "not run" if base is None else f"{base.wall:.3g} s, NRMSE {base.error:.3g}"
        lines += [f"- **{name}**: default bake ({' / '.join(BASELINE)}) {default}"]
        lines += [f"  - best error within {seconds:g} s: {best_within(records, seconds)}" for seconds in BUDGETS]
        lines += [f"  - fastest to NRMSE <= {GOOD:g}: {fastest_good(records)}"]
    return lines


def truth_line(reference: Record | Answer | None, quantity: str) -> str:
    """What the scene's bakes are measured against: the exact ``quantity``, the reference bake or
    the path-traced answer."""
    if reference is None:
        return f"Exact truth (`{quantity}` of the corners of the compared triangles)."
    if isinstance(reference, Answer):
        return (f"Answer: path tracing (bench/pathtrace.py, bench/corner_answer.py) at {reference.corners:,} random "
                f"corners of the non-emitting triangles, each where a bake reads it (its node), {reference.paths:,} "
                f"paths each ({reference.seconds:.0f} s). Its noise, {pct(reference.noise)} of the mean in RMS, is "
                "removed from every error below in quadrature. Errors are measured at those corners only (the worst 5 "
                "% share too); no triangle means are compared.")
    r = reference
    stats = r.stats
    converged = (f"unshot fraction {stats['unshot_fraction']:.3g}" if "unshot_fraction" in stats
                 else f"error bound {stats.get('error_bound', float('nan')):.3g}")
    estimate = "" if r.estimate is None else f", its own error estimate {r.estimate:.3g}"
    return (f"Reference: the project at extreme settings, {settings(r)}: {stats['patches']:,} patches, {r.work}, "
            f"{converged}{estimate}; {r.wall:.0f} s, {r.peak / MIB:.0f} MiB ({r.status}). Errors are measured on the "
            "corner colours of the non-emitting triangles; below the reference's own error they are not resolved.")


def markdown(run: Run, notes: dict[str, str], figures: list[Path]) -> str:
    """The whole report, with per scene the note on its sweep, showing ``figures``."""
    results = run.results
    names = {path.name for path in figures}
    about = (f"`{md.command('tradeoffs', '--quick')}` is a small sweep for development (about a minute, written to "
             "build/bench-quick/). The machine is shared and noisy: compare times within one run (the `x default` "
             "column), not across runs.")
    lines = [
        *md.opening("Speed against accuracy: knobs, methods, solvers and presets", "tradeoffs",
                    "--quick" if run.quick else "", run.minutes, run.quick, about, run.header),
        "",
        "## Summary",
        "",
        *summary(results),
        "",
        "## How it is measured",
        "",
        "- One knob at a time moves away from bake()'s defaults (patch size = scene extent / "
        f"{AUTO_PATCH_DIVISIONS}, flat regions merged, hemicube resolution 64, 16 rays per form factor, tolerance "
        "1e-3), for each method with each solver; the presets of `core.settings` are baked with each method and "
        "solver too (the hemicube ignores their rays: the scenes have no lights or sky). The hemicube resolution is "
        "swept for the hemicube only, the rays for ray casting only. Explicit solvers (Jacobi, Gauss-Seidel: a P x P "
        "matrix) are left out where P is too large.",
        "- Each bake runs in a fresh process (bench/runner.py), so it starts without the thread pool or Embree "
        "scene of an earlier bake. It is baked twice (once if the first took over a minute) and the faster wall "
        "time counts; `CPU s / wall s` is for that run (at most the number of cores).",
        "- Peak memory: the growth of the process's peak resident set size (VmHWM, started again at its size "
        "just before the first bake) over that size: NumPy arrays, Embree's BVH and thread stacks alike.",
        "- Error: NRMSE = RMS of the difference over the mean of the truth (bench/metrics.py), over R, G and B of "
        "every corner of the compared triangles (the non-emitting ones, except in the furnace where all emit): "
        "against the exact value where there is one, otherwise against the scene's converged reference, or where "
        "no bake of ours converges (Sponza) against path tracing at random corners, with its noise removed in "
        "quadrature (both cached in build/bench/tradeoffs_cache/ under a digest of core/). `estimate` is the bake's "
        "own `stats[\"error_estimate\"][\"total\"]`, where the core reports it. `worst 5 % share`: the share of the "
        "corners' squared error carried by the worst 5 % of them (5 % when the error is spread evenly, near 100 % "
        "when a few corners carry it). `NRMSE triangle means`: the same over the triangles' area means "
        "(`triangle_radiosity`), against the reference.",
        "- Pareto front: the bakes that no other bake of the scene beats in both wall time and error; the figures "
        "draw it as a dotted staircase. Errors below 1e-6 are drawn at 1e-6.",
        "",
    ]
    for name, records in results.items():
        figure = f"tradeoffs_{name}.png"
        lines += [f"## {name}", "", describe(name) + ".", "",
                  truth_line(run.references.get(name), run.quantities[name]), ""]
        lines += [notes[name], ""] if notes.get(name) else []
        if figure in names:
            lines += [f"![{name}: error against time]({figure})", ""]
        lines += ["Pareto front, fastest first:", "", *front_lines(records), "",
                  scene_table(records, name in estimated_scenes(run)), ""]
    lines += ["## The bakes' own error estimates", ""]
    if "tradeoffs_estimates.png" in names:
        left_out = [name for name in results if name not in estimated_scenes(run)]
        lines += ["![estimated against measured error](tradeoffs_estimates.png)", ""]
        lines += [f"Left out: {', '.join(left_out)}, compared on the corners' lighting; the estimate is of the corner "
                  "colours (all 0 under its black walls).", ""] if left_out else []
    else:
        lines += ["No bake reported `stats[\"error_estimate\"]`: this core does not estimate its error yet.", ""]
    return "\n".join(lines)


def describe(name: str) -> str:
    """One line on what scene ``name`` is."""
    return exact.DESCRIPTIONS.get(name) or scenes.DESCRIPTIONS[name]
