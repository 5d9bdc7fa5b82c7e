"""Progress reporting and cancellation shared by every stage of a bake."""

from __future__ import annotations

import time
from typing import Callable

ProgressCallback = Callable[[float, str], "bool | None"]

# The caller hears from a bake at least this often while it works (the contract is 0.2 s).
REPORT_INTERVAL = 0.1


class BakeCancelled(Exception):
    """Raised by ``bake`` when the progress callback returned False; nothing was produced."""


class Progress:
    """Maps each stage's own 0..1 progress into the bake's overall fraction and calls the user's
    callback at most every REPORT_INTERVAL seconds (always at stage boundaries)."""

    def __init__(self, callback: ProgressCallback | None) -> None:
        self._callback = callback
        self._last = time.perf_counter()
        self._start, self._span, self._stage = 0.0, 1.0, ""

    def stage(self, name: str, start: float, end: float) -> None:
        self._start, self._span, self._stage = start, end - start, name
        self.report(0.0, force=True)

    def report(self, fraction: float, detail: str = "", force: bool = False) -> None:
        """Tell the caller where the current stage is; raise BakeCancelled if it says stop."""
        if self._callback is None:
            return
        now = time.perf_counter()
        if not force and now - self._last < REPORT_INTERVAL:
            return
        self._last = now
        message = f"{self._stage}: {detail}" if detail else self._stage
        overall = self._start + self._span * min(max(fraction, 0.0), 1.0)
        if self._callback(overall, message) is False:
            raise BakeCancelled(f"cancelled during {self._stage}")
