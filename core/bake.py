"""bake(): a Scene in, per-corner radiosity out, through discretise -> form factors -> solve ->
gather at the receiver nodes -> per-corner colours."""

from __future__ import annotations

import math
import time
from dataclasses import asdict, dataclass, field
from typing import Callable

import numpy as np

from . import estimate, montecarlo, nearfield, refine, simplify, solvers, touching
from .discretize import Discretization, discretize
from .formfactors import METHODS, FormFactorEngine
from .lights import DirectLighting
from .progress import Progress, ProgressCallback
from .raycast import check_ray_count
from .scene import Scene
from .visibility import Visibility

AUTO_PATCH_DIVISIONS = 8  # default patch size: the scene's extent over this (the PREVIEW preset's)
COARSE_TOLERANCE = 10  # a level that will be refined stops at this times the tolerance
NEAR_FIELD_FROM = 0.97  # the progress fraction where the near-field correction starts
MONTE_CARLO_FROM = 0.5  # with monte_carlo_rays, the share of the solve's progress the shots take


@dataclass(frozen=True)
class BakeSettings:
    """The knobs of a bake, validated on construction.

    patch_size : longest patch edge in scene units; None picks extent / 8.
    crease_angle : degrees; faces meeting at a sharper angle (and always beyond 90) do not
        share a vertex colour.
    hemicube_resolution : pixels across the hemicube's top face (even).
    rays_per_form_factor : visibility rays per point-to-patch form factor (a perfect square);
        also the shadow rays per piece of an area light (16 pieces or more, within a bound:
        ``lights``) and the sky directions per point.
    tolerance : stop when the estimated fraction of light not yet distributed (progressive) or
        the bound on the relative error (Jacobi, Gauss-Seidel) is below this.
    ambient : progressive only: add the ambient estimate of the light not yet shot.
    max_shots : progressive refinement stops after this many shots (None: when converged; with
        ``monte_carlo_rays``, once every emitter has shot).
    monte_carlo_rays : progressive only: what is left unshot when the shots stop is carried by
        Monte Carlo (``montecarlo``) instead of the ambient term: rays / 16 particles per patch,
        then this many final-gather rays per vertex (a perfect square; 0: off). Every emitting
        patch shoots first, whatever ``max_shots`` says, so direct light and its shadows stay
        exact. For large scenes, where converging takes a shot per patch.
    max_iterations : Jacobi and Gauss-Seidel stop after this many sweeps.
    memory_budget : bytes the explicit matrix of Jacobi / Gauss-Seidel may take.
    column_cache : bytes of form-factor columns progressive refinement may keep for reshooting.
    seed : fixes the ray-casting sample positions.
    refinement_levels : times the patches where radiosity jumps are split in four after a solve
        (each patch at most once per level); with one or more, and the hemicube or no near
        field, the change in the last level is the discretisation error estimate (the
        hemicube's at least the gap estimate too; ``estimate``).
    refinement_threshold : a patch is split when its radiosity differs from a neighbour's on
        the same surface by more than this fraction of the mean radiosity of the patches that
        do not emit.
    near_field : read the patches next to each vertex from their linear interpolants, not their
        means (``nearfield``): the vertices along concave edges and contact lines.
    probe_rays : ray casting: cast a quarter of each form factor's rays first, the rest only
        where they disagree (``raycast.RayCaster``): about half the time, shadows a little
        less exact.
    merge_flat : patch flat regions of triangles smaller than the patch size as panels up to
        the patch size (``simplify``), not triangle by triangle: a finely tessellated wall costs
        about what a coarse one does, and the patch size, not the mesh, sets the accuracy;
        colours are still evaluated at every input vertex. Off: every input triangle is at
        least one patch.
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
    column_cache: int = 1 << 30
    seed: int = 0
    refinement_levels: int = 0
    refinement_threshold: float = 0.25
    near_field: bool = True
    probe_rays: bool = True
    merge_flat: bool = True
    monte_carlo_rays: int = 0

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
        if self.max_shots is not None and (int(self.max_shots) != self.max_shots or self.max_shots < 0):
            raise ValueError(f"max_shots must be a non-negative integer or None, got {self.max_shots}")
        check_ray_count(self.rays_per_form_factor)
        if self.monte_carlo_rays:
            montecarlo.check_gather_rays(self.monte_carlo_rays)
        if int(self.refinement_levels) != self.refinement_levels or not 0 <= self.refinement_levels <= 8:
            raise ValueError(f"refinement_levels must be an integer from 0 to 8, got {self.refinement_levels}")
        if not (math.isfinite(self.refinement_threshold) and self.refinement_threshold > 0):
            raise ValueError(f"refinement_threshold must be a positive number, got {self.refinement_threshold}")


@dataclass
class BakeResult:
    """corner_colors (T, 3, 3): RGB radiosity at each corner of each input triangle, B = E + rho G.
    triangle_radiosity (T, 3): area-weighted mean radiosity of each input triangle's patches (the
        mean of its corner colours where it was merged into a larger panel, ``merge_flat``).
    corner_lighting (T, 3, 3): the light arriving at each corner, G = irradiance / pi (what a
        white surface would reflect: "lighting only", to multiply with a texture later).
    stats: what the bake measured (seconds per stage, shots or iterations, rays, ...)."""

    corner_colors: np.ndarray
    triangle_radiosity: np.ndarray
    corner_lighting: np.ndarray
    stats: dict = field(default_factory=dict)


def _patch_size(scene: Scene, settings: BakeSettings) -> float:
    return settings.patch_size if settings.patch_size is not None else scene.extent / AUTO_PATCH_DIVISIONS


def discretised(scene: Scene, settings: BakeSettings, report: Callable[[float], object] = lambda _: None
                ) -> tuple[Discretization, simplify.Panels | None]:
    """The patches and nodes ``bake`` solves on, and the panels they were cut from: with
    ``merge_flat`` flat regions of small triangles merged (``simplify``; else None), cut into
    patches of ``patch_size`` (by default the scene's extent / AUTO_PATCH_DIVISIONS), without
    the back faces no surface sees (``discretize``'s ``hidden_backs``)."""
    patch_size = _patch_size(scene, settings)
    crease = math.radians(settings.crease_angle)
    panels = simplify.panels(scene, patch_size, lambda f: report(f / 2)) if settings.merge_flat else None
    return discretize(scene, patch_size, crease, lambda f: report(0.5 + f / 2), panels=panels,
                      hidden_backs=False), panels


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

    The scene is solved on patches of ``patch_size``, then ``refinement_levels`` times the
    patches where radiosity jumps by more than ``refinement_threshold`` are split in four and
    the solve goes on from where it was (``refine``). ``stats["error_estimate"]`` comes from
    ``estimate``: the light left unshot, plus the discretisation's part: with ray casting and the
    near field, how far the near patches are from linear (``nearfield.reading_error``); otherwise
    twice the change of the vertex colours in the last level, or with no refinement their gap to
    the nearest patches (with the hemicube at least that gap, which covers its aliasing).
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
    patch_size = _patch_size(scene, settings)
    mesh, panels = discretised(scene, settings, stages.report)
    crease = math.radians(settings.crease_angle)
    channels = 1 if scene.is_grey else 3
    seconds["discretise"], clock = _lap(clock)

    stages.stage("preparing rays", 0.02, 0.04)
    engine = FormFactorEngine(mesh, method, settings.hemicube_resolution, settings.rays_per_form_factor, settings.seed,
                              probing=settings.probe_rays)
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
    node_direct = node_direct[:, :channels]

    level = _Level(engine, solver, settings, channels, node_direct)
    levels = settings.refinement_levels
    end = NEAR_FIELD_FROM if settings.near_field else 1.0
    monte_carlo_from = end
    if solver == "progressive" and settings.monte_carlo_rays:
        end, monte_carlo_from = start + MONTE_CARLO_FROM * (end - start), end
    span = (end - start) / (1 + levels)
    previous_colors = None
    refinements = []
    for number in range(levels + 1):
        stages_from = start + number * span
        if number > 0:
            clock = time.perf_counter()
            chosen = refine.to_split(mesh, radiosity, colors, crease, settings.refinement_threshold)
            if len(chosen) == 0:
                break
            stages.stage(f"refining {number} of {levels}", stages_from, stages_from + 0.05 * span)
            mesh, origin = refine.split(mesh, chosen)
            engine = FormFactorEngine(mesh, method, settings.hemicube_resolution, settings.rays_per_form_factor,
                                      settings.seed, visibility=engine.visibility if method == "raycast" else None,
                                      probing=settings.probe_rays)
            patch_direct = _refined_direct(direct, mesh, origin, patch_direct)
            refinements.append({"split": int(len(chosen)), "patches": mesh.patch_count})
            level.refine(engine, origin, mesh.patch_emission[:, :channels] + mesh.patch_reflectance[:, :channels]
                         * patch_direct[:, :channels], lambda f: stages.report(f))
            seconds["refine"] = seconds.get("refine", 0.0) + _lap(clock)[0]
        # lit by the lights, a patch starts out as if it emitted what it reflects of them
        sources = mesh.patch_emission[:, :channels] + mesh.patch_reflectance[:, :channels] * patch_direct[:, :channels]
        # a level to be refined needs only roughly where light changes: it stops COARSE_TOLERANCE looser
        # (but no looser than 0.1, or than the tolerance itself)
        tolerance = settings.tolerance
        if number < levels:
            tolerance = max(tolerance, min(tolerance * COARSE_TOLERANCE, 0.1))
        radiosity, node_lighting = level.solve(sources, tolerance, stages,
                                               stages_from + (0.05 * span if number else 0.0), stages_from + span, seconds)
        colors = mesh.node_emission[:, :channels] + mesh.node_reflectance[:, :channels] * node_lighting
        change = None if previous_colors is None else estimate.level_change(mesh, colors, previous_colors)
        previous_colors = colors
    noise = None
    if solver == "progressive" and settings.monte_carlo_rays and not level.stats["converged"]:
        radiosity, node_lighting, noise = level.monte_carlo(stages, end, monte_carlo_from, seconds)
        colors = mesh.node_emission[:, :channels] + mesh.node_reflectance[:, :channels] * node_lighting
    near_stats = None
    if settings.near_field:
        clock = time.perf_counter()
        stages.stage("near field", NEAR_FIELD_FROM, 1.0)
        near = nearfield.near_field(scene, mesh, radiosity, engine.point_form_factors)
        point_lighting = engine.gather(near.points, near.normals, radiosity, lambda f: stages.report(f / 2))
        direct_light = direct.at_points(near.points, near.normals, lambda f: stages.report(0.5 + f / 2))
        point_lighting += direct_light[:, :channels]
        near, direct_detail, detailed_pairs = touching.read_touching(
            near, mesh, lambda points, normals: engine.emitted_light(points, normals)
            + direct.lights_at(points, normals), channels)
        node_lighting = node_lighting + direct_detail[: mesh.node_count]
        point_lighting = point_lighting + direct_detail[mesh.node_count:]
        lighting, iterations = nearfield.corrected_lighting(near, mesh, radiosity, node_lighting, point_lighting)
        node_lighting = lighting[: mesh.node_count]
        near_stats = {"pairs": near.pair_count, "interpolation_nodes": len(near.points), "iterations": iterations,
                      "direct_detail_pairs": detailed_pairs}
        colors = mesh.node_emission[:, :channels] + mesh.node_reflectance[:, :channels] * node_lighting
        # ray casting's discretisation estimate, tighter than the change in the last level; the
        # hemicube's aliasing at the nodes is not in it (docs/methods.md)
        if near.pair_count and method == "raycast":
            change = estimate.near_field_error(mesh, colors, nearfield.reading_error(near, mesh, radiosity, lighting))
        seconds["near_field"], _ = _lap(clock)
    if change is None:
        change = estimate.corner_patch_gap(mesh, colors, radiosity, engine.receiving_points)
    elif method == "hemicube":  # the gap is what covers the hemicube's aliasing (docs/methods.md)
        change = max(change, estimate.corner_patch_gap(mesh, colors, radiosity, engine.receiving_points))
    clock = time.perf_counter()
    corner_colors, triangle_radiosity, corner_lighting = _per_corner(
        scene, mesh, radiosity, node_lighting, None if panels is None else panels.triangle_panel)
    seconds["reconstruct"], _ = _lap(clock)
    stages.report(1.0, "done", force=True)

    solve_stats = level.stats
    if noise is None:
        left = estimate.solver_error(mesh, radiosity, solve_stats)
    else:  # the light not shot is distributed, up to the final gather's noise
        left = estimate.monte_carlo_error(mesh, colors, mesh.node_reflectance[:, :channels] * noise)
    stats = {
        "method": method,
        "solver": solver,
        "settings": asdict(settings) | {"patch_size": patch_size},
        "triangles": len(scene.triangles),
        "panels": len(mesh.panel_corners),
        "patches": mesh.patch_count,
        "lights": len(scene.lights),
        "nodes": mesh.node_count,
        "channels": channels,
        "refinements": refinements,
        "near_field": near_stats,
        "seconds": seconds | {"total": sum(seconds.values())},
        "rays_cast": engine.rays_cast,
        "peak_memory_estimate": _base_bytes(mesh) + level.extra_bytes + engine.working_bytes(),
        "error_estimate": {
            "unshot": left,
            "discretisation": change,
            "total": max(left + change, estimate.ROUNDING_FLOOR),
        },
        **solve_stats,
    }
    return BakeResult(corner_colors, triangle_radiosity, corner_lighting, stats)


class _Level:
    """The solve of one discretisation, and how it goes on after the patches are refined:
    progressive refinement resumes its ShootingState, the refined patches' light corrected by a
    gather at their own receiving points; Jacobi and Gauss-Seidel start from the refined
    patches' inherited radiosity."""

    def __init__(self, engine: FormFactorEngine, solver: str, settings: BakeSettings, channels: int,
                 node_direct: np.ndarray):
        self.engine, self.solver, self.settings = engine, solver, settings
        self.channels, self.node_direct = channels, node_direct
        self.state: solvers.ShootingState | None = None
        self.radiosity: np.ndarray | None = None  # the explicit solvers' last answer
        self.stats: dict = {}
        self.extra_bytes = 0

    def refine(self, engine: FormFactorEngine, origin: np.ndarray, sources: np.ndarray, report) -> None:
        """Move to ``engine``'s refined patches; ``origin`` maps each to the patch it came from."""
        self.engine = engine
        if self.state is not None:
            state = self.state
            patch_count = len(state.unshot)
            inherited = state.radiosity[:patch_count][origin]
            new = refine.children(origin, patch_count)
            mesh = engine.mesh
            # what the new patches have received is what was shot, B - U: the unshot rest reaches
            # them when it is shot (or carried by montecarlo), not now as well
            shot = (state.radiosity[:patch_count] - state.unshot)[origin]
            gathered = engine.gather(engine.receiving_points[new], mesh.patch_normals[new], shot, report)
            corrected = sources[new] + mesh.patch_reflectance[new, : self.channels] * gathered
            unshot = state.unshot[origin]
            unshot[new] += corrected - inherited[new]
            radiosity = inherited.copy()
            radiosity[new] = corrected
            self.state = solvers.ShootingState(np.concatenate([radiosity, state.radiosity[patch_count:]]), unshot,
                                               state.shots, state.power_shot, state.power_captured)
        else:
            self.radiosity = self.radiosity[origin]

    def solve(self, sources: np.ndarray, tolerance: float, stages: Progress, begin: float, end: float,
              seconds: dict):
        """Patch radiosity (P, C) and the light G arriving at the nodes (N, C)."""
        engine, settings = self.engine, self.settings
        mesh = engine.mesh
        clock = time.perf_counter()
        if self.solver == "progressive":
            nodes_receive = engine.method == "raycast"
            if self.state is None:
                self.state = solvers.ShootingState.start(
                    sources, self.node_direct if nodes_receive else np.zeros((0, self.channels)))
            stages.stage("shooting", begin, end if nodes_receive else begin + 0.8 * (end - begin))
            max_shots, first = settings.max_shots, None
            if settings.monte_carlo_rays:  # the emitters shoot, then the rest is left to montecarlo
                max_shots, first = max_shots or 0, mesh.patch_emission.any(axis=1)
            radiosity, node_lighting, stats = solvers.progressive(
                engine.shooting_columns, mesh.patch_areas, mesh.patch_reflectance[:, : self.channels], sources,
                np.ones_like(self.node_direct) if nodes_receive else None,
                self.node_direct if nodes_receive else None,
                tolerance=tolerance, ambient=settings.ambient, max_shots=max_shots,
                cache_bytes=settings.column_cache, report=stages.report, state=self.state, first=first,
            )
            self.extra_bytes = max(self.extra_bytes, stats["cached_columns"] * 8 * (mesh.patch_count + mesh.node_count))
            seconds["solve"] = seconds.get("solve", 0.0) + _lap(clock)[0]
            if not nodes_receive:
                node_lighting = self._gather(radiosity, stages, begin + 0.8 * (end - begin), end, seconds)
        else:
            radiosity, stats = self._solve_explicit(sources, tolerance, stages, begin, begin + 0.7 * (end - begin),
                                                    seconds)
            node_lighting = self._gather(radiosity, stages, begin + 0.7 * (end - begin), end, seconds)
        self.stats = stats
        return radiosity, node_lighting

    def monte_carlo(self, stages: Progress, begin: float, end: float, seconds: dict):
        """Patch radiosity (P, C), the light arriving at the nodes (N, C) and its standard error
        (N, C; None with the hemicube): the shots so far, plus what the light left unshot adds with all its bounces,
        X = U + rho F X, by particle tracing on the patches and a final gather at the nodes
        (``montecarlo``; with the hemicube, the nodes gather the result by hemicube instead)."""
        engine, settings, state = self.engine, self.settings, self.state
        clock = time.perf_counter()
        mesh = engine.mesh
        patch_count, front = mesh.patch_count, mesh.front_patch_count
        visibility = engine.visibility
        if len(visibility.triangle_normals) != front:  # refined: the rays' triangles must be the patches
            visibility = Visibility(mesh.patch_corners[:front], two_sided=mesh.back_of_front >= 0,
                                    owners=mesh.patch_triangle[:front])
        middle = (begin + end) / 2
        stages.stage("tracing particles", begin, middle)
        particles = int(patch_count * settings.monte_carlo_rays * montecarlo.PARTICLES_PER_RAY)
        future = montecarlo.trace(mesh, visibility, state.unshot, mesh.patch_reflectance[:, : self.channels],
                                  particles, settings.seed, stages.report)
        radiosity = state.radiosity[:patch_count] - state.unshot + future
        self.stats["monte_carlo"] = {"particles": particles, "gather_rays": settings.monte_carlo_rays}
        if engine.method == "hemicube":
            seconds["monte_carlo"], _ = _lap(clock)
            node_lighting = self._gather(radiosity, stages, middle, end, seconds)
            return radiosity, node_lighting, None  # the estimate keeps the unshot light's bound
        stages.stage("final gather", middle, end)
        gathered = montecarlo.gather(mesh, visibility, mesh.node_points, mesh.node_normals, future,
                                     settings.monte_carlo_rays, settings.seed, stages.report)
        seconds["monte_carlo"], _ = _lap(clock)
        return radiosity, state.radiosity[patch_count:] + gathered.light, gathered.standard_error

    def _gather(self, radiosity, stages: Progress, begin: float, end: float, seconds: dict) -> np.ndarray:
        clock = time.perf_counter()
        stages.stage("gathering at vertices", begin, end)
        mesh = self.engine.mesh
        gathered = self.engine.gather(mesh.node_points, mesh.node_normals, radiosity, lambda f: stages.report(f))
        seconds["gather"] = seconds.get("gather", 0.0) + _lap(clock)[0]
        return self.node_direct + gathered

    def _solve_explicit(self, sources, tolerance: float, stages: Progress, begin: float, end: float, seconds: dict):
        """Build the P x P matrix (within the memory budget), then Jacobi or Gauss-Seidel."""
        engine, settings, solver = self.engine, self.settings, self.solver
        mesh, clock = engine.mesh, time.perf_counter()
        matrix_bytes = 8 * mesh.patch_count**2
        if matrix_bytes > settings.memory_budget:
            raise ValueError(
                f"the {solver} solver needs a {mesh.patch_count:,} x {mesh.patch_count:,} form-factor matrix "
                f"({matrix_bytes / 2**30:.2f} GiB), over the memory budget of "
                f"{settings.memory_budget / 2**30:.2f} GiB; "
                "use solver='progressive', a larger patch_size, fewer refinement_levels, or raise memory_budget"
            )
        middle = (begin + end) / 2
        stages.stage("form factors", begin, middle)
        matrix = engine.patch_rows(np.arange(mesh.patch_count), lambda f: stages.report(f, "matrix"))
        seconds["form_factors"] = seconds.get("form_factors", 0.0) + _lap(clock)[0]
        clock = time.perf_counter()
        stages.stage("solving", middle, end)
        iterate = solvers.jacobi if solver == "jacobi" else solvers.gauss_seidel
        radiosity, stats = iterate(matrix, mesh.patch_reflectance[:, : self.channels], sources,
                                   tolerance, settings.max_iterations, stages.report, self.radiosity)
        self.radiosity = radiosity
        self.extra_bytes = max(self.extra_bytes, matrix_bytes)
        seconds["solve"] = seconds.get("solve", 0.0) + _lap(clock)[0]
        return radiosity, stats


def _refined_direct(direct: DirectLighting, mesh: Discretization, origin: np.ndarray,
                    patch_direct: np.ndarray) -> np.ndarray:
    """The patches' mean direct light, inherited, then measured again on the new children."""
    result = patch_direct[origin]
    if direct.empty:
        return result
    new = refine.children(origin, len(patch_direct))
    result[new] = direct.patch_means(mesh.patch_corners[new], mesh.patch_normals[new], lambda _f: None)
    return result


def _lap(start: float) -> tuple[float, float]:
    now = time.perf_counter()
    return now - start, now


def _base_bytes(mesh: Discretization) -> int:
    """Rough size of the discretisation and the solver's vectors."""
    return sum(value.nbytes for value in vars(mesh).values() if isinstance(value, np.ndarray)) + 64 * mesh.patch_count


def _per_corner(scene: Scene, mesh: Discretization, radiosity: np.ndarray, node_lighting: np.ndarray,
                triangle_panel: np.ndarray | None = None):
    """Corner colours B = E + rho G and lighting G from the nodes, triangle means from the front
    patches of each triangle's panel (``triangle_panel``: the panel that is the triangle, -1
    where it was merged into a larger one, whose mean is then its corners'); RGB float64."""
    count = len(scene.triangles)
    rgb = np.broadcast_to(radiosity, (len(radiosity), 3)) if radiosity.shape[1] == 1 else radiosity
    lighting = np.broadcast_to(node_lighting, (len(node_lighting), 3))
    nodes = mesh.node_emission + mesh.node_reflectance * lighting
    corner_node = mesh.corner_node
    has_node = (corner_node >= 0)[..., None]
    corner_colors = np.where(has_node, nodes[np.maximum(corner_node, 0)], scene.emission[:, None, :])
    corner_lighting = np.where(has_node, lighting[np.maximum(corner_node, 0)], 0.0)
    front = np.arange(mesh.front_patch_count)
    owner = mesh.patch_triangle[front]
    if triangle_panel is not None:  # panels to input triangles
        panel_triangle = np.full(len(mesh.panel_corners), -1)
        panel_triangle[triangle_panel[triangle_panel >= 0]] = np.flatnonzero(triangle_panel >= 0)
        owner = panel_triangle[owner]
        front, owner = front[owner >= 0], owner[owner >= 0]
    weights = mesh.patch_areas[front]
    area = np.bincount(owner, weights=weights, minlength=count)
    sums = np.stack([np.bincount(owner, weights=weights * rgb[front, c], minlength=count) for c in range(3)], axis=1)
    triangle_radiosity = np.where(
        (area > 0)[:, None], sums / np.where(area > 0, area, 1.0)[:, None], corner_colors.mean(axis=1)
    )
    return np.ascontiguousarray(corner_colors), triangle_radiosity, np.ascontiguousarray(corner_lighting)
