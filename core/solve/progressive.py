"""Progressive refinement: B = E + rho * (F @ B) solved by shooting, matrix-free, all channels
at once, float64; ``report(fraction, detail)`` is called often and raises BakeCancelled to stop.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from ..util.progress import Report, effort, quiet

# Progressive refinement shoots, with the brightest patch, every patch whose unshot power is at
# least this share of its: one matrix product instead of a loop of shots (a block of Southwell's
# method), which changes little in what is shot.
TOGETHER = 0.5
# A column with at most this share of nonzero values is kept as those values and their indices.
SPARSE = 0.25


class ColumnCache:
    """Form-factor columns F[:, q] (n values each) with the share of each q's light that lands on
    a patch, iterated oldest first. A column with more than SPARSE of its values nonzero is a row
    of one array, so that a group's columns come out in one gather (the array grows by doubling
    up to ``most`` rows); one with fewer (a shot that reached its room alone, ``transport.reach``)
    keeps its nonzero values and their indices."""

    def __init__(self) -> None:
        self.most = 1 << 62
        self._rows: np.ndarray | None = None
        # q: its row, or its (indices, values), in the order the columns came
        self._slot: dict[int, int | tuple[np.ndarray, np.ndarray]] = {}
        self._capture: dict[int, float] = {}
        self._free: list[int] = []
        self._used = 0  # rows [0, used) have held a column
        self._sparse_bytes = 0

    def __contains__(self, q: int) -> bool:
        return q in self._slot

    def __len__(self) -> int:
        return len(self._slot)

    def __iter__(self):
        return iter(list(self._slot))

    @property
    def nbytes(self) -> int:
        rows = 0 if self._rows is None else self._used * self._rows.itemsize * self._rows.shape[1]
        return rows + self._sparse_bytes

    def add(self, q: int, column: np.ndarray | tuple[np.ndarray, np.ndarray], capture: float) -> None:
        """Keep ``column``: its n values, or the indices (int32) and values of its nonzero ones."""
        self._capture[q] = capture
        if isinstance(column, tuple):
            self._slot[q] = column
            self._sparse_bytes += 12 * len(column[0])
            return
        nonzero = np.flatnonzero(column)
        if len(nonzero) <= SPARSE * len(column):
            self.add(q, (nonzero.astype(np.int32), column[nonzero]), capture)
            return
        if self._free:
            slot = self._free.pop()
        else:
            slot, self._used = self._used, self._used + 1
            if self._rows is None or slot >= len(self._rows):
                rows = np.empty((min(max(16, 2 * slot), max(self.most, slot + 1)), len(column)))
                if self._rows is not None:
                    rows[:slot] = self._rows[:slot]
                self._rows = rows
        self._rows[slot] = column
        self._slot[q] = slot

    def remove(self, q: int) -> None:
        slot = self._slot.pop(q)
        if isinstance(slot, tuple):
            self._sparse_bytes -= 12 * len(slot[0])
        else:
            self._free.append(slot)
        del self._capture[q]

    def shot(self, sources: np.ndarray, shooting: np.ndarray, size: int) -> np.ndarray:
        """(size, C) sum_j F[:, sources[j]] shooting[j], for ``shooting`` (k, C) and columns of
        ``size`` values."""
        slots = [self._slot[int(q)] for q in sources]
        dense = [j for j, slot in enumerate(slots) if not isinstance(slot, tuple)]
        if len(dense) == len(slots):
            return self._rows[slots].T @ shooting
        result = self._rows[[slots[j] for j in dense]].T @ shooting[dense] if dense \
            else np.zeros((size, shooting.shape[1]))
        sparse = [j for j, slot in enumerate(slots) if isinstance(slot, tuple)]
        indices = np.concatenate([slots[j][0] for j in sparse])
        values = [slots[j][1] for j in sparse]
        for c in range(shooting.shape[1]):
            result[:, c] += np.bincount(indices, np.concatenate([v * shooting[j, c] for j, v in zip(sparse, values)]),
                                        size)
        return result

    def captures(self, sources: np.ndarray) -> np.ndarray:
        return np.array([self._capture[int(q)] for q in sources])


@dataclass
class ShootingState:
    """Where progressive refinement stands: radiosity (P + N, C) of the patches then the passive
    points, without the ambient term; unshot (P, C), signed (a refined patch may have received
    too much); the power shot so far, all of it and the part that landed on patches; and which
    patches have shot at least once (P,) bool."""

    radiosity: np.ndarray
    unshot: np.ndarray
    shots: int = 0
    power_shot: float = 0.0
    power_captured: float = 0.0
    has_shot: np.ndarray | None = None

    def __post_init__(self) -> None:
        if self.has_shot is None:
            self.has_shot = np.zeros(len(self.unshot), dtype=bool)

    @classmethod
    def start(cls, emission: np.ndarray, passive_emission: np.ndarray) -> "ShootingState":
        return cls(np.concatenate([emission, passive_emission]), emission.copy())


def progressive(
    columns: Callable[[np.ndarray, Callable[[float], None]], tuple[np.ndarray, np.ndarray]],
    areas: np.ndarray,
    reflectance: np.ndarray,
    emission: np.ndarray,
    passive_reflectance: np.ndarray | None = None,
    passive_emission: np.ndarray | None = None,
    tolerance: float = 1e-3,
    ambient: bool = True,
    max_shots: int | None = None,
    cache_bytes: int = 1 << 30,
    batch: int = 16,
    report: Report = quiet,
    state: ShootingState | None = None,
    first: np.ndarray | None = None,
    cache: ColumnCache | None = None,
) -> tuple[np.ndarray, np.ndarray, dict]:
    """Progressive refinement (Cohen, Chen, Wallace and Greenberg 1988): repeatedly shoot the
    patch q with the most unshot power, A_q sum_c |U_q,c| / L_c with L_c all the light of
    channel c (so that a faint channel is shot too), to every receiver r:

        dB_r = rho_r F[r, q] U_q;   B_r += dB_r;   U_r += dB_r (patches only);   U_q = 0.

    Receivers are the P patches, then N passive points that receive but never shoot (the
    vertices of Wallace et al. 1989), given by ``passive_reflectance`` and ``passive_emission``
    (N, C). ``columns(q, tick)`` returns F[:, q] for the k patches q, each (P + N,) values or the
    indices and values of its nonzero ones (``ColumnCache.add``), and the share of each one's
    light that lands on a patch (k,), calling ``tick(fraction done)`` as it goes.
    When the shooter's column is not at hand, the columns of the next brightest shooters are
    fetched with it (``batch`` at most), since they are about to shoot. Columns are kept while
    they fit ``cache_bytes``, so reshooting is cheap in small scenes; memory otherwise stays
    O(P + N). (Not as float32: its rounding, amplified by 1 / (1 - rho), breaks the energy
    balance of a closed room at rho = 0.9999 by 3e-4.) With the brightest shooter, every patch
    within TOGETHER of its unshot power shoots too, in one product. ``state`` (ShootingState)
    resumes an earlier solve and is updated in place; without it the solve starts from B = U = E.
    ``first`` (P,) bool: patches that each shoot once before any other patch shoots, and before
    ``max_shots`` may stop the solve (the emitters, when what is left goes to ``montecarlo``):
    their own light goes out first, and what they reflect later waits like any other light (an
    emitter that reflects is lit again by every shot, so "until the emitters have nothing left"
    would last until the whole solve converges). That first phase is at most one shot per patch
    of ``first``. ``cache`` holds the columns kept, and may come filled from an earlier solve
    with the same ``columns`` (a re-solve: ``bake.BakeSession``).

    Stops when, in every channel, the light still unshot, with all its future bounces in a
    closed scene, sum A |U| / (1 - rho_mean), is at most ``tolerance`` of all the light,
    distributed and not (where light escapes, that overestimates what is left: the stop is
    conservative). The largest share over channels is reported as ``unshot_fraction``.

    With ``ambient`` the result adds the remainder as a uniform ambient term (Cohen et al.
    1988): rho_r * c (sum A U / sum A) / (1 - c rho_mean), where c is the share of the power
    shot so far that landed on patches (as ``columns`` measures it per shooter, weighted by
    the shot's power): 1 in a closed scene, as Cohen et al. assume, and less where light
    escapes. It restores the total energy of a closed scene of uniform reflectance, and every
    value when the unshot light is uniform. (c estimates the light already shot, so it is not
    used to stop: a shooter yet to shoot may reach far more.)
    Returns B of the patches (P, C), B of the passive points (N, C) and the statistics.
    """
    patch_count, channels = emission.shape
    if passive_emission is None:
        passive_reflectance = passive_emission = np.zeros((0, channels))
    if state is None:
        state = ShootingState.start(emission, passive_emission)
    all_reflectance = np.concatenate([reflectance, passive_reflectance])
    radiosity, unshot = state.radiosity, state.unshot
    total_area = areas.sum()
    mean_reflectance = (areas @ reflectance) / total_area
    gain = 1.0 / (1.0 - mean_reflectance)  # (C,) all future bounces, closed scene
    cache = ColumnCache() if cache is None else cache
    cache_limit = max(batch, cache_bytes // (8 * len(radiosity)))
    cache.most = cache_limit + batch
    limit = state.shots + (max_shots if max_shots is not None else np.inf)  # converges for rho < 1
    shots_before = state.shots

    def undistributed() -> tuple[float, np.ndarray]:
        """The largest share over channels, and each channel's light (C,), distributed or not."""
        remaining = (areas @ np.abs(unshot)) * gain
        light = remaining + areas @ np.abs(radiosity[:patch_count])
        shares = np.divide(remaining, light, out=np.zeros_like(light), where=light > 0)
        return float(shares.max()), light

    left, light = undistributed()
    while (state.shots < limit or _waiting(state, first).any()) and left > tolerance:
        power = areas * (np.abs(unshot) / np.where(light > 0, light, 1.0)).sum(axis=1)
        waiting = _waiting(state, first)
        if waiting.any():
            power = np.where(waiting, power, 0.0)
        source = int(np.argmax(power))
        # the patches within TOGETHER of the brightest shoot with it, in one product (all of them,
        # so that ties in a symmetric scene are not broken by rounding, unless the columns would
        # not fit the cache or max_shots would be passed: not in the first phase, which it does
        # not stop)
        group = np.flatnonzero(power >= TOGETHER * power[source])
        room = np.inf if waiting.any() else limit - state.shots
        group = group[np.argsort(-power[group], kind="stable")][: max(1, int(min(cache_limit, room)))]
        missing = [int(q) for q in group if q not in cache]
        if missing:
            brightest = np.argsort(-power, kind="stable")[: batch + len(cache) + len(missing)]
            ahead = [int(q) for q in brightest if q not in cache and q not in missing]
            wanted = missing + ahead[: max(0, batch - len(missing))]
            # make room first: forget the oldest columns outside the group
            members = set(group.tolist())
            excess = len(cache) + len(wanted) - max(cache_limit, len(group))
            for q in [q for q in cache if q not in members][: max(0, excess)]:
                cache.remove(q)
            done, detail = effort(left, tolerance), f"{state.shots} shots, form factors of {len(wanted)} more"
            for start in range(0, len(wanted), batch):  # (P + N, batch) at a time
                part = wanted[start:start + batch]
                fetched, captures = columns(np.array(part), lambda _done: report(done, detail))
                for q, factors, capture in zip(part, fetched, np.clip(captures, 0.0, 1.0)):
                    cache.add(q, factors, float(capture))
        shooting = unshot[group].copy()  # (k, C)
        captures = cache.captures(group)
        shot_power = areas[group] * np.abs(shooting).sum(axis=1)
        state.power_shot += float(shot_power.sum())
        state.power_captured += float(shot_power @ captures)
        received = np.zeros_like(radiosity)
        for start in range(0, len(group), batch):  # (P + N, batch) columns at a time, not the group's
            part = group[start:start + batch]
            received += cache.shot(part, shooting[start:start + batch], len(received))
        received *= all_reflectance
        radiosity += received
        unshot[group] = 0.0
        state.has_shot[group] = True
        unshot += received[:patch_count]
        state.shots += len(group)
        left, light = undistributed()
        report(effort(left, tolerance), f"{state.shots} shots, {100 * left:.2g}% unshot")
    captured = state.power_captured / state.power_shot if state.power_shot > 0 else 1.0
    ambient_term = (areas @ unshot) / total_area * captured / (1.0 - captured * mean_reflectance)
    result = radiosity + all_reflectance * ambient_term if ambient else radiosity.copy()
    return result[:patch_count], result[patch_count:], {
        "shots": state.shots,
        "shots_this_solve": state.shots - shots_before,
        "converged": left <= tolerance,
        "unshot_fraction": left,
        "ambient": (ambient_term if ambient else 0 * ambient_term).tolist(),
        "captured_fraction": captured,
        "cached_columns": len(cache),
    }


def _waiting(state: ShootingState, first: np.ndarray | None) -> np.ndarray:
    """(P,) bool: the patches of ``first`` that have light to shoot and have not shot yet."""
    if first is None:
        return np.zeros(len(state.unshot), dtype=bool)
    return first & ~state.has_shot & state.unshot.any(axis=1)
