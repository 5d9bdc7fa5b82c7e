"""Progress, cancellation and timing shared by every stage of a bake."""

from __future__ import annotations

import contextvars
import math
import threading
import time
from contextlib import contextmanager
from contextvars import ContextVar
from typing import Callable, Iterator, TypeVar

ProgressCallback = Callable[[float, str], "bool | None"]
Report = Callable[..., None]  # report(fraction of the stage done, detail="")
Result = TypeVar("Result")

# The caller hears from a bake at least this often while it works (the contract is 0.2 s).
REPORT_INTERVAL = 0.1


class BakeCancelled(Exception):
    """Raised by ``bake`` when the progress callback returned False; nothing was produced."""


def quiet(_fraction: float, _detail: str = "") -> None:
    """A ``Report`` that tells nobody."""


def effort(fraction_left: float, tolerance: float) -> float:
    """Progress 0..1 of an iteration as the (log of the) remaining fraction falls from 1 to the
    tolerance."""
    if fraction_left <= tolerance:
        return 1.0
    return min(max(math.log(fraction_left) / math.log(tolerance), 0.0), 1.0)


def spans(shares: dict[str, float]) -> dict[str, tuple[float, float]]:
    """Consecutive (start, end) parts of 0..1 in proportion to ``shares``, in their order."""
    total, start, result = sum(shares.values()), 0.0, {}
    for name, share in shares.items():
        result[name] = (start / total, (start + share) / total)
        start += share
    return result


class Progress:
    """Maps each stage's own 0..1 progress into the bake's overall fraction and calls the user's
    callback at most every REPORT_INTERVAL seconds (always at stage boundaries)."""

    def __init__(self, callback: ProgressCallback | None) -> None:
        self._callback = callback
        self._last = time.perf_counter()
        self._start, self._span, self._stage = 0.0, 1.0, ""
        self._fraction, self._detail = 0.0, ""

    def stage(self, name: str, start: float, end: float) -> None:
        self._start, self._span, self._stage = start, end - start, name
        self.report(0.0, force=True)

    def beat(self) -> None:
        """Tell the caller again where the stage last was (``heartbeat``)."""
        self.report(self._fraction, self._detail)

    def report(self, fraction: float, detail: str = "", force: bool = False) -> None:
        """Tell the caller where the current stage is; raise BakeCancelled if it says stop."""
        self._fraction, self._detail = fraction, detail
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


_running: ContextVar[Progress | None] = ContextVar("running", default=None)
# Work whose caller cancelled it and heard so at once; it stops at its next report, and the next
# relayed work waits for that (``stop_abandoned``).
_abandoned: list[threading.Thread] = []


class _Relay:
    """What work on a worker thread last reported, for the caller's thread to pass on."""

    def __init__(self) -> None:
        self.first = self.latest = (0.0, "starting")  # fraction and message
        self.reports = 0  # counted after ``latest`` is set
        self.cancelled = False
        self.news = threading.Event()  # a report not yet passed on, or the work's end

    def report(self, fraction: float, message: str) -> None:
        """The work's progress callback: raises BakeCancelled once the caller has cancelled."""
        if self.cancelled:
            raise BakeCancelled(f"cancelled before {message}")
        if self.reports == 0:
            self.first = (fraction, message)
        self.latest = (fraction, message)
        self.reports += 1
        self.news.set()

    def pass_on(self, callback: ProgressCallback, passed: int) -> int:
        """Call ``callback`` with the latest report, preceded by the work's first one (where its
        bar starts) if that was never passed on; return the reports passed on so far."""
        reports, latest = self.reports, self.latest
        unheard_start = [self.first] if passed == 0 and latest is not self.first else []
        for fraction, message in unheard_start + [latest]:
            if callback(fraction, message) is False:
                raise BakeCancelled(f"cancelled during {message}")
        return reports


