"""The trade-off sweep's figures (matplotlib, PNG): per scene, error against wall time for each knob
(log-log, one curve per method / solver) with the presets and the Pareto front, and memory
against time; over all scenes, the bakes' own error estimates against their measured errors."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from matplotlib import ticker  # noqa: E402

from bench.markdown import MIB  # noqa: E402
from bench.studies.tradeoffs_records import COMBOS, Record, pareto_front  # noqa: E402

ERROR_FLOOR = 1e-6  # errors below this (exact to rounding) are drawn at it
COLOURS = dict(zip(COMBOS, ("tab:blue", "tab:cyan", "tab:purple", "tab:orange", "tab:red", "tab:brown", "tab:green")))
MARKERS = {"progressive": "o", "jacobi": "s", "gauss_seidel": "^", "hierarchical": "D"}
PANEL_TITLES = {
    "patch_size": "patch size (extent / d)",
    "hemicube_resolution": "hemicube resolution",
    "rays_per_form_factor": "rays per form factor",
    "tolerance": "tolerance",
    "refinement_levels": "refinement levels",
    "max_shots": "shots (progressive refinement stopped after)",
    "monte_carlo_rays": "Monte Carlo: final-gather rays per vertex",
    "near_field": "near field on (1) or off (0)",
    "merge_flat": "flat regions merged (1) or not (0)",
    "link_tolerance": "hierarchical: link tolerance",
    "denoise": "Monte Carlo: denoise strength (0: off)",
}
PRESET_LETTERS = {"DRAFT": "D", "PREVIEW": "Pv", "PRODUCTION": "Pr", "REFERENCE": "R"}


def write_all(results: dict[str, list[Record]], output: Path, estimated: list[str]) -> list[Path]:
    """One figure per scene, and the estimate figure of the scenes ``estimated`` if any of their
    bakes estimated its error (a stale one is removed otherwise); returns the paths written."""
    paths = []
    for name, records in results.items():
        paths.append(output / f"tradeoffs_{name}.png")
        scene_figure(name, records, paths[-1])
    estimates = output / "tradeoffs_estimates.png"
    chosen = {name: results[name] for name in estimated}
    if any(r.ok and r.estimate is not None for records in chosen.values() for r in records):
        estimate_figure(chosen, estimates)
        paths.append(estimates)
    else:
        estimates.unlink(missing_ok=True)
    return paths


def knob_value(record: Record, knob: str) -> float:
    """Where a point lies along the knob: the patch size's divisions of the extent, the shots
    taken for ``max_shots`` (None, its default, stops where the solver does; 0 for the explicit
    solvers, which take none), else the knob."""
    if knob == "patch_size":
        return record.case.divisions
    if knob == "max_shots":
        return record.stats.get("shots", 0)
    return record.case.knob(knob)


def point_label(record: Record, knob: str) -> str:
    """The knob's value at a point, short: "/8", "128", "16", "1e-03"."""
    value = knob_value(record, knob)
    if knob == "patch_size":
        return f"/{value}"
    return f"{value:.0e}" if knob == "tolerance" else f"{value:g}"


def curve(records: list[Record], combo: tuple[str, str], knob: str) -> list[Record]:
    """The records of one method / solver on the knob's curve, in the knob's order: the default
    bake lies on every curve, so a curve of one record means the knob was not varied."""
    on = [r for r in records if r.ok and (r.case.method, r.case.solver) == combo
          and (knob in r.case.tags or "default" in r.case.tags)]
    return sorted(on, key=lambda r: knob_value(r, knob))


def _error(record: Record) -> float:
    return max(record.error, ERROR_FLOOR)


def _front(axes, records: list[Record]) -> None:
    """The Pareto front as a staircase: no bake lies below and left of it."""
    front = pareto_front(records)
    if front:
        axes.step([r.wall for r in front], [_error(r) for r in front], where="post", color="black",
                  linewidth=0.8, linestyle=":", marker="o", markersize=7, markerfacecolor="none",
                  label="Pareto front", zorder=1)


def _axes_style(axes, title: str) -> None:
    """Log-log, a grid, small type (the ticks are set once the ranges are known: _ticks)."""
    axes.set_xscale("log")
    axes.set_yscale("log")
    axes.set_title(title, fontsize=9)
    axes.set_xlabel("wall s (fastest of the runs)", fontsize=8)
    axes.set_ylabel("NRMSE of corners", fontsize=8)
    axes.tick_params(labelsize=7)
    axes.grid(True, which="both", linewidth=0.3, alpha=0.5)


def knob_panel(axes, records: list[Record], knob: str) -> None:
    """Error against time along one knob, a curve per method / solver, values written by the points."""
    for combo in COMBOS:
        points = curve(records, combo, knob)
        if len(points) < 2:  # the knob was not varied for this method / solver
            continue
        axes.plot([r.wall for r in points], [_error(r) for r in points], color=COLOURS[combo],
                  marker=MARKERS[combo[1]], markersize=4, linewidth=1,
                  linestyle="-" if combo[0] == "raycast" else "--", label=" / ".join(combo), zorder=2)
        for r in points:
            axes.annotate(point_label(r, knob), (r.wall, _error(r)), fontsize=6, xytext=(3, 2),
                          textcoords="offset points", color=COLOURS[combo])
    _front(axes, records)
    _axes_style(axes, PANEL_TITLES[knob])


