"""progress.heartbeat: the thread pool's waits keep a bake's caller informed and cancellable."""

import time

import numpy as np
import pytest

from core.util import parallel
from core.util.progress import REPORT_INTERVAL, BakeCancelled, Stages, heartbeat

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
