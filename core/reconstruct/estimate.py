"""How far a bake's corner colours may be from the converged answer: the light not yet
distributed (or, where Monte Carlo carried it, the final gather's noise: ``monte_carlo_error``),
plus the error of representing radiosity as constant over each patch, plus the noise of the sky's
directions at the nodes that see part of it (the spread of their looks along its outline).

Errors are relative RMS over the receiver nodes that emit nothing, all channels:
sqrt(mean |c - c*|^2) / mean |c*| (the NRMSE the benchmarks measure, docs/results/tradeoffs.md).

Discretisation, by the first of three measures that applies:
- with ray casting and the near field, how far the patches next to each node are from linear,
  rho_n sum_{q near n} F(n, q) |mean corner colour - B_q| (``nearfield.reading_error``); where
  Monte Carlo's final gather read the patches next to the nodes where its rays landed, what that
  changed at each node (``gather.Gathered.near_change``) stands in for it;
- after adaptive refinement, LEVEL_FACTOR times the change of the node colours in the last
  level: if each level shrinks the error by a factor r, what is left after it is the sum of the
  changes still to come, r / (1 - r) times the last one, at most 2 for r <= 2/3 (the reflective
  cube room of tests/core/test_error_estimate.py is about that);
- on one level, the gap between each corner's colour (evaluated at the corner) and the radiosity
  of its triangle's patch nearest that corner (evaluated at the patch's receiving point): the
  change of radiosity across a patch's reach, which a constant patch cannot represent. Loose,
  but it covers the hemicube's aliasing at the nodes, which the first two do not: hemicube bakes
  take at least this one.
"""

from __future__ import annotations

import numpy as np

from ..mesh.discretize import Discretization

LEVEL_FACTOR = 2.0
# Ray geometry is float32 in a unit-size space (``rays.visibility``): no estimate claims better.
ROUNDING_FLOOR = 1e-6


def solver_error(mesh: Discretization, colors: np.ndarray, radiosity: np.ndarray, solve_stats: dict) -> float:
    """The solver's part, relative to the mean light of what emits nothing.

    Progressive: the unshot light with its future bounces, u / (1 - u) sum_p A_p B_p, where u
    is ``unshot_fraction`` (of all light), over sum_quiet A_p B_p. Jacobi, Gauss-Seidel: the
    RMS of their patch-by-patch bound (``rms_error_bound``: ``rms_patch_error``) over the mean
    of the node ``colors`` (N, C) that emit nothing, which read the patches' errors through form
    factors that sum to at most 1 (infinite where those are all dark and the bound is not 0).
    Hierarchical: the bound on max |B - B*|, ``error_bound`` max |B|, over the quiet patches'
    mean |B|."""
    if "rms_error_bound" in solve_stats:
        scale, left = _mean_colour(colors, ~mesh.node_emission.any(axis=1)), solve_stats["rms_error_bound"]
        return left / scale if scale > 0 else (float("inf") if left > 0 else 0.0)
    quiet = _quiet_patches(mesh)
    light = mesh.patch_areas @ np.abs(radiosity).sum(axis=1)
    quiet_light = mesh.patch_areas[quiet] @ np.abs(radiosity[quiet]).sum(axis=1)
    if quiet_light <= 0:
        return 0.0
    if "unshot_fraction" in solve_stats:
        left = solve_stats["unshot_fraction"]
        return float(left / (1 - left) * light / quiet_light) if left < 1 else float("inf")
    mean = quiet_light / (mesh.patch_areas[quiet].sum() * radiosity.shape[1])
    return float(solve_stats["error_bound"] * np.abs(radiosity).max() / mean)


def rms_patch_error(mesh: Discretization, bounds: np.ndarray) -> float:
    """sqrt(sum_p A_p |e_p|^2 / sum_p A_p) over the patches that emit nothing and all channels:
    the RMS, weighed by area, of a bound ``bounds`` e (P, C) on each patch's error
    (``iterative.componentwise_bound``)."""
    quiet = _quiet_patches(mesh)
    areas = mesh.patch_areas[quiet]
    return float(np.sqrt((areas @ (bounds[quiet] ** 2).mean(axis=1)) / areas.sum()))


def _quiet_patches(mesh: Discretization) -> np.ndarray:
    """(P,) the patches that emit nothing (all, where every patch emits)."""
    quiet = ~mesh.patch_emission.any(axis=1)
    return quiet if quiet.any() else np.ones_like(quiet)


def monte_carlo_error(mesh: Discretization, colors: np.ndarray, standard_error: np.ndarray) -> float:
    """The Monte Carlo remainder's part (``montecarlo``): the RMS of the nodes' standard errors
    (N, C) over the mean colour of the nodes that emit nothing. It counts each node's own
    sampling spread, and through it the noise of the patches it reads; not the blur of pooling."""
    return relative_rms(standard_error, colors, ~mesh.node_emission.any(axis=1))


