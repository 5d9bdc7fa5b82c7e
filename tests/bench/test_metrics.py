"""The benchmarks' error measures (bench/metrics.py) against values worked out by hand."""

import math

import numpy as np
import pytest

from bench.metrics import nrmse, rms, seed_noise, without_noise, worst_share


def test_rms_of_a_constant_is_its_size():
    assert rms(np.full((4, 3), -2.0)) == pytest.approx(2.0)


def test_nrmse_is_the_rms_difference_over_the_mean_of_the_yardstick():
    """Every value 0.1 off a yardstick of mean 2 (values 1 and 3): 0.1 / 2, whatever its RMS."""
    yardstick = np.array([[1.0, 3.0], [3.0, 1.0]])
    off = yardstick + np.array([[0.1, -0.1], [-0.1, 0.1]])
    assert nrmse(off, yardstick) == pytest.approx(0.05)
    assert nrmse(yardstick, yardstick) == 0.0


def test_noise_is_removed_in_quadrature():
    assert without_noise(0.05, 0.03) == pytest.approx(0.04)
    assert without_noise(0.03, 0.05) == 0.0


def test_the_noise_of_one_seed_from_two():
    """Two results e above and below the truth differ by 2e: RMS(2e) / sqrt(2) = sqrt(2) e per seed."""
    truth = np.linspace(1.0, 3.0, 12).reshape(4, 3)
    first, second = truth + 0.01, truth - 0.01
    assert seed_noise(first, second, scale=2.0) == pytest.approx(math.sqrt(2) * 0.01 / 2.0)


def test_the_worst_share_is_what_the_largest_carry():
    assert worst_share(np.array([1.0, 4.0, 2.0, 3.0]), 1) == pytest.approx(0.4)
    assert worst_share(np.array([[1.0, 4.0], [2.0, 3.0]]), 2) == pytest.approx(0.7)
    assert worst_share(np.zeros(5), 2) == 0.0
