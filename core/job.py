"""A bake for hosts that must stay responsive (Blender's modal operators): ``step(budget)`` waits
about ``budget`` seconds for the bake's reports and returns.

The bake's reports come to a thread that pauses at the first report after the slice's budget
is spent and waits there for the next ``step``; so the host sees progress, can cancel, and takes
the result, all from its own thread. Reports come every REPORT_INTERVAL seconds while the bake
works, even inside one long step (``progress.relayed``: the bake's own work runs on a worker
thread of its own, and goes on while the host runs; it touches no host data).
"""

from __future__ import annotations

import threading
import time
from typing import Callable

from .bake import BakeResult, bake
from .scene import Scene
from .util.progress import BakeCancelled, stop_abandoned


class BakeJob:
    """``bake(scene, method, solver, **knobs)`` in slices (or ``work(progress)``: see
    ``running``). Nothing runs until the first step."""

    def __init__(self, scene: Scene, method: str = "raycast", solver: str = "progressive", **knobs) -> None:
        self.fraction = 0.0
        self.message = "waiting"
        self._work_function: Callable = lambda progress: bake(scene, method, solver, progress=progress, **knobs)
        self._budget = 0.0
        self._slice_start = 0.0
        self._cancel = False
        self._result: BakeResult | None = None
        self._error: BaseException | None = None
        self._finished = False
        self._go = threading.Event()  # the host lets the worker run a slice
        self._paused = threading.Event()  # the worker stopped: slice spent, or finished
        self._thread = threading.Thread(target=self._work, name="radiosity-bake", daemon=True)

    @classmethod
    def running(cls, work: Callable) -> "BakeJob":
        """A job of ``work(progress)``, which calls ``progress(fraction, message)`` as ``bake``
        does (a session's bakes, one after another) and returns what ``result()`` gives."""
        job = cls(None)
        job._work_function = work
        return job

    @property
    def done(self) -> bool:
        """True once the bake finished, failed or was cancelled."""
        return self._finished

    def step(self, budget: float) -> bool:
        """Let the bake work for about ``budget`` seconds; True once it has finished (then
        ``result()`` returns or raises)."""
        if self.done:
            return True
        self._budget = budget
        self._paused.clear()
        self._slice_start = time.perf_counter()
        if self._thread.ident is None:
            self._thread.start()
        else:
            self._go.set()
        self._paused.wait()
        return self._finished

    def cancel(self) -> None:
        """Stop the bake at its next progress report and wait for it; ``result()`` then raises
        BakeCancelled (unless it had already finished)."""
        self._cancel = True
        if self._thread.ident is None:
            self._error, self._finished = BakeCancelled("cancelled before it started"), True
            return
        self._go.set()
        self._thread.join()
        stop_abandoned()

    def result(self) -> BakeResult:
        """The finished bake's result; the bake's own exception if it failed or was cancelled."""
        if not self.done:
            raise RuntimeError("the bake has not finished: call step() until it returns True")
        if self._error is not None:
            raise self._error
        return self._result

    def _work(self) -> None:
        try:
            self._result = self._work_function(self._report)
        except BaseException as error:  # handed to the host thread by result()
            self._error = error
        finally:
            self._finished = True
            self._paused.set()

    def _report(self, fraction: float, message: str) -> bool:
        self.fraction, self.message = fraction, message
        if not self._cancel and time.perf_counter() - self._slice_start >= self._budget:
            self._go.clear()
            self._paused.set()
            self._go.wait()
        return not self._cancel