def relative_rms(difference: np.ndarray, colors: np.ndarray, quiet: np.ndarray) -> float:
    """sqrt(mean |difference|^2) / mean |colors| over rows ``quiet`` (all rows if none is)."""
    chosen = quiet if quiet.any() else np.ones_like(quiet)
    scale = _mean_colour(colors, chosen)
    return float(np.sqrt((difference[chosen] ** 2).mean()) / scale) if scale > 0 else 0.0


def _mean_colour(colors: np.ndarray, quiet: np.ndarray) -> float:
    """mean |colors| over rows ``quiet`` (all rows if none is)."""
    return float(np.abs(colors[quiet if quiet.any() else slice(None)]).mean())


def level_change(mesh: Discretization, colors: np.ndarray, previous: np.ndarray) -> float:
    """LEVEL_FACTOR times the relative RMS change of the node colours (N, C) from the previous
    level's."""
    return LEVEL_FACTOR * relative_rms(colors - previous, colors, ~mesh.node_emission.any(axis=1))


def near_field_error(mesh: Discretization, colors: np.ndarray, node_errors: np.ndarray) -> float:
    """Relative RMS of the near field's bound on each node's error (N, C)
    (``nearfield.reading_error``)."""
    return relative_rms(node_errors, colors, ~mesh.node_emission.any(axis=1))


def corner_patch_gap(mesh: Discretization, colors: np.ndarray, radiosity: np.ndarray,
                     receiving_points: np.ndarray) -> float:
    """Relative RMS of node colour (N, C) minus the radiosity (P, C) of the nearest patch of
    the same panel, over the corners of the panels."""
    front = mesh.front_patch_count
    owner = mesh.patch_triangle[:front]
    corner_node = mesh.panel_node[owner]  # (F, 3) the nodes of each patch's panel
    valid = corner_node >= 0
    nodes = np.maximum(corner_node, 0)
    distance = np.linalg.norm(receiving_points[:front, None, :] - mesh.node_points[nodes], axis=2)
    distance[~valid] = np.inf
    differences, references, quiet = [], [], []
    for k in range(3):
        order = np.lexsort((distance[:, k], owner))  # by triangle, nearest patch first
        first = order[np.r_[True, owner[order][1:] != owner[order][:-1]]]
        first = first[valid[first, k]]
        node = corner_node[first, k]
        differences.append(colors[node] - radiosity[first])
        references.append(colors[node])
        quiet.append(~mesh.node_emission[node].any(axis=1))
    return relative_rms(np.concatenate(differences), np.concatenate(references), np.concatenate(quiet))


def of_bake(mesh: Discretization, colors: np.ndarray, radiosity: np.ndarray, receiving_points: np.ndarray,
            method: str, solve_stats: dict, level_change: float | None, noise: np.ndarray | None,
            near_errors: np.ndarray | None, direct_noise: np.ndarray | None = None) -> dict:
    """{"unshot", "discretisation", "direct_sampling", "total"}: the estimate of a bake whose node
    colours are ``colors`` (N, C) over patches of ``radiosity`` (P, C), as the module docstring
    says: the solver's part from ``solve_stats`` (or the Monte Carlo ``noise`` (N, C) of the
    nodes' lighting), the discretisation's from the near field's ``near_errors`` (N, C; ray
    casting; or what the final gather's near rays changed), the last refinement level's
    ``level_change``, or the corner-patch gap; and the
    sampling's of the sky at the nodes, from its standard error ``direct_noise`` (N, C) there
    (``DirectLighting.sampled_factors_at``)."""
    change = level_change
    if near_errors is not None and method == "raycast":  # tighter than the level change
        change = near_field_error(mesh, colors, near_errors)
    if change is None:
        change = corner_patch_gap(mesh, colors, radiosity, receiving_points)
    elif method == "hemicube":  # the gap is what covers the hemicube's aliasing
        change = max(change, corner_patch_gap(mesh, colors, radiosity, receiving_points))
    if noise is None:
        left = solver_error(mesh, colors, radiosity, solve_stats)
    else:  # the light not shot is distributed, up to the final gather's noise
        left = monte_carlo_error(mesh, colors, mesh.node_reflectance[:, : colors.shape[1]] * noise)
    sampling = 0.0 if direct_noise is None else relative_rms(mesh.node_reflectance[:, : colors.shape[1]] * direct_noise,
                                                             colors, ~mesh.node_emission.any(axis=1))
    return {"unshot": left, "discretisation": change, "direct_sampling": sampling,
            "total": max(left + change + sampling, ROUNDING_FLOOR)}
