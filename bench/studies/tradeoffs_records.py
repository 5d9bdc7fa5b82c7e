"""What the trade-off sweep bakes and what it measured, and the Pareto front."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from core import BakeSettings

COMBOS = tuple((method, solver) for method in ("raycast", "hemicube")
               for solver in ("progressive", "jacobi", "gauss_seidel")) + (("raycast", "hierarchical"),)


@dataclass(frozen=True)
class Case:
    """One bake: ``knobs`` (sorted (name, value) pairs, those at bake()'s defaults left out) go
    to bake() as they are. ``tags`` say which curves it lies on: a knob swept around the
    defaults, "default", "reference" or "preset:NAME"; ``divisions`` is the patch size as a
    fraction of the scene's extent."""

    scene: str
    method: str
    solver: str
    knobs: tuple[tuple[str, float], ...]
    divisions: int
    tags: tuple[str, ...] = ()

    @property
    def key(self) -> tuple:
        """What makes two cases the same bake."""
        return self.scene, self.method, self.solver, self.knobs

    @property
    def combo(self) -> str:
        """method / solver."""
        return f"{self.method} / {self.solver}"

    def knob(self, name: str):
        """The value of knob ``name`` in this bake (bake()'s default unless the case sets it)."""
        return dict(self.knobs).get(name, getattr(BakeSettings(), name))


@dataclass
class Record:
    """What one case measured. ``walls`` are the wall seconds of each timed run (the minimum
    counts); ``peak`` is the growth of the bake process's peak resident set over its size
    before the first run, in bytes; ``error`` is the NRMSE of the corners against the truth or
    the reference (None for a failed bake), ``mean_error`` that of the triangle means against
    the reference; ``worst_share`` is the share of the corners' squared error that the worst
    5 % of them carry; ``status`` is "ok" or why there is no measurement."""

    case: Case
    status: str = "ok"
    walls: tuple[float, ...] = ()
    cpu: float = 0.0
    peak: int = 0
    stats: dict = field(default_factory=dict)
    error: float | None = None
    mean_error: float | None = None
    worst_share: float | None = None

    @property
    def ok(self) -> bool:
        """Baked and scored, with a finite error."""
        return self.status == "ok" and self.error is not None and math.isfinite(self.error)

    @property
    def wall(self) -> float:
        """The fastest of the timed runs."""
        return min(self.walls)

    @property
    def estimate(self) -> float | None:
        """The bake's own estimate of its relative RMS error (stats["error_estimate"]["total"]),
        if the core reports one."""
        estimate = self.stats.get("error_estimate")
        return None if not isinstance(estimate, dict) else estimate.get("total")

    @property
    def work(self) -> str:
        """Shots (progressive) or sweeps (Jacobi, Gauss-Seidel), and whether the solver converged
        or Monte Carlo carried the rest."""
        count = self.stats.get("shots", self.stats.get("iterations"))
        unit = ("shot" if "shots" in self.stats else "sweep") + ("" if count == 1 else "s")
        if "monte_carlo" in self.stats:
            return f"{count:,} {unit}, then Monte Carlo"
        return f"{count:,} {unit}" + ("" if self.stats.get("converged", True) else " (stopped)")


@dataclass(frozen=True)
class Answer:
    """A path-traced answer's summary (bench/corner_answer.py): its corners, the paths at each, its noise
    (RMS of the standard errors over the mean) and the seconds the paths took."""

    corners: int
    paths: int
    noise: float
    seconds: float


@dataclass
class Run:
    """What one run of the sweep measured: the records per scene; per benchmark scene the
    reference bake's record or the path-traced answer's summary; per scene the BakeResult array
    compared; the machine, its load and the core (``header``), the minutes the run took, and
    whether it was the quick sweep."""

    results: dict[str, list[Record]]
    references: dict[str, Record | Answer]
    quantities: dict[str, str]
    header: dict[str, str]
    minutes: float
    quick: bool


SAME_ERROR = 0.01  # errors closer than this, relatively, are the same for the Pareto front


def pareto_front(records: list[Record]) -> list[Record]:
    """The records no other record beats in both wall time and error, fastest first: sorted by
    time (ties: the lower error first), each one whose error is below every faster one's by more
    than SAME_ERROR (less is rounding and sampling noise, not a better bake)."""
    front: list[Record] = []
    for record in sorted((r for r in records if r.ok), key=lambda r: (r.wall, r.error)):
        if not front or record.error < front[-1].error * (1 - SAME_ERROR):
            front.append(record)
    return front
