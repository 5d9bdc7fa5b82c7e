"""Jacobi and Gauss-Seidel on an explicit form-factor matrix: B = E + rho * (F @ B), all channels
at once, float64, stopped by an error bound; ``report(fraction, detail)`` is called often and
raises BakeCancelled to stop."""

from __future__ import annotations

import time

import numpy as np

from ..util.progress import Report, effort, quiet

# The patch-by-patch error bound (``componentwise_bound``) takes lambda_m for m = 0, 1, ... until it
# falls by less than a part in a hundred, at most MAX_SMOOTHING + 1 products with the matrix, each as
# much as a Jacobi sweep. On the shared Cornell box Jacobi's took 3 to 13 (fewer the longer it had
# swept: its residual nears the Perron vector), Gauss-Seidel's 10.
MAX_SMOOTHING = 16
STEADY = 0.99


def _bound_factor(matrix: np.ndarray, reflectance: np.ndarray) -> float:
    """max_p rho_p sum_q |F_pq|: the contraction factor of the iteration (< 1 is required)."""
    row_sums = np.abs(matrix).sum(axis=1)
    return float((reflectance.max(axis=1) * row_sums).max())


def _check_contraction(factor: float) -> None:
    if factor >= 1.0:
        raise ValueError(
            f"the system does not converge: max rho * row sum of F = {factor:.6g} >= 1 "
            "(a form factor row sums to more than 1 / rho)"
        )


def jacobi(
    matrix: np.ndarray,
    reflectance: np.ndarray,
    emission: np.ndarray,
    tolerance: float = 1e-3,
    max_iterations: int = 1_000_000,
    report: Report = quiet,
    initial: np.ndarray | None = None,
) -> tuple[np.ndarray, dict]:
    """Jacobi iteration B <- E + rho * (F @ B), that is B <- B + r for the residual
    r = E + rho F B - B, from B = ``initial`` (default E). Stops on the error bound of
    ``_iterate``."""
    return _iterate(lambda radiosity, residual: radiosity + residual, "iteration",
                    matrix, reflectance, emission, tolerance, max_iterations, report, initial)


def gauss_seidel(
    matrix: np.ndarray,
    reflectance: np.ndarray,
    emission: np.ndarray,
    tolerance: float = 1e-3,
    max_iterations: int = 1_000_000,
    report: Report = quiet,
    initial: np.ndarray | None = None,
) -> tuple[np.ndarray, dict]:
    """Gauss-Seidel: each sweep updates B_p = E_p + rho_p sum_q F_pq B_q in place, row by row,
    using the newest values, from B = ``initial`` (default E). Stops on the error bound of
    ``_iterate``."""
    last_report = [time.perf_counter()]

    def sweep(radiosity, residual):
        done = effort(np.abs(residual).max() / max(np.abs(radiosity).max(), np.finfo(float).tiny), tolerance)
        for row in range(len(matrix)):
            radiosity[row] = emission[row] + reflectance[row] * (matrix[row] @ radiosity)
            if time.perf_counter() - last_report[0] > 0.05:
                last_report[0] = time.perf_counter()
                report(done, f"sweep row {row} of {len(matrix)}")
        return radiosity

    return _iterate(sweep, "sweep", matrix, reflectance, emission, tolerance, max_iterations, report, initial)


def _iterate(sweep, name, matrix, reflectance, emission, tolerance, max_iterations, report,
             initial=None) -> tuple[np.ndarray, dict]:
    """Run ``sweep(B, r)`` until the error bound is at most ``tolerance`` * |B|_inf: with
    q = max_p rho_p sum_q |F_pq| < 1 (a contraction), |B - B*|_inf <= |r|_inf / (1 - q). The
    statistics give that bound over |B|_inf (``error_bound``) and, as ``error_bounds`` (P, C),
    the tighter bound patch by patch (``componentwise_bound``)."""
    factor = _bound_factor(matrix, reflectance)
    _check_contraction(factor)
    radiosity = (emission if initial is None else initial).copy()
    iterations = 0
    while True:
        residual = emission + reflectance * (matrix @ radiosity) - radiosity
        scale = np.abs(radiosity).max()
        error_bound = np.abs(residual).max() / (1 - factor) / scale if scale > 0 else 0.0
        if error_bound <= tolerance or iterations >= max_iterations:
            break
        report(effort(error_bound, tolerance), f"{name} {iterations}, error bound {error_bound:.2g}")
        radiosity = sweep(radiosity, residual)
        iterations += 1
    return radiosity, {"iterations": iterations, "converged": bool(error_bound <= tolerance),
                       "residual": float(np.abs(residual).max()), "error_bound": float(error_bound),
                       "error_bounds": componentwise_bound(matrix, reflectance, residual, error_bound * scale)}


def componentwise_bound(matrix: np.ndarray, reflectance: np.ndarray, residual: np.ndarray,
                        uniform: float) -> np.ndarray:
    """(P, C) a bound on |B* - B| patch by patch, channel by channel, for B whose ``residual``
    (P, C) is r = E + A B - B, A = rho F >= 0: B* - B = sum_k A^k r, so with w_m = A^m |r| and
    lambda_m = max_p (A w_m)_p / (w_m)_p < 1 (Collatz-Wielandt: A w_m <= lambda_m w_m, hence
    A^j w_m <= lambda_m^j w_m),

        |B* - B| <= sum_{k < m} A^k |r| + w_m / (1 - lambda_m),

    the least of these for m = 0, 1, ... (until lambda_m settles) and ``uniform``, the bound on
    max |B* - B| of ``_iterate``. Where w_m is nearly A's Perron vector, lambda_m is about A's
    spectral radius, and where r keeps one sign (as from B = E) no term cancels another: the bound
    is then about the error itself. Jacobi's r is such a vector after a few sweeps (m = 0 will
    do); Gauss-Seidel's is 0 on the rows it updated last (lambda_0 is then infinite, and m >= 1 is
    needed). The uniform bound takes the largest row sum and the largest |r| instead."""
    bound = np.full(residual.shape, uniform)
    if matrix.min(initial=0.0) < 0:  # not a form-factor matrix: A^k |r| need not bound |A^k r|
        return bound
    power, before = np.abs(residual), np.zeros(residual.shape)
    last = np.full(residual.shape[1], np.inf)
    for _ in range(MAX_SMOOTHING + 1):
        spread = reflectance * (matrix @ power)
        ratio = np.divide(spread, power, out=np.where(spread > 0, np.inf, 0.0), where=power > 0)
        factor = ratio.max(axis=0)  # (C,)
        tight = factor < 1
        bound[:, tight] = np.minimum(bound[:, tight], before[:, tight] + power[:, tight] / (1 - factor[tight]))
        if tight.all() and (factor >= STEADY * last).all():  # lambda settled: about the spectral radius
            break
        before, power, last = before + power, spread, factor
    return bound
