"""A reference for bakes where no closed form exists: the light arriving at points by path tracing,
independent of the patches' radiosity (only their geometry, reflectance and emission are read).

The light arriving at x, G(x) = irradiance / pi, is the sum over paths x -> y1 -> y2 -> ... of
rho(y1) ... rho(yk) times the light that reaches yk straight from the emitters (Kajiya 1986; next-
event estimation, Pharr, Jakob and Humphreys, "Physically Based Rendering", 4th ed., 13.2):

* at x and at every yk, one point of an emitting patch q, chosen with probability proportional to
  its power A_q sum_c E_q,c and uniformly on it, adds
  E_q cos(theta_x) cos(theta_q) / (pi r^2) / p, p = P(q) / A_q, if the segment is clear;
* the path goes on in a cosine-distributed direction to the next surface met, whose emission
  counts too; the two estimates of the same light are weighted by the power heuristic (Veach and
  Guibas 1995), so neither a close emitter (whose samples vary as 1 / r^2) nor a small one (that
  bounces rarely meet) makes the noise;
* from the third bounce on, Russian roulette: the path survives with s = max_c of its throughput
  (at least MIN_SURVIVAL), divided by s if it does; at most MAX_BOUNCES bounces (the light of
  longer paths, below rho_max^MAX_BOUNCES of the total, is left out);
* a uniform sky S (``Scene.sky``) adds S times the path's throughput where a bounce meets no
  surface (cosine-distributed bounces sample it exactly in proportion to what it gives: an
  open point's G is S).

Rays meet the patches as ``montecarlo``'s do (``Surfaces``: the front patches, a back face landing
on its back patch; see-through surfaces are taken as opaque). Lights (``lights``) and a sky that
varies with direction are not sampled.
"""

from __future__ import annotations

import numpy as np

from core.mesh.discretize import Discretization
from core.rays.visibility import RAY_EPSILON, Visibility
from core.solve.montecarlo import Gathered, Surfaces, cosine_directions, uniform_points
from core.util.progress import Report, quiet

MIN_SURVIVAL = 0.05
MAX_BOUNCES = 256
PATHS_PER_BLOCK = 1 << 17


class _Emitters:
    """The emitting patches, sampled in proportion to their power."""

    def __init__(self, mesh: Discretization) -> None:
        self.patches = np.flatnonzero(mesh.patch_emission.any(axis=1) & (mesh.patch_areas > 0))
        power = mesh.patch_areas[self.patches] * mesh.patch_emission[self.patches].sum(axis=1)
        self.cumulative = np.cumsum(power) / power.sum() if len(self.patches) else np.zeros(0)
        # the probability per unit area of a sampled point, on every patch (0 where nothing emits)
        self.density = np.zeros(mesh.patch_count)
        if len(self.patches):
            self.density[self.patches] = power / power.sum() / mesh.patch_areas[self.patches]
        self.mesh = mesh

    def light(self, visibility: Visibility, points: np.ndarray, normals: np.ndarray,
              rng: np.random.Generator) -> np.ndarray:
        """(n, C) one next-event estimate of the light reaching ``points`` facing ``normals``
        straight from the emitters, weighted against ``met`` by the power heuristic."""
        mesh = self.mesh
        result = np.zeros((len(points), mesh.patch_emission.shape[1]))
        if not len(self.patches) or not len(points):
            return result
        chosen = np.minimum(np.searchsorted(self.cumulative, rng.random(len(points)), side="right"),
                            len(self.patches) - 1)
        patch = self.patches[chosen]
        target = uniform_points(mesh.patch_corners[patch], rng.random((len(points), 2)))
        offset = target - points
        cos_here = np.einsum("ij,ij->i", offset, normals)
        cos_there = -np.einsum("ij,ij->i", offset, mesh.patch_normals[patch])  # both times the distance
        lit = np.flatnonzero((cos_here > 0) & (cos_there > 0))
        if not len(lit):
            return result
        # as ``raycast``: from RAY_EPSILON off the surface to RAY_EPSILON short of the emitter's
        # plane (measured across it), in unit space
        start = visibility.to_unit(points[lit]) + RAY_EPSILON * visibility.to_unit_directions(normals[lit])
        ray = visibility.to_unit(target[lit]) - start
        across = np.maximum(-np.einsum("ij,ij->i", ray, mesh.patch_normals[patch[lit]]), np.finfo(np.float32).tiny)
        clear = ~visibility.occluded_unit(start, ray, 1 - RAY_EPSILON / across)
        squared = np.einsum("ij,ij->i", offset[lit], offset[lit])
        density = self.density[patch[lit]]
        geometry = cos_here[lit] * cos_there[lit] / (np.pi * squared**2) / density
        light_density, bounce_density = _solid_angle_densities(density, squared, cos_here[lit], cos_there[lit])
        share = light_density**2 / (light_density**2 + bounce_density**2)
        result[lit] = (clear * geometry * share)[:, None] * mesh.patch_emission[patch[lit]]
        return result

    def met(self, origins: np.ndarray, normals: np.ndarray, patches: np.ndarray, points: np.ndarray) -> np.ndarray:
        """(n, C) the emission of ``patches`` met at ``points`` by cosine-distributed bounces from
        ``origins`` facing ``normals``, weighted against ``light`` by the power heuristic."""
        mesh = self.mesh
        offset = points - origins
        squared = np.einsum("ij,ij->i", offset, offset)
        cos_here = np.einsum("ij,ij->i", offset, normals)
        cos_there = np.maximum(-np.einsum("ij,ij->i", offset, mesh.patch_normals[patches]), 1e-300)
        light_density, bounce_density = _solid_angle_densities(self.density[patches], np.maximum(squared, 1e-300),
                                                               np.maximum(cos_here, 0.0), cos_there)
        share = bounce_density**2 / np.maximum(light_density**2 + bounce_density**2, 1e-300)
        return share[:, None] * mesh.patch_emission[patches]


