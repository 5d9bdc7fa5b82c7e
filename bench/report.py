"""The benchmark's tables in Markdown, and the errors against each scene's reference bake."""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from measure import Measurement

MIB = float(1 << 20)


def nrmse(values: np.ndarray, reference: np.ndarray, scale: str = "rms") -> float:
    """RMS of the difference over the RMS (``scale="rms"``) or the mean (``scale="mean"``) of the
    reference, over every element."""
    if scale not in ("rms", "mean"):
        raise ValueError(f"scale must be 'rms' or 'mean', got {scale!r}")
    norm = np.sqrt(np.mean(reference**2)) if scale == "rms" else np.mean(reference)
    return float(np.sqrt(np.mean((values - reference) ** 2)) / norm)


class Errors(NamedTuple):
    """NRMSE against the reference bake, over all triangles and over the non-emitting ones (an
    emitter's corners carry its emission, which can dominate the reference's RMS)."""

    corners: float
    triangles: float
    lit_corners: float
    lit_triangles: float


def errors(measurements: list[Measurement]) -> list[Errors | None]:
    """Errors of each bake against the reference bake of the same scene; None for the references."""
    references = {m.case.scene: m for m in measurements if m.case.reference}
    result: list[Errors | None] = []
    for m in measurements:
        reference = references[m.case.scene]
        lit = ~m.emitting
        result.append(None if m is reference else Errors(
            nrmse(m.corner_colors, reference.corner_colors),
            nrmse(m.triangle_radiosity, reference.triangle_radiosity),
            nrmse(m.corner_colors[lit], reference.corner_colors[lit]),
            nrmse(m.triangle_radiosity[lit], reference.triangle_radiosity[lit]),
        ))
    return result


def markdown_table(header: list[str], rows: list[list[str]]) -> str:
    """A Markdown table."""
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    return "\n".join(lines + ["| " + " | ".join(row) + " |" for row in rows])


def _knobs(m: Measurement) -> str:
    """The method and the knobs the case gave bake()."""
    knobs = ", ".join(f"{key}={value:g}" if isinstance(value, float) else f"{key}={value}"
                      for key, value in m.case.knobs.items())
    return f"{m.case.method}" + (f", {knobs}" if knobs else " (defaults)")


def _stages(m: Measurement) -> str:
    """Seconds of each stage of the bake, as bake() measured them."""
    return ", ".join(f"{stage} {seconds:.2f}" for stage, seconds in m.stats["seconds"].items() if stage != "total")


def quality_table(measurements: list[Measurement], errs: list[Errors | None]) -> str:
    """Settings, size of the discretisation, convergence and errors per bake."""
    rows = []
    for m, error in zip(measurements, errs):
        s = m.stats
        rows.append([
            m.case.label, _knobs(m), f"{s['settings']['patch_size']:.4g}",
            f"{s['triangles']:,}", f"{s['patches']:,}", f"{s['nodes']:,}", f"{s['shots']:,}",
            f"{100 * s['unshot_fraction']:.3g} %",
            *(["reference"] * 4 if error is None else [f"{value:.4f}" for value in error]),
        ])
    return markdown_table(["bake", "method, knobs", "patch size", "triangles", "patches", "nodes", "shots", "unshot",
                           "NRMSE corners", "NRMSE triangle means", "NRMSE corners, non-emitting",
                           "NRMSE triangle means, non-emitting"], rows)


def speed_table(measurements: list[Measurement]) -> str:
    """Seconds per stage, wall and CPU time, and bake against raw Embree ray throughput."""
    rows = [[
        m.case.label, _stages(m), f"{m.wall:.2f}", f"{m.cpu / m.wall:.2f}",
        f"{m.stats['rays_cast']:,}", f"{m.bake_rays_per_second / 1e6:.2f}",
        f"{m.raw_rays_per_second / 1e6:.2f} ({m.raw_query})", f"{100 * m.ratio:.0f} %", f"{100 * m.cpu_ratio:.0f} %",
    ] for m in measurements]
    return markdown_table(["bake", "seconds per stage", "wall s", "CPU s / wall s", "rays cast",
                           "bake Mrays/s", "raw Embree Mrays/s", "bake / raw", "bake / raw per CPU s"], rows)


def memory_table(measurements: list[Measurement]) -> str:
    """tracemalloc peak, the process's ru_maxrss, and the bake's own estimate, in MiB."""
    rows = [[
        m.case.label, f"{m.traced_peak / MIB:.1f}", f"{m.maxrss_after / MIB:.0f}",
        f"{(m.maxrss_after - m.maxrss_before) / MIB:+.0f}", f"{m.stats['peak_memory_estimate'] / MIB:.1f}",
        "yes" if m.repeatable else "NO",
    ] for m in measurements]
    return markdown_table(["bake", "tracemalloc peak MiB", "ru_maxrss MiB", "ru_maxrss over the loaded scene MiB",
                           "peak_memory_estimate MiB", "rerun identical"], rows)
