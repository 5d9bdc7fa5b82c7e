"""bake(): a Scene in, per-corner radiosity out, through discretise -> form factors -> solve ->
gather at the receiver nodes -> per-corner colours."""

from __future__ import annotations

import math
import time
from dataclasses import asdict, dataclass, field

import numpy as np

from . import solvers
from .discretize import Discretization, discretize
from .formfactors import METHODS, FormFactorEngine
from .lights import DirectLighting
from .progress import Progress, ProgressCallback
from .raycast import check_ray_count
from .scene import Scene

AUTO_PATCH_DIVISIONS = 4  # default patch size: the scene's extent over this (docs/benchmarks.md)


@dataclass(frozen=True)
class BakeSettings:
    """The knobs of a bake, validated on construction.

    patch_size : longest patch edge in scene units; None picks extent / 4.
    crease_angle : degrees; faces meeting at a sharper angle (and always beyond 90) do not
        share a vertex colour.
    hemicube_resolution : pixels across the hemicube's top face (even).
    rays_per_form_factor : visibility rays per point-to-patch form factor (a perfect square);
        also the shadow rays per area-light triangle and the sky directions per point.
    tolerance : stop when the estimated fraction of light not yet distributed (progressive) or
        the bound on the relative error (Jacobi, Gauss-Seidel) is below this.
    ambient : progressive only: add the ambient estimate of the light not yet shot.
    max_shots : progressive refinement stops after this many shots (None: when converged).
    max_iterations : Jacobi and Gauss-Seidel stop after this many sweeps.
    memory_budget : bytes the explicit matrix of Jacobi / Gauss-Seidel may take.
    column_cache : bytes of form-factor columns progressive refinement may keep for reshooting.
    seed : fixes the ray-casting sample positions.
    """

    patch_size: float | None = None
    crease_angle: float = 30.0
    hemicube_resolution: int = 64
    rays_per_form_factor: int = 16
    tolerance: float = 1e-3
    ambient: bool = True
    max_shots: int | None = None
    max_iterations: int = 100_000
    memory_budget: int = 2 << 30
    column_cache: int = 256 << 20
    seed: int = 0

    def __post_init__(self) -> None:
        if self.patch_size is not None and not (math.isfinite(self.patch_size) and self.patch_size > 0):
            raise ValueError(f"patch_size must be a positive length or None, got {self.patch_size}")
        if not 0 <= self.crease_angle <= 180:
            raise ValueError(f"crease_angle must be in [0, 180] degrees, got {self.crease_angle}")
        if not 0 < self.tolerance < 1:
            raise ValueError(f"tolerance must be in (0, 1), got {self.tolerance}")
        for name in ("hemicube_resolution", "rays_per_form_factor", "max_iterations", "memory_budget", "column_cache"):
            if int(getattr(self, name)) != getattr(self, name) or getattr(self, name) < 0:
                raise ValueError(f"{name} must be a non-negative integer, got {getattr(self, name)}")
        check_ray_count(self.rays_per_form_factor)


@dataclass
class BakeResult:
    """corner_colors (T, 3, 3): RGB radiosity at each corner of each input triangle, B = E + rho G.
    triangle_radiosity (T, 3): area-weighted mean radiosity of each input triangle.
    corner_lighting (T, 3, 3): the light arriving at each corner, G = irradiance / pi (what a
        white surface would reflect: "lighting only", to multiply with a texture later).
    stats: what the bake measured (seconds per stage, shots or iterations, rays, ...)."""

    corner_colors: np.ndarray
    triangle_radiosity: np.ndarray
    corner_lighting: np.ndarray
    stats: dict = field(default_factory=dict)


