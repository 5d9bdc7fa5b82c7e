"""Running a function in a fresh interpreter (bench/runner.py): its value, its errors, a timeout,
and what the process used."""

import math
import time

from bench.runner import in_fresh_process, peak_resident, reset_peak, resident

MIB = 1 << 20


def test_the_value_comes_back_with_the_time_and_memory_the_process_took():
    outcome = in_fresh_process(math.factorial, 10)
    assert outcome.ok and outcome.value == 3628800
    assert outcome.wall > 0 and outcome.cpu > 0 and outcome.peak > MIB


def test_the_peak_is_the_child_s_own():
    outcome = in_fresh_process(bytearray, 100 * MIB)
    assert outcome.ok and len(outcome.value) == 100 * MIB
    assert outcome.peak >= 100 * MIB


def test_an_error_is_reported_not_raised():
    outcome = in_fresh_process(math.sqrt, -1.0)
    assert outcome.status == "failed: ValueError: math domain error" and outcome.value is None


def test_a_process_that_runs_too_long_is_stopped():
    start = time.perf_counter()
    outcome = in_fresh_process(time.sleep, 30, timeout=1.0)
    assert outcome.status == "timed out" and time.perf_counter() - start < 10


def test_the_peak_starts_again_from_the_size_now():
    block = bytearray(64 * MIB)
    block[::4096] = b"x" * len(block[::4096])  # touch every page
    del block
    reset_peak()
    assert peak_resident() - resident() < 16 * MIB