def preset_panel(axes, records: list[Record]) -> None:
    """Every bake in grey, the presets coloured by method / solver, and the Pareto front."""
    done = [r for r in records if r.ok]
    axes.scatter([r.wall for r in done], [_error(r) for r in done], s=6, color="0.75", zorder=1)
    for r in done:
        for tag in r.case.tags:
            if tag.startswith("preset:"):
                combo = (r.case.method, r.case.solver)
                axes.scatter(r.wall, _error(r), marker="*", s=60, color=COLOURS[combo], zorder=3)
                axes.annotate(PRESET_LETTERS.get(tag[7:], tag[7:]), (r.wall, _error(r)), fontsize=6,
                              xytext=(3, 2), textcoords="offset points")
    _front(axes, records)
    _axes_style(axes, "presets (D draft, Pv preview, Pr production, R reference) and all bakes")


def memory_panel(axes, records: list[Record]) -> None:
    """Peak memory growth against time, per method / solver."""
    for combo in COMBOS:
        done = [r for r in records if r.ok and (r.case.method, r.case.solver) == combo]
        if done:
            axes.scatter([r.wall for r in done], [max(r.peak, 1) / MIB for r in done], s=12,
                         color=COLOURS[combo], marker=MARKERS[combo[1]], label=" / ".join(combo))
    _axes_style(axes, "peak memory growth of the bake process")
    axes.set_ylabel("MiB", fontsize=8)


def _ticks(axes) -> None:
    """Ticks written plainly, at 1, 2 and 5 times the powers of ten an axis spans (at the powers
    alone when it spans more than three)."""
    for axis, (low, high) in ((axes.xaxis, axes.get_xlim()), (axes.yaxis, axes.get_ylim())):
        subs = (1.0, 2.0, 5.0) if high / low <= 1e3 else (1.0,)
        axis.set_major_locator(ticker.LogLocator(subs=subs, numticks=40))
        axis.set_major_formatter(ticker.FuncFormatter(lambda value, _position: f"{value:g}"))
        axis.set_minor_formatter(ticker.NullFormatter())


def limits(values: list[float], margin: float) -> tuple[float, float]:
    """A log axis's range around ``values``, ``margin`` times wider at each end."""
    return min(values) / margin, max(values) * margin


def scene_figure(name: str, records: list[Record], path: Path) -> None:
    """A panel per knob the scene's sweep varied, then the presets, memory and the legend, four
    to a row; every panel spans the same times, and every error panel the same errors, so that
    panels compare at a glance."""
    knobs = [knob for knob in PANEL_TITLES if any(len(curve(records, combo, knob)) > 1 for combo in COMBOS)]
    rows = -(-(len(knobs) + 3) // 4)
    figure, panels = plt.subplots(rows, 4, figsize=(19, 4.75 * rows), squeeze=False)
    panels = list(panels.flat)
    done = [r for r in records if r.ok]
    times = limits([r.wall for r in done], 1.4) if done else None
    errors = limits([_error(r) for r in done], 1.6) if done else None
    for axes, knob in zip(panels, knobs):
        knob_panel(axes, records, knob)
        axes.set(xlim=times, ylim=errors)
    preset_panel(panels[len(knobs)], records)
    panels[len(knobs)].set(xlim=times, ylim=errors)
    memory_panel(panels[len(knobs) + 1], records)
    panels[len(knobs) + 1].set(xlim=times)
    handles = {label: handle for axes in panels for handle, label in zip(*axes.get_legend_handles_labels())}
    order = [" / ".join(combo) for combo in COMBOS] + ["Pareto front"]
    for axes in panels[: len(knobs) + 2]:
        _ticks(axes)
    for axes in panels[len(knobs) + 2:]:
        axes.axis("off")
    labels = [label for label in order if label in handles]
    panels[-1].legend([handles[label] for label in labels], labels, loc="center", fontsize=9,
                      title="method / solver (line: ray casting, dashed: hemicube)")
    figure.suptitle(f"{name}: error against wall time, one knob at a time around the defaults "
                    f"(errors below {ERROR_FLOOR:g} drawn at it)", fontsize=11)
    figure.tight_layout(rect=(0, 0, 1, 0.97))
    figure.savefig(path, dpi=110)
    plt.close(figure)


def estimate_figure(results: dict[str, list[Record]], path: Path) -> None:
    """The bakes' own error estimates against the measured errors, log-log, with y = x."""
    figure, axes = plt.subplots(figsize=(6.5, 6))
    low, high = 1.0, 0.0
    for index, (name, records) in enumerate(results.items()):
        pairs = [(_error(r), max(r.estimate, ERROR_FLOOR)) for r in records if r.ok and r.estimate is not None]
        if pairs:
            measured, estimated = zip(*pairs)
            axes.scatter(measured, estimated, s=12, color=f"C{index}", label=name)
            low, high = min(low, *measured, *estimated), max(high, *measured, *estimated)
    axes.plot([low, high], [low, high], color="black", linewidth=0.8, label="estimate = measured")
    _axes_style(axes, "the bake's error estimate (stats['error_estimate']['total']) against the measured error")
    axes.set_xlabel("measured NRMSE of corners", fontsize=8)
    axes.set_ylabel("estimated", fontsize=8)
    _ticks(axes)
    axes.legend(fontsize=8)
    figure.tight_layout()
    figure.savefig(path, dpi=110)
    plt.close(figure)