def bake(
    scene: Scene,
    method: str = "raycast",
    solver: str = "progressive",
    progress: ProgressCallback | None = None,
    **knobs,
) -> BakeResult:
    """Solve B = E + rho F B on ``scene`` and return colours per triangle corner.

    method: "hemicube" or "raycast"; solver: "progressive", "jacobi" or "gauss_seidel";
    ``knobs`` are the fields of BakeSettings. ``progress(fraction, message)`` is called at least
    every 0.2 s; if it returns False the bake raises BakeCancelled.
    """
    if method not in METHODS:
        raise ValueError(f"method must be one of {METHODS}, got {method!r}")
    if solver not in solvers.SOLVERS:
        raise ValueError(f"solver must be one of {solvers.SOLVERS}, got {solver!r}")
    settings = BakeSettings(**knobs)
    stages = Progress(progress)
    seconds: dict[str, float] = {}
    clock = time.perf_counter()

    stages.stage("discretising", 0.0, 0.02)
    patch_size = settings.patch_size if settings.patch_size is not None else scene.extent / AUTO_PATCH_DIVISIONS
    mesh = discretize(scene, patch_size, math.radians(settings.crease_angle), stages.report)
    channels = 1 if scene.is_grey else 3
    seconds["discretise"], clock = _lap(clock)

    stages.stage("preparing rays", 0.02, 0.04)
    engine = FormFactorEngine(mesh, method, settings.hemicube_resolution, settings.rays_per_form_factor, settings.seed)
    seconds["setup"], clock = _lap(clock)

    direct = DirectLighting(scene.lights, scene.sky, engine.visibility, settings.rays_per_form_factor, settings.seed)
    start = 0.04
    if not direct.empty:
        start = 0.1
        stages.stage("direct light", 0.04, 0.1)
        patch_direct = direct.patch_means(mesh.patch_corners, mesh.patch_normals, lambda f: stages.report(f / 2))
        node_direct = direct.at_points(mesh.node_points, mesh.node_normals, lambda f: stages.report(0.5 + f / 2))
        seconds["direct_light"], clock = _lap(clock)
    else:
        patch_direct, node_direct = np.zeros((mesh.patch_count, 3)), np.zeros((mesh.node_count, 3))
    # lit by the lights, a patch starts out as if it emitted what it reflects of them
    sources = mesh.patch_emission[:, :channels] + mesh.patch_reflectance[:, :channels] * patch_direct[:, :channels]
    node_direct = node_direct[:, :channels]

    if solver == "progressive":
        solved = _solve_progressive(engine, sources, node_direct, settings, stages, start, seconds)
    else:
        solved = _solve_explicit(engine, sources, solver, settings, stages, start, seconds)
    radiosity, node_lighting, solve_stats, extra_bytes = solved
    if node_lighting is None:
        clock = time.perf_counter()
        stages.stage("gathering at vertices", 0.85, 1.0)
        node_lighting = node_direct + engine.gather(
            mesh.node_points, mesh.node_normals, radiosity, lambda f: stages.report(f)
        )
        seconds["gather"], _ = _lap(clock)
    clock = time.perf_counter()
    corner_colors, triangle_radiosity, corner_lighting = _per_corner(scene, mesh, radiosity, node_lighting)
    seconds["reconstruct"], _ = _lap(clock)
    stages.report(1.0, "done", force=True)

    stats = {
        "method": method,
        "solver": solver,
        "settings": asdict(settings) | {"patch_size": patch_size},
        "triangles": len(scene.triangles),
        "patches": mesh.patch_count,
        "lights": len(scene.lights),
        "nodes": mesh.node_count,
        "channels": channels,
        "seconds": seconds | {"total": sum(seconds.values())},
        "rays_cast": engine.rays_cast,
        "peak_memory_estimate": _base_bytes(mesh) + extra_bytes + engine.working_bytes(),
        **solve_stats,
    }
    return BakeResult(corner_colors, triangle_radiosity, corner_lighting, stats)