def _solid_angle_densities(area_density: np.ndarray, squared: np.ndarray, cos_here: np.ndarray,
                           cos_there: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The densities per solid angle, both times the distance r, of reaching an emitter's point
    by sampling the emitters (p r^2 / cos_there, p per unit area) and by a cosine-distributed
    bounce (cos_here / pi): the power heuristic's two weights (cosines times r, as computed)."""
    return area_density * squared**1.5 / cos_there, cos_here / (np.pi * np.sqrt(squared))


def path_traced(mesh: Discretization, visibility: Visibility, points: np.ndarray, normals: np.ndarray,
                paths: int, seed: int = 0, report: Report = quiet, sky: np.ndarray | None = None) -> Gathered:
    """G at ``points`` (n, 3) facing unit ``normals`` (n, 3) from ``paths`` paths each (see the
    module docstring), under a uniform ``sky`` (C,) (None: none), with the standard error of each
    estimate from the spread of its paths. ``visibility`` holds the mesh's front patches (as for
    ``montecarlo``)."""
    surfaces = Surfaces(mesh, visibility)
    emitters = _Emitters(mesh)
    reflectance = mesh.patch_reflectance
    channels = mesh.patch_emission.shape[1]
    sky = np.zeros(channels) if sky is None else np.asarray(sky, dtype=np.float64)[:channels]
    per_block = max(1, PATHS_PER_BLOCK // max(paths, 1))
    starts = range(0, len(points), per_block)

    def block(start: int) -> Gathered:
        rng = np.random.default_rng([seed, 3, start])
        count = len(points[start:start + per_block])
        point = np.repeat(points[start:start + per_block], paths, axis=0)
        normal = np.repeat(normals[start:start + per_block], paths, axis=0)
        total = emitters.light(visibility, point, normal, rng)
        path = np.arange(len(point))
        weight = np.ones((len(point), channels))
        for bounce in range(MAX_BOUNCES):
            origin = point
            patch, point, escaped = surfaces.opaque_hit(point, cosine_directions(normal, rng.random((len(point), 2))),
                                                        normal)
            total[path[escaped]] += weight[escaped] * sky
            landed = patch >= 0
            patch, point, path, weight = patch[landed], point[landed], path[landed], weight[landed]
            shining = np.flatnonzero(emitters.density[patch] > 0)
            if len(shining):
                total[path[shining]] += weight[shining] * emitters.met(
                    origin[landed][shining], normal[landed][shining], patch[shining], point[shining])
            normal = mesh.patch_normals[patch]  # the side met, facing back along the ray
            weight = weight * reflectance[patch]
            total[path] += weight * emitters.light(visibility, point, normal, rng)  # each path once
            if bounce >= 2:
                survival = np.clip(weight.max(axis=1), MIN_SURVIVAL, 1.0)
                alive = rng.random(len(path)) < survival
                patch, point, path, normal = patch[alive], point[alive], path[alive], normal[alive]
                weight = weight[alive] / survival[alive, None]
            if not len(path):
                break
        return Gathered.of(total.reshape(count, paths, channels))

    return Gathered.on_threads(block, starts, channels, report)
