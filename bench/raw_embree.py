"""One benchmark case, measured in a fresh process (so ru_maxrss is this bake's own): a timed bake,
the same bake again under tracemalloc (it slows NumPy-heavy code by ~25 %, so it never times), and
the raw Embree throughput on the bake's own patch triangles, sampled before and after the rerun."""

from __future__ import annotations

import math
import resource
import statistics
import time
import tracemalloc
from dataclasses import dataclass, field
from typing import Callable

import numpy as np

import machine
import scenes
from core import Scene, bake
from core.util import parallel
from core.mesh.discretize import Discretization, discretize
from core.rays.visibility import RAY_EPSILON, Visibility

RAY_STAGES = ("form_factors", "solve", "gather")  # the stages of bake() that cast rays
RAW_RAYS = 1 << 21  # rays in the raw batch, split across parallel.THREADS threads
RAW_REPEATS = 5  # traces of the raw batch per sample; the median time counts
SHOOTERS = 16  # sources per raw ray batch, as progressive refinement fetches 16 columns at a time


@dataclass(frozen=True)
class Case:
    """A bake to measure: ``knobs`` go to bake() as they are; the errors of a scene's other bakes
    are measured against its ``reference`` bake."""

    scene: str
    setting: str
    method: str = "raycast"
    knobs: dict = field(default_factory=dict)
    reference: bool = False

    @property
    def label(self) -> str:
        """The scene and setting, and the method unless it is the default, ray casting."""
        return f"{self.scene} {self.setting}" + ("" if self.method == "raycast" else f" {self.method}")


@dataclass
class Measurement:
    """What one case measured; sizes in bytes, times in seconds, rates in rays per second."""

    case: Case
    core: str  # machine.core_digest() when the case started
    stats: dict  # BakeResult.stats of the timed bake
    wall: float
    cpu: float  # CPU seconds of the process (all threads) during the timed bake
    bake_rays_per_second: float  # rays_cast over the seconds of the RAY_STAGES
    raw_query: str
    raw_rays_per_second: float
    raw_rays_per_cpu_second: float
    traced_peak: int  # tracemalloc peak of the rerun
    maxrss_before: int  # ru_maxrss with the scene loaded, before baking
    maxrss_after: int  # ru_maxrss after the timed bake (before anything else)
    repeatable: bool  # the rerun gave identical corner colours
    emitting: np.ndarray  # (T,) bool, the triangles with non-zero emission
    corner_colors: np.ndarray
    triangle_radiosity: np.ndarray

    @property
    def ratio(self) -> float:
        """Bake rays per second over raw Embree rays per second."""
        return self.bake_rays_per_second / self.raw_rays_per_second

    @property
    def cpu_ratio(self) -> float:
        """The same per CPU second (the whole bake's): what the ratio would be if other processes
        took no CPU from either measurement, and both used the cores equally well."""
        return self.stats["rays_cast"] / self.cpu / self.raw_rays_per_cpu_second


def measure(case: Case) -> Measurement:
    """Load the case's scene, bake it timed, then bake it again traced between two samples of
    raw Embree throughput (so the raw figure sees the machine's load at two moments)."""
    core = machine.core_digest()
    scene = scenes.LOADERS[case.scene]()
    maxrss_before = _maxrss()
    cpu, wall = _cpu_seconds(), time.perf_counter()
    result = bake(scene, case.method, **case.knobs)
    wall, cpu = time.perf_counter() - wall, _cpu_seconds() - cpu
    maxrss_after = _maxrss()
    stats = result.stats
    raw = RawEmbree(scene, stats["settings"], case.method)
    samples = [raw.sample()]
    tracemalloc.start()
    rerun = bake(scene, case.method, **case.knobs)
    traced_peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    samples.append(raw.sample())
    ray_seconds = sum(stats["seconds"].get(stage, 0.0) for stage in RAY_STAGES)
    return Measurement(
        case=case,
        core=core,
        stats=stats,
        wall=wall,
        cpu=cpu,
        bake_rays_per_second=stats["rays_cast"] / ray_seconds,
        raw_query=raw.query,
        raw_rays_per_second=RAW_RAYS / statistics.mean(seconds for seconds, _cpu in samples),
        raw_rays_per_cpu_second=RAW_RAYS * RAW_REPEATS / statistics.mean(cpu for _seconds, cpu in samples),
        traced_peak=traced_peak,
        maxrss_before=maxrss_before,
        maxrss_after=maxrss_after,
        repeatable=bool(np.array_equal(result.corner_colors, rerun.corner_colors)),
        emitting=(scene.emission > 0).any(axis=1),
        corner_colors=result.corner_colors,
        triangle_radiosity=result.triangle_radiosity,
    )


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
            self._trace = visibility.occluded_unit
        chunks = np.array_split(np.arange(RAW_RAYS), parallel.THREADS)
        self._parts = [tuple(array[chunk] for array in rays) for chunk in chunks]

    def sample(self) -> tuple[float, float]:
        """(median wall seconds of RAW_REPEATS traces of the batch, CPU seconds of all of them)."""
        cpu = _cpu_seconds()
        seconds = statistics.median(_timed(self._trace, self._parts) for _ in range(RAW_REPEATS))
        return seconds, _cpu_seconds() - cpu


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


def _maxrss() -> int:
    """Peak resident set size of this process so far, in bytes (Linux reports KiB)."""
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024


def _cpu_seconds() -> float:
    """User plus system CPU time of this process, all threads."""
    usage = resource.getrusage(resource.RUSAGE_SELF)
    return usage.ru_utime + usage.ru_stime
