"""progress.heartbeat: the thread pool's waits keep a bake's caller informed and cancellable;
progress.relayed: so does work inside one long step that cannot report."""

import sys
import time

import numpy as np
import pytest

from core.util import parallel
from core.util.progress import REPORT_INTERVAL, BakeCancelled, Stages, heartbeat, relayed

BLOCK_SECONDS = 0.35  # each block of work: longer than the 0.2 s promise


def slow(item: int) -> int:
    time.sleep(BLOCK_SECONDS)
    return item


def test_waiting_on_the_pool_tells_the_caller_where_the_stage_was():
    """Blocks of 0.35 s with no report of their own: the caller still hears at most every 0.2 s
    (REPORT_INTERVAL 0.1 s, so 0.2 s leaves room for a loaded machine), at the fraction the
    stage last reported and with its detail."""
    calls = []
    stages = Stages(lambda fraction, message: calls.append((time.perf_counter(), fraction, message)))

    def stage(report):
        report(0.25, "halfway there")
        return list(parallel.map_ordered(slow, range(4)))

    assert stages.run("waiting", (0.0, 0.5), stage) == [0, 1, 2, 3]
    times = [when for when, _, _ in calls]
    assert len(calls) >= 4 * BLOCK_SECONDS / parallel.THREADS / (2 * REPORT_INTERVAL)
    assert np.diff(times).max() <= 0.2
    # the first call opens the stage; the report right after it is too soon to be passed on
    assert {(fraction, message) for _, fraction, message in calls[1:]} == {(0.125, "waiting: halfway there")}


def test_a_cancel_heard_while_waiting_stops_the_work():
    """The caller says stop during the wait: BakeCancelled, and the blocks not started are dropped."""
    started = []

    def counted(item: int) -> int:
        started.append(item)
        return slow(item)

    stages = Stages(lambda fraction, message: len(started) < 2)
    with pytest.raises(BakeCancelled):
        stages.run("waiting", (0.0, 1.0), lambda report: list(parallel.map_ordered(counted, range(40))))
    time.sleep(BLOCK_SECONDS)
    assert len(started) <= 2 * parallel.THREADS + 1


def test_outside_a_bake_and_on_the_pool_a_heartbeat_is_silent():
    """No bake runs in this thread, nor in the pool's: a heartbeat there calls nobody (and so never
    raises a cancel that is not its own)."""
    heartbeat()
    calls = []

    def stop_at_the_second_call(_fraction, message):
        calls.append(message)
        return len(calls) < 2

    def on_the_pool():
        time.sleep(2 * REPORT_INTERVAL)
        heartbeat()

    Stages(stop_at_the_second_call).run("outer", (0.0, 1.0), lambda report: parallel.submit(on_the_pool).result())
    assert calls == ["outer"]


LONG_STEP = 0.6  # s: one step of the work that cannot report (three times the 0.2 s promise)


def test_relayed_work_is_heard_while_it_is_inside_one_long_step():
    """The work reports, then sleeps 0.6 s in one call (as a sort of millions of keys would, the
    GIL released): its caller still hears every 0.2 s at most, with what it last reported, and gets
    its result."""
    calls = []

    def work(report):
        report(0.5, "before the long step")
        time.sleep(LONG_STEP)
        report(1.0, "done")
        return "result"

    assert relayed(work, lambda fraction, message: calls.append((time.perf_counter(), fraction, message))) == "result"
    times = [when for when, _, _ in calls]
    assert times[-1] - times[0] >= LONG_STEP * 0.9
    assert np.diff(times).max() <= 0.2
    assert calls[-1][1:] == (1.0, "done")
    assert ({(fraction, message) for _, fraction, message in calls[:-1]}
            <= {(0.0, "starting"), (0.5, "before the long step")})


def test_relayed_work_is_heard_from_its_first_report_even_when_the_caller_wakes_late():
    """The work reports its start and its middle before the caller's thread runs again (the
    interpreter switches threads only after 10 s here): the caller still hears the start first,
    so its bar rises from where the work's bar starts, then the middle and the end."""
    calls = []

    def work(report):
        report(0.0, "start")
        report(0.5, "middle")
        time.sleep(2 * REPORT_INTERVAL)
        report(1.0, "done")

    interval = sys.getswitchinterval()
    sys.setswitchinterval(10.0)
    try:
        relayed(work, lambda fraction, message: calls.append((fraction, message)))
    finally:
        sys.setswitchinterval(interval)
    assert calls[0] == (0.0, "start") and calls[-1] == (1.0, "done")
    assert set(calls) == {(0.0, "start"), (0.5, "middle"), (1.0, "done")}


def test_a_cancel_during_a_long_step_is_heard_at_once_and_the_work_stops_at_its_next_report():
    """The caller cancels 0.2 s into a 0.6 s step: BakeCancelled reaches it within a report
    interval, the work never goes past its next report, and the next relayed work (even one
    without a callback) starts only after it has stopped."""
    events = []

    def work(report):
        report(0.1, "before")
        time.sleep(LONG_STEP)
        events.append("reported after the step")
        report(0.9, "after")
        events.append("went on after a cancel")

    started = time.perf_counter()
    with pytest.raises(BakeCancelled):
        relayed(work, lambda fraction, message: time.perf_counter() - started < 0.2)
    assert time.perf_counter() - started <= 0.2 + 2 * REPORT_INTERVAL
    assert events == []
    relayed(lambda report: events.append("the next work"), None)  # with no one to tell, too
    assert events == ["reported after the step", "the next work"]


def test_an_error_of_relayed_work_reaches_the_caller():
    def work(report):
        raise MemoryError("too large")

    with pytest.raises(MemoryError, match="too large"):
        relayed(work, lambda fraction, message: True)