def relayed(work: Callable[[ProgressCallback | None], Result], callback: ProgressCallback | None) -> Result:
    """``work(report)`` on a worker thread while this thread calls ``callback(fraction, message)``
    with what it last reported: at once when it reports, and every REPORT_INTERVAL while it is
    inside one long step that cannot (a sort of millions of keys, a large vectorised pass: NumPy
    and Embree's queries and BVH builds release the GIL (``embree_build``); ``np.repeat`` and
    ``np.unique(axis=0)`` do not). A cancel (``callback`` returning False) raises
    BakeCancelled here at once; the work stops at its next report, its result dropped, before the
    next relayed work starts (``stop_abandoned``)."""
    stop_abandoned()
    if callback is None:
        return work(None)
    relay, outcome = _Relay(), {}
    context = contextvars.copy_context()

    def run() -> None:
        try:
            outcome["result"] = context.run(work, relay.report)
        except BaseException as error:  # raised again in the caller's thread
            outcome["error"] = error
        finally:
            relay.news.set()

    worker = threading.Thread(target=run, name="radiosity-work", daemon=True)
    worker.start()
    passed = 0  # reports passed on
    try:
        while worker.is_alive():
            relay.news.wait(REPORT_INTERVAL)
            relay.news.clear()
            if worker.is_alive():
                passed = relay.pass_on(callback, passed)
    except BaseException:  # a cancel, or an interrupt of the caller's thread
        relay.cancelled = True
        _abandoned.append(worker)
        raise
    if "error" in outcome:
        raise outcome["error"]
    if relay.reports != passed:  # the last, as "done"
        relay.pass_on(callback, passed)
    return outcome["result"]


def stop_abandoned() -> None:
    """Wait until the work of every cancelled ``relayed`` call has stopped (each at its next
    report): no two bakes run side by side, nor touch one session at once."""
    while _abandoned:
        _abandoned[-1].join()
        _abandoned.pop()


def heartbeat() -> None:
    """Tell the caller of the bake running in this thread, if any, that it goes on (at most every
    REPORT_INTERVAL, the bar where its stage last put it), and raise BakeCancelled if it says
    stop: for long steps deep inside a stage that cannot know their share of it (the thread
    pool's waits, ``parallel.map_ordered``). The pool's own threads have no bake: they never
    raise."""
    progress = _running.get()
    if progress is not None:
        progress.beat()


class Stages:
    """Runs the stages of a bake: each in its span of the progress bar, named in the messages,
    and timed into ``seconds`` (each key's time excludes the stages run inside it, so the
    values add up to the whole)."""

    def __init__(self, callback: ProgressCallback | None) -> None:
        self.progress = Progress(callback)
        self.seconds: dict[str, float] = {}
        self._open: list[list] = []  # per running stage: [start, end, seconds of its inner stages]

    def run(self, name: str, span: tuple[float, float], function: Callable[..., Result], *args,
            timer: str | None = None) -> Result:
        """``function(*args, report)`` as the stage ``name``: ``span`` (start, end) is its part of
        the enclosing stage's progress (of the whole bake at the top level); its seconds add to
        ``seconds[timer or name]``."""
        start, end = self._part(span)
        self._open.append([start, end, 0.0])
        self.progress.stage(name, start, end)
        clock = time.perf_counter()
        running = _running.set(self.progress)
        try:
            return function(*args, self.progress.report)
        finally:
            _running.reset(running)
            elapsed = time.perf_counter() - clock
            inner = self._open.pop()[2]
            key = timer or name
            self.seconds[key] = self.seconds.get(key, 0.0) + elapsed - inner
            if self._open:
                self._open[-1][2] += elapsed

    @contextmanager
    def within(self, span: tuple[float, float]) -> Iterator[None]:
        """Stages run inside share ``span`` of the enclosing stage's progress, as ``run``'s would,
        each named and timed on its own."""
        self._open.append([*self._part(span), 0.0])
        try:
            yield
        finally:
            inner = self._open.pop()[2]
            if self._open:
                self._open[-1][2] += inner

    def _part(self, span: tuple[float, float]) -> tuple[float, float]:
        """``span`` of the enclosing stage's progress, as fractions of the whole bake."""
        low, high = (self._open[-1][0], self._open[-1][1]) if self._open else (0.0, 1.0)
        return low + span[0] * (high - low), low + span[1] * (high - low)

    def done(self) -> None:
        """The bake has finished: the caller hears 1.0."""
        self.progress.stage("done", 1.0, 1.0)
