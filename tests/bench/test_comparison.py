"""What the studies against Cycles share (bench/comparison.py): the ladder of samples, Cycles'
time at an error along its curve, and the corners of a bake."""

import math

import numpy as np
import pytest

from bench.comparison import Corners, CyclesAnswer, cycles_label, ladder, seconds_at


def test_the_ladder_goes_up_by_four_to_the_top():
    assert ladder(16384) == (16, 64, 256, 1024, 4096, 16384)
    assert ladder(100) == (16, 64, 100)
    assert ladder(32) == (16, 32)


# Cycles' noise law: error = 0.8 / sqrt(samples) at 0.01 s per sample, so seconds = 0.0064 / error^2.
SAMPLES = (16, 64, 256)
ERRORS = [0.8 / math.sqrt(n) for n in SAMPLES]
SECONDS = [0.01 * n for n in SAMPLES]


@pytest.mark.parametrize("error", [0.2, 0.1, 0.05])
def test_cycles_time_inside_its_curve_is_the_power_law_through_it(error):
    seconds, how = seconds_at(error, ERRORS, SECONDS)
    assert seconds == pytest.approx(0.0064 / error**2) and how == ""


@pytest.mark.parametrize("error", [0.3, 0.01])
def test_cycles_time_beyond_its_curve_is_extrapolated(error):
    """Above its highest error along the first segment, below its lowest along 1 / error^2: both
    the same law here."""
    seconds, how = seconds_at(error, ERRORS, SECONDS)
    assert seconds == pytest.approx(0.0064 / error**2) and how == "extrapolated"


def test_no_time_reaches_no_error():
    assert seconds_at(0.0, ERRORS, SECONDS)[0] == math.inf


def mesh(colours, weights):
    return {"colours": colours, "weights": weights}


RESULT = {"objects": {"floor": mesh([[1.0, 1.0, 1.0], [3.0, 3.0, 3.0]], [1.0, 3.0]),
                      "wall": mesh([[0.5, 0.0, 0.0]], [2.0])}}


def test_corners_stack_the_meshes_in_the_order_of_the_result():
    corners = Corners.of(RESULT)
    assert corners.colours.tolist() == [[1, 1, 1], [3, 3, 3], [0.5, 0, 0]]
    assert corners.surface.tolist() == [0, 0, 1]
    assert corners.surface_means().tolist() == [[2.5, 2.5, 2.5], [0.5, 0, 0]]  # area-weighted


def test_cycles_answer_is_the_mean_of_its_seeds_with_their_noise():
    first = {"objects": {"floor": mesh([[1.1, 1.1, 1.1], [2.9, 2.9, 2.9]], [1.0, 1.0])}}
    second = {"objects": {"floor": mesh([[0.9, 0.9, 0.9], [3.1, 3.1, 3.1]], [1.0, 1.0])}}
    answer = CyclesAnswer([first, second])
    assert answer.colours == pytest.approx(np.array([[1.0] * 3, [3.0] * 3]))
    assert answer.scale == pytest.approx(2.0)
    assert answer.seed_noise == pytest.approx(math.sqrt(2) * 0.1 / 2.0)
    assert answer.noise == pytest.approx(0.1 / 2.0)
    assert cycles_label(64, 2) == "cycles 64 seed 2"
