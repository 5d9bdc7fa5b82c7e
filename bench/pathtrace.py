"""A reference for bakes where no closed form exists: the light arriving at points by path tracing,
independent of the patches' radiosity (only their geometry, reflectance and emission are read).

The light arriving at x, G(x) = irradiance / pi, is the sum over paths x -> y1 -> y2 -> ... of
rho(y1) ... rho(yk) times the light that reaches yk straight from the emitters (Kajiya 1986; next-
event estimation, Pharr, Jakob and Humphreys, "Physically Based Rendering", 4th ed., 13.2):

* at x and at every yk, one point of an emitting patch adds the light it sends if the segment is
  clear (``core.solve.emitters``);
* the path goes on in a cosine-distributed direction to the next surface met, whose emission
  counts too; the two estimates of the same light are weighted by the power heuristic;
* from the third bounce on, Russian roulette: the path survives with s = max_c of its throughput
  (at least MIN_SURVIVAL), divided by s if it does; at most MAX_BOUNCES bounces (the light of
  longer paths, below rho_max^MAX_BOUNCES of the total, is left out: 0.999^65,536 = 3e-29 for the
  OBJ reader's brightest surfaces, where 256 left out up to 77 %: a furnace of 0.999 read 0.225 of
  its light, and the light carried hundreds of bounces under a cup 3 mm above a table, both of
  0.999, half of it);
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
from core.rays.visibility import Visibility
from core.solve.emitters import Emitters
from core.solve.gather import Gathered
from core.solve.montecarlo import Surfaces
from core.util.geometry import cosine_directions
from core.util.progress import Report, quiet

MIN_SURVIVAL = 0.05
MAX_BOUNCES = 1 << 16
PATHS_PER_BLOCK = 1 << 17


def _emitted(emitters: Emitters, visibility: Visibility, points: np.ndarray, normals: np.ndarray,
             rng: np.random.Generator) -> np.ndarray:
    """(n, C) one next-event estimate of the light reaching ``points`` facing ``normals`` straight
    from the emitters (``Emitters.sample``; its weight is 0 where it sampled none)."""
    patch, weight = emitters.sample(visibility, points, normals, rng)
    return weight[:, None] * emitters.mesh.patch_emission[np.maximum(patch, 0)]


def path_traced(mesh: Discretization, visibility: Visibility, points: np.ndarray, normals: np.ndarray,
                paths: int, seed: int = 0, report: Report = quiet, sky: np.ndarray | None = None) -> Gathered:
    """G at ``points`` (n, 3) facing unit ``normals`` (n, 3) from ``paths`` paths each (see the
    module docstring), under a uniform ``sky`` (C,) (None: none), with the standard error of each
    estimate from the spread of its paths. ``visibility`` holds the mesh's front patches (as for
    ``montecarlo``)."""
    surfaces = Surfaces(mesh, visibility)
    emitters = Emitters(mesh)
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
        total = _emitted(emitters, visibility, point, normal, rng)
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
                share = emitters.met_share(origin[landed][shining], normal[landed][shining], patch[shining],
                                           point[shining])
                total[path[shining]] += weight[shining] * share[:, None] * mesh.patch_emission[patch[shining]]
            normal = mesh.patch_normals[patch]  # the side met, facing back along the ray
            weight = weight * reflectance[patch]
            total[path] += weight * _emitted(emitters, visibility, point, normal, rng)  # each path once
            if bounce >= 2:
                survival = np.clip(weight.max(axis=1), MIN_SURVIVAL, 1.0)
                alive = rng.random(len(path)) < survival
                patch, point, path, normal = patch[alive], point[alive], path[alive], normal[alive]
                weight = weight[alive] / survival[alive, None]
            if not len(path):
                break
        return Gathered.of(total.reshape(count, paths, channels))

    return Gathered.on_threads(block, starts, channels, report)