def _solve_progressive(engine: FormFactorEngine, sources: np.ndarray, node_direct: np.ndarray,
                       settings: BakeSettings, stages: Progress, start: float, seconds: dict):
    """Shoot; ray casting's shots reach the nodes too (their result is the light G they
    receive), the hemicube's are gathered after."""
    mesh, clock = engine.mesh, time.perf_counter()
    nodes_receive = engine.method == "raycast"
    channels = sources.shape[1]
    stages.stage("shooting", start, 1.0 if nodes_receive else 0.85)
    radiosity, node_lighting, stats = solvers.progressive(
        engine.shooting_columns, mesh.patch_areas, mesh.patch_reflectance[:, :channels], sources,
        np.ones_like(node_direct) if nodes_receive else None,
        node_direct if nodes_receive else None,
        tolerance=settings.tolerance, ambient=settings.ambient, max_shots=settings.max_shots,
        cache_bytes=settings.column_cache, report=stages.report,
    )
    seconds["solve"], _ = _lap(clock)
    cache_bytes = stats["cached_columns"] * 8 * (mesh.patch_count + mesh.node_count)
    return radiosity, node_lighting if nodes_receive else None, stats, cache_bytes


def _solve_explicit(engine: FormFactorEngine, sources: np.ndarray, solver: str, settings: BakeSettings,
                    stages: Progress, start: float, seconds: dict):
    """Build the P x P matrix (within the memory budget), then Jacobi or Gauss-Seidel."""
    mesh, clock = engine.mesh, time.perf_counter()
    matrix_bytes = 8 * mesh.patch_count**2
    if matrix_bytes > settings.memory_budget:
        raise ValueError(
            f"the {solver} solver needs a {mesh.patch_count:,} x {mesh.patch_count:,} form-factor matrix "
            f"({matrix_bytes / 2**30:.2f} GiB), over the memory budget of {settings.memory_budget / 2**30:.2f} GiB; "
            "use solver='progressive', a larger patch_size, or raise memory_budget"
        )
    stages.stage("form factors", start, 0.6)
    matrix = engine.patch_rows(np.arange(mesh.patch_count), lambda f: stages.report(f, "matrix"))
    seconds["form_factors"], clock = _lap(clock)
    stages.stage("solving", 0.6, 0.85)
    iterate = solvers.jacobi if solver == "jacobi" else solvers.gauss_seidel
    radiosity, stats = iterate(matrix, mesh.patch_reflectance[:, :sources.shape[1]], sources,
                               settings.tolerance, settings.max_iterations, stages.report)
    seconds["solve"], _ = _lap(clock)
    return radiosity, None, stats, matrix_bytes


def _lap(start: float) -> tuple[float, float]:
    now = time.perf_counter()
    return now - start, now


def _base_bytes(mesh: Discretization) -> int:
    """Rough size of the discretisation and the solver's vectors."""
    return sum(value.nbytes for value in vars(mesh).values() if isinstance(value, np.ndarray)) + 64 * mesh.patch_count


def _per_corner(scene: Scene, mesh: Discretization, radiosity: np.ndarray, node_lighting: np.ndarray):
    """Corner colours B = E + rho G and lighting G from the nodes, triangle means from the front
    patches; RGB float64."""
    count = len(scene.triangles)
    rgb = np.broadcast_to(radiosity, (len(radiosity), 3)) if radiosity.shape[1] == 1 else radiosity
    lighting = np.broadcast_to(node_lighting, (len(node_lighting), 3))
    nodes = mesh.node_emission + mesh.node_reflectance * lighting
    corner_node = mesh.corner_node
    has_node = (corner_node >= 0)[..., None]
    corner_colors = np.where(has_node, nodes[np.maximum(corner_node, 0)], scene.emission[:, None, :])
    corner_lighting = np.where(has_node, lighting[np.maximum(corner_node, 0)], 0.0)
    front = slice(0, mesh.front_patch_count)
    owner = mesh.patch_triangle[front]
    weights = mesh.patch_areas[front]
    area = np.bincount(owner, weights=weights, minlength=count)
    sums = np.stack([np.bincount(owner, weights=weights * rgb[front, c], minlength=count) for c in range(3)], axis=1)
    triangle_radiosity = np.where(
        (area > 0)[:, None], sums / np.where(area > 0, area, 1.0)[:, None], corner_colors.mean(axis=1)
    )
    return np.ascontiguousarray(corner_colors), triangle_radiosity, np.ascontiguousarray(corner_lighting)
