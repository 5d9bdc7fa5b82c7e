"""BakeJob: a bake in time-budgeted slices gives the same result as bake(), reports progress
between slices, and cancels cleanly at any slice."""

import time

import numpy as np
import pytest

from core import BakeCancelled, bake
from core.job import BakeJob
from tests.core.scenes import lit_room

KNOBS = {"patch_size": 0.2}


def run(job: BakeJob, budget: float) -> tuple[int, list[float]]:
    """Step to the end; the number of slices and the fraction seen after each."""
    slices, fractions = 0, []
    while not job.step(budget):
        slices += 1
        fractions.append(job.fraction)
    return slices, fractions


def test_slices_give_the_same_colours_as_one_call():
    scene = lit_room()
    whole = bake(scene, **KNOBS)
    job = BakeJob(scene, **KNOBS)
    slices, fractions = run(job, 0.0)  # pause at every progress report
    np.testing.assert_array_equal(job.result().corner_colors, whole.corner_colors)
    assert slices >= 3
    assert fractions == sorted(fractions) and 0 <= fractions[0] and fractions[-1] <= 1


def test_a_slice_keeps_to_its_budget():
    """A slice stops at the first progress report past its budget; reports come every 0.1 s."""
    job = BakeJob(lit_room(), **KNOBS)
    longest = 0.0
    while True:
        start = time.perf_counter()
        finished = job.step(0.05)
        longest = max(longest, time.perf_counter() - start)
        if finished:
            break
    # budget + one report interval (0.1 s) + the 0.2 s the report contract allows for a gap
    assert longest < 0.05 + 0.1 + 0.2 + 0.5  # 0.5 s of slack for a loaded shared machine


@pytest.mark.parametrize("slices_before_cancel", [0, 1, 3])
def test_cancel_at_any_slice_raises_bake_cancelled(slices_before_cancel):
    job = BakeJob(lit_room(), **KNOBS)
    for _ in range(slices_before_cancel):
        assert not job.step(0.0)
    job.cancel()
    assert job.done
    with pytest.raises(BakeCancelled):
        job.result()


def test_errors_of_the_bake_reach_the_host():
    job = BakeJob(lit_room(), method="nonsense")
    assert job.step(1.0)
    with pytest.raises(ValueError, match="method"):
        job.result()


def test_result_before_the_end_is_refused():
    job = BakeJob(lit_room(), **KNOBS)
    job.step(0.0)
    with pytest.raises(RuntimeError, match="not finished"):
        job.result()
    job.cancel()
