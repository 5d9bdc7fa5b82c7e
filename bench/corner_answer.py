"""The path-traced answer at random triangle corners of a scene, each where a bake reads it (its
node), for scenes where no bake of ours converges: the Sponza rows of the trade-off sweep and the
scoring of Sponza's bakes against Cycles' (the tradeoffs and path_traced studies).

Path tracing (bench/pathtrace.py) reads only the patches' geometry, reflectance and emission, not
their radiosity, so it is independent of the solvers and of the bake's knobs but its seed."""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from bench import machine
from bench.metrics import rms
from bench.pathtrace import path_traced
from core import BakeSettings, Scene
from core.mesh.discretize import discretised
from core.rays.visibility import Visibility

SELECTION_SEED = 7  # which corners are chosen
PATH_SEED = 1


@dataclass
class CornerAnswer:
    """B at ``triangles``, ``corners`` (n,) each: ``radiosity`` (n, C), its ``standard_error``
    (n, C) from the spread of the paths, and the ``seconds`` the paths took."""

    triangles: np.ndarray
    corners: np.ndarray
    radiosity: np.ndarray
    standard_error: np.ndarray
    seconds: float

    @property
    def noise(self) -> float:
        """The answer's own noise: RMS of the standard errors over the mean radiosity."""
        return rms(self.standard_error) / float(self.radiosity.mean())


def tracer_digest() -> str:
    """``machine.sources_digest`` of this module and bench/pathtrace.py: which path tracer an answer
    came from (a cached answer of another is traced again)."""
    here = Path(__file__)
    return machine.sources_digest((here, here.with_name("pathtrace.py")), here.parent)


def path_traced_corners(scene: Scene, patch_size: float, count: int, paths: int) -> CornerAnswer:
    """B = E + rho G at ``count`` random corners of non-emitting triangles (drawn with
    SELECTION_SEED among those with a node), G path-traced with ``paths`` paths at each corner's
    node, on the patches of a default bake of ``patch_size``. The path tracer samples emitting
    surfaces and a uniform sky: ValueError if the scene has lights or an environment."""
    if scene.lights or scene.environment is not None:
        raise ValueError("the path tracer samples emitting surfaces and a uniform sky: this scene has lights "
                         "or an environment")
    mesh, _ = discretised(scene, patch_size, math.radians(BakeSettings().crease_angle), True)
    front = mesh.front_patch_count
    visibility = Visibility(mesh.patch_corners[:front], two_sided=mesh.back_of_front >= 0,
                            owners=mesh.patch_triangle[:front])
    candidates = np.argwhere((mesh.corner_node >= 0) & ~scene.emission.any(axis=1)[:, None])
    chosen = candidates[np.random.default_rng(SELECTION_SEED).choice(len(candidates), count, replace=False)]
    nodes = mesh.corner_node[chosen[:, 0], chosen[:, 1]]
    start = time.perf_counter()
    found = path_traced(mesh, visibility, mesh.node_points[nodes], mesh.node_normals[nodes], paths, seed=PATH_SEED,
                        sky=scene.sky)
    reflectance = mesh.node_reflectance[nodes]
    return CornerAnswer(chosen[:, 0], chosen[:, 1], mesh.node_emission[nodes] + reflectance * found.light,
                        reflectance * found.standard_error, time.perf_counter() - start)
