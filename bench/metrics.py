"""The error measures of every study, with one denominator: the mean of the yardstick.

    nrmse(values, yardstick) = RMS(values - yardstick) / mean(yardstick)

over every element given (corners x R, G, B channels). The mean, not the RMS, so that a few bright
values (an emitter's corners) do not hide the error everywhere else. A yardstick with noise of
its own (Cycles' bakes, path tracing) has that noise removed in quadrature before a difference is
called an error (../shared/CYCLES.md); noise is measured from two seeds.
"""

from __future__ import annotations

import math

import numpy as np


def rms(values: np.ndarray) -> float:
    """The root mean square of ``values``, over every element."""
    return float(np.sqrt(np.mean(np.square(values))))


def nrmse(values: np.ndarray, yardstick: np.ndarray) -> float:
    """RMS(values - yardstick) / mean(yardstick), over every element of the same-shaped arrays."""
    return rms(values - yardstick) / float(np.mean(yardstick))


def without_noise(error: float, noise: float) -> float:
    """sqrt(error^2 - noise^2): the part of ``error`` that ``noise`` does not explain (0 if none)."""
    return math.sqrt(max(error**2 - noise**2, 0.0))


def seed_noise(first: np.ndarray, second: np.ndarray, scale: float) -> float:
    """One seed's noise relative to ``scale``, from two results that differ only in their seed:
    RMS(first - second) / sqrt(2) / scale. The mean of the two has 1 / sqrt(2) of it."""
    return rms(first - second) / math.sqrt(2) / scale


def worst_share(squares: np.ndarray, count: int) -> float:
    """The share of sum(squares) that the ``count`` largest of ``squares`` carry (0 if all are 0)."""
    total = float(np.sum(squares))
    return float(np.sort(squares, axis=None)[::-1][:count].sum() / total) if total > 0 else 0.0
