"""The nodes' light averaged with their neighbours' where they differ by no more than their noise
explains and lie close for what they see: non-local means weights with variance cancellation
(Rousselle, Knaus and Zwicker, "Adaptive rendering with non-local means filtering", 2012), on the
mesh instead of the image, within the reach of irradiance caching (Ward, Rubinstein and Clear,
"A ray tracing solution for diffuse interreflection", 1988).

A Monte Carlo bake knows the standard error s of each node's light G (the final gather's spread
and the sky's sampling) and how far its gather's rays went (R, their harmonic mean distance).
Node i takes the mean of itself and the nodes j that share a triangle with it:

    G'_i = (G_i + sum_j w_ij G_j) / (1 + sum_j w_ij),   w_ij = exp(-max(0, d_ij)) max(0, 1 - e_ij / WARD_ERROR),
    d_ij = mean_c ((G_i - G_j)^2 - v_ij) / (K^2 v_ij),   e_ij = |x_i - x_j| / min(R_i, R_j) + sqrt(1 - n_i . n_j),

v_ij = s_i^2 + s_j^2 per channel c, the variance of their difference were they alike, and K the
bake's ``denoise`` strength. The first factor averages nodes whose light differs by what their
noise gives (their noise falls) and keeps a shadow's edge many standard errors high; the second,
Ward's bound on how fast light can change between points that see surfaces R away, keeps nodes
apart whose light may truly differ by less than their noise: vertices metres apart, or facing
other ways. A node without noise is left as it is. One ring of neighbours, once: on the breakfast
room a second ring or a second pass blurred more light than it took noise away
(docs/notes/experiments.md, "Each node's light averaged with its neighbours' where their noise
allows").

The bake's error estimate keeps the noise before the filter (``estimate``): its bias is not
measured bake by bake, and neighbours that read the same particles share noise no average takes away.
"""

from __future__ import annotations

import numpy as np

from ..mesh.discretize import Discretization
from ..util.progress import Report, quiet

# Ward's a: the largest error e_ij of a neighbour's weight (above, it counts for nothing). On Sponza,
# the breakfast room and a small lit room, 0.5 to 0.7 lowered the error of the first two and left the
# third's as it was; without it, a strength of 2 or more blurred the light of the other two.
WARD_ERROR = 0.5


def neighbours(mesh: Discretization) -> tuple[np.ndarray, np.ndarray]:
    """The pairs (i, j) (E,) each of nodes that share a triangle, each pair both ways round."""
    corner_node = mesh.corner_node.astype(np.int64)
    pairs = np.concatenate([corner_node[:, [0, 1]], corner_node[:, [1, 2]], corner_node[:, [2, 0]]])
    pairs = np.sort(pairs[(pairs >= 0).all(axis=1) & (pairs[:, 0] != pairs[:, 1])], axis=1)
    count = mesh.node_count
    key = np.unique(pairs[:, 0] * count + pairs[:, 1])
    low, high = key // count, key % count
    return np.concatenate([low, high]), np.concatenate([high, low])


def denoised(mesh: Discretization, lighting: np.ndarray, standard_error: np.ndarray, distance: np.ndarray,
             strength: float, report: Report = quiet) -> np.ndarray:
    """The nodes' ``lighting`` G (N, C) averaged with their neighbours' by their ``standard_error``
    s (N, C) and the harmonic mean ``distance`` R (N,) their gathers' rays went (inf: they met
    nothing), alike up to about ``strength`` K standard errors apart (the module's docstring)."""
    first, second = neighbours(mesh)
    report(0.3)
    variance = standard_error**2
    apart = variance[first] + variance[second]
    excess = (lighting[first] - lighting[second]) ** 2 - apart
    # alike without noise only where equal; with it, by how far beyond the noise they are
    scaled = np.divide(excess, strength**2 * apart, out=np.where(excess > 0, np.inf, 0.0), where=apart > 0)
    offset = mesh.node_points[first] - mesh.node_points[second]
    normals = mesh.node_normals
    error = np.sqrt(np.einsum("ij,ij->i", offset, offset)) / np.minimum(distance[first], distance[second]) + np.sqrt(
        np.maximum(1.0 - np.einsum("ij,ij->i", normals[first], normals[second]), 0.0))
    weight = np.exp(-np.maximum(scaled.mean(axis=1), 0.0)) * np.maximum(1.0 - error / WARD_ERROR, 0.0)
    report(0.7)
    count = len(lighting)
    total = 1.0 + np.bincount(first, weight, minlength=count)
    summed = np.stack([np.bincount(first, weight * lighting[second, c], minlength=count)
                       for c in range(lighting.shape[1])], axis=1)
    return (lighting + summed) / total[:, None]
