"""Embree alone on the patches a bake made, for the kind of ray its method casts: the throughput
a bake's ray casting is measured against (the benchmarks study)."""

from __future__ import annotations

import functools
import math
import statistics
import time
from typing import Callable

import numpy as np

from bench.runner import cpu_seconds
from core import Scene
from core.mesh.discretize import Discretization, discretize
from core.rays.visibility import RAY_EPSILON, Visibility
from core.util import parallel

RAW_RAYS = 1 << 21  # rays in the raw batch, split across parallel.THREADS threads
RAW_REPEATS = 5  # traces of the raw batch per sample; the median time counts
SHOOTERS = 16  # sources per raw ray batch, as progressive refinement fetches 16 columns at a time


class RawEmbree:
    """Embree alone on the patches a bake made, for the kind of ray its method casts: OCCLUDED
    segments between points on patches (raycast) or INTERSECT rays from points on patches into
    their hemisphere (hemicube), RAW_RAYS of them in one batch split across parallel.THREADS
    threads of the bake's own pool."""

    def __init__(self, scene: Scene, settings: dict, method: str, seed: int = 0) -> None:
        mesh = discretize(scene, settings["patch_size"], math.radians(settings["crease_angle"]))
        visibility = Visibility(mesh.patch_corners[: mesh.front_patch_count])
        rng = np.random.default_rng(seed)
        if method == "hemicube":
            self.query, rays, self._trace = "INTERSECT", _hemisphere_rays(mesh, rng), visibility.nearest
        else:
            self.query, rays = "OCCLUDED", _segment_rays(mesh, visibility, rng)
            self._trace = functools.partial(visibility.occluded_unit, jittered=True)  # drawn at random, as the shots'
        chunks = np.array_split(np.arange(RAW_RAYS), parallel.THREADS)
        self._parts = [tuple(array[chunk] for array in rays) for chunk in chunks]

    def sample(self) -> tuple[float, float]:
        """(median wall seconds of RAW_REPEATS traces of the batch, CPU seconds of all of them)."""
        cpu = cpu_seconds()
        seconds = statistics.median(_timed(self._trace, self._parts) for _ in range(RAW_REPEATS))
        return seconds, cpu_seconds() - cpu


def _timed(trace: Callable[..., np.ndarray], parts: list[tuple[np.ndarray, ...]]) -> float:
    """Wall seconds to trace every part, the parts side by side on the bake's thread pool."""
    start = time.perf_counter()
    for _ in parallel.map_ordered(lambda part: trace(*part), parts):
        pass
    return time.perf_counter() - start


def _segment_rays(mesh: Discretization, visibility: Visibility, rng: np.random.Generator):
    """(starts, directions, reach) in unit space, RAW_RAYS of them, built as raycast.RayCaster
    builds its rays: in batches of SHOOTERS source patches (drawn by area, as the brightest
    shoot first) times random receivers, from a random point on the receiver, RAY_EPSILON
    off its surface, to a random point on the source, for the pairs that face each other."""
    front = mesh.front_patch_count
    corners, normals, areas = mesh.patch_corners[:front], mesh.patch_normals[:front], mesh.patch_areas[:front]
    batches, count = [], 0
    while count < RAW_RAYS:
        sources = rng.choice(front, SHOOTERS, p=areas / areas.sum())
        receivers = np.repeat(rng.integers(0, front, RAW_RAYS // SHOOTERS), SHOOTERS)
        sources = np.tile(sources, len(receivers) // SHOOTERS)
        start, end = _random_points(corners[receivers], rng), _random_points(corners[sources], rng)
        segment = end - start
        facing = (np.einsum("nx,nx->n", segment, normals[receivers]) > 0) & (
            np.einsum("nx,nx->n", segment, normals[sources]) < 0
        )
        origin = visibility.to_unit(start[facing]) + RAY_EPSILON * normals[receivers[facing]].astype(np.float32)
        offset = visibility.to_unit(end[facing]) - origin
        reach = (1 - RAY_EPSILON / np.linalg.norm(offset, axis=1)).astype(np.float32)
        batches.append((origin, offset, reach))
        count += len(origin)
    return tuple(np.concatenate(arrays)[:RAW_RAYS] for arrays in zip(*batches))


def _hemisphere_rays(mesh: Discretization, rng: np.random.Generator):
    """(origins, directions, normals) in world space, RAW_RAYS of them: from a random point on a
    random patch, uniformly into the hemisphere above it (as a hemicube looks out of a patch)."""
    patches = rng.integers(0, mesh.front_patch_count, RAW_RAYS)
    origins = _random_points(mesh.patch_corners[patches], rng)
    directions = rng.normal(size=(RAW_RAYS, 3))
    directions /= np.linalg.norm(directions, axis=1, keepdims=True)
    directions *= np.sign(np.einsum("nx,nx->n", directions, mesh.patch_normals[patches]))[:, None]
    return origins, directions, mesh.patch_normals[patches]


def _random_points(corners: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """(n, 3) one uniform random point in each triangle of corners (n, 3, 3)."""
    u, v = rng.random((2, len(corners)))
    root = np.sqrt(u)
    weights = np.stack([1 - root, root * (1 - v), root * v], axis=1)
    return np.einsum("nb,nbx->nx", weights, corners)
