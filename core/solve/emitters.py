"""Next-event estimation of the light straight from the emitting patches, weighted against
cosine-distributed rays that meet them by the power heuristic (Veach and Guibas 1995), so that
neither a close emitter (whose samples vary as 1 / r^2) nor a small one (that few rays meet)
makes the noise. Used by the final gather's rays of their own (``gather``) and by the benchmarks'
path tracer (bench/pathtrace.py).

One point of an emitting patch q, chosen with probability proportional to its power
A_q sum_c E_q,c and uniformly on it, adds E_q cos(theta_x) cos(theta_q) / (pi r^2) / p_A, p_A =
P(q) / A_q, if the segment is clear; with K cosine-distributed rays from x as the other technique,
the sample's share is p_L^2 / (p_L^2 + (K p_B)^2) and a ray meeting q's share (K p_B)^2 / (p_L^2 +
(K p_B)^2), p_L = p_A r^2 / cos(theta_q) and p_B = cos(theta_x) / pi the densities per solid
angle (Pharr, Jakob and Humphreys, "Physically Based Rendering", 4th ed., 13.2 and 2.4.3).
"""

from __future__ import annotations

import numpy as np

from ..mesh.discretize import Discretization
from ..rays.visibility import RAY_EPSILON, Visibility
from ..util.geometry import uniform_points


class Emitters:
    """The emitting patches of ``mesh``, sampled in proportion to their power."""

    def __init__(self, mesh: Discretization) -> None:
        self.patches = np.flatnonzero(mesh.patch_emission.any(axis=1) & (mesh.patch_areas > 0))
        power = mesh.patch_areas[self.patches] * mesh.patch_emission[self.patches].sum(axis=1)
        self.cumulative = np.cumsum(power) / power.sum() if len(self.patches) else np.zeros(0)
        # the probability per unit area of a sampled point, on every patch (0 where nothing emits)
        self.density = np.zeros(mesh.patch_count)
        if len(self.patches):
            self.density[self.patches] = power / power.sum() / mesh.patch_areas[self.patches]
        self.mesh = mesh

    def sample(self, visibility: Visibility, points: np.ndarray, normals: np.ndarray, rng: np.random.Generator,
               rays: int = 1) -> tuple[np.ndarray, np.ndarray]:
        """One next-event estimate at each of ``points`` facing unit ``normals``: the emitting
        patch sampled (n,) (-1: none) and its weight (n,), the light reaching the point being
        weight x that patch's emission; its share against ``rays`` cosine-distributed rays."""
        mesh = self.mesh
        patch = np.full(len(points), -1)
        weight = np.zeros(len(points))
        if not len(self.patches) or not len(points):
            return patch, weight
        chosen = self.patches[np.minimum(np.searchsorted(self.cumulative, rng.random(len(points)), side="right"),
                                         len(self.patches) - 1)]
        target = uniform_points(np.take(mesh.patch_corners, chosen, axis=0), rng.random((len(points), 2)))
        offset = target - points
        cos_here = np.einsum("ij,ij->i", offset, normals)
        cos_there = -np.einsum("ij,ij->i", offset, mesh.patch_normals[chosen])  # both times the distance
        lit = np.flatnonzero((cos_here > 0) & (cos_there > 0))
        if not len(lit):
            return patch, weight
        # as ``raycast``: from RAY_EPSILON off the surface to RAY_EPSILON short of the emitter's
        # plane (measured across it), in unit space
        start = visibility.to_unit(points[lit]) + RAY_EPSILON * visibility.to_unit_directions(normals[lit])
        ray = visibility.to_unit(target[lit]) - start
        across = np.maximum(-np.einsum("ij,ij->i", ray, mesh.patch_normals[chosen[lit]]), np.finfo(np.float32).tiny)
        passing = 1 - visibility.blocked_unit(start, ray, 1 - RAY_EPSILON / across, jittered=True)
        squared = np.einsum("ij,ij->i", offset[lit], offset[lit])
        density = self.density[chosen[lit]]
        geometry = cos_here[lit] * cos_there[lit] / (np.pi * squared**2) / density
        light_density, ray_density = _solid_angle_densities(density, squared, cos_here[lit], cos_there[lit])
        share = light_density**2 / (light_density**2 + (rays * ray_density)**2)
        patch[lit], weight[lit] = chosen[lit], passing * geometry * share
        return patch, weight

    def met_share(self, origins: np.ndarray, normals: np.ndarray, patches: np.ndarray, points: np.ndarray,
                  rays: int = 1) -> np.ndarray:
        """(n,) the share of the emission of ``patches`` (-1: none) met at ``points`` by
        cosine-distributed rays, ``rays`` from each of ``origins`` facing ``normals``, against
        ``sample`` (1 where a patch emits nothing or none was met)."""
        share = np.ones(len(patches))
        shining = np.flatnonzero(self.density[np.maximum(patches, 0)] * (patches >= 0) > 0)
        if not len(shining):
            return share
        offset = points[shining] - origins[shining]
        squared = np.maximum(np.einsum("ij,ij->i", offset, offset), 1e-300)
        cos_here = np.maximum(np.einsum("ij,ij->i", offset, normals[shining]), 0.0)
        cos_there = np.maximum(-np.einsum("ij,ij->i", offset, self.mesh.patch_normals[patches[shining]]), 1e-300)
        light_density, ray_density = _solid_angle_densities(self.density[patches[shining]], squared, cos_here,
                                                            cos_there)
        share[shining] = (rays * ray_density)**2 / np.maximum(light_density**2 + (rays * ray_density)**2, 1e-300)
        return share


def _solid_angle_densities(area_density: np.ndarray, squared: np.ndarray, cos_here: np.ndarray,
                           cos_there: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The densities per solid angle of reaching an emitter's point by sampling the emitters
    (p r^2 / cos_there, p per unit area) and by a cosine-distributed ray (cos_here / pi), from
    ``squared`` r^2 and the cosines times r (as computed): the power heuristic's two weights."""
    return area_density * squared**1.5 / cos_there, cos_here / (np.pi * np.sqrt(squared))
