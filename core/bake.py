"""bake(): a Scene in, colours per triangle corner out, through the stages of the pipeline;
``BakeSession``: bakes that keep their geometry work and re-solve when only colours change."""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field

import numpy as np

from .mesh.discretize import Discretization, discretised
from .mesh.panels import Panels
from .mesh.surfaces import regions_split, resurfaced
from .reconstruct import estimate
from .reconstruct.corners import at_corners, per_corner
from .reconstruct.correction import near_field_correction
from .reconstruct.denoise import denoised
from .scene import Scene
from .scene.changes import geometry_change, intensities
from .settings import BakeSettings, resolved, with_monte_carlo
from .solve.levels import Solution, solve
from .transport.arriving import ArrivingLight
from .transport.direct import DirectLighting
from .transport.formfactors import FormFactorEngine
from .util.hugepages import without_huge_page_advice
from .util.progress import ProgressCallback, Stages, relayed, spans

# Each stage's share of the progress bar: about what it takes of a typical bake.
SHARES = {"discretise": 2, "rays": 2, "direct": 6, "solve": 87, "near field": 3, "denoise": 0, "split": 2,
          "corners": 0}


@dataclass
class BakeResult:
    """corner_colors (T, 3, 3): RGB radiosity at each corner of each input triangle, B = E + rho G.
    triangle_radiosity (T, 3): area-weighted mean radiosity of each input triangle's patches (the
        mean of its corner colours where it was merged into a larger panel, ``merge_flat``).
    corner_lighting (T, 3, 3): the light arriving at each corner, G = irradiance / pi (what a
        white surface would reflect: "lighting only", to multiply with a texture later).
    corner_direct (T, 3, 3): with ``split_direct``, the part of ``corner_lighting`` that comes
        straight from the lights, the sky and the emitters (at most all of it), else None
        (``reconstruct.corners.direct_and_indirect`` makes colours of it).
    stats: what the bake measured (seconds per stage, shots or iterations, rays, ...)."""

    corner_colors: np.ndarray
    triangle_radiosity: np.ndarray
    corner_lighting: np.ndarray
    stats: dict = field(default_factory=dict)
    corner_direct: np.ndarray | None = None


def bake(scene: Scene, method: str = "raycast", solver: str = "progressive", progress: ProgressCallback | None = None,
         **knobs) -> BakeResult:
    """Solve B = E + rho F B on ``scene`` and return colours per triangle corner.

    ``method``, ``solver`` and ``knobs`` are BakeSettings' (``core.settings.KNOBS``).
    ``progress(fraction, message)`` is called at least every 0.2 s; if it returns False the bake
    raises BakeCancelled. ``stats["error_estimate"]`` is ``reconstruct.estimate``'s.
    """
    return BakeSession(method, solver, keep=False, **knobs).bake(scene, progress)


@dataclass
class _Kept:
    """What a session's first bake computed from the geometry alone (``BakeSession``)."""

    scene: Scene  # the scene it baked: its geometry and light sources
    settings: BakeSettings
    panels: Panels | None
    solver: dict = field(default_factory=dict)  # levels.solve's form factors and gather rays
    near_field: dict = field(default_factory=dict)  # correction's pairs, rows and factors
    sharp: dict = field(default_factory=dict)  # ArrivingLight.sharp's form factors and shadows
    # from the solve on: the light over the last level's patches (the engine, its rays, the
    # sources), each source's light per unit over those patches (P, S, 3) and at the nodes (N, S, 3)
    light: ArrivingLight | None = None
    patch_factors: np.ndarray | None = None
    node_factors: np.ndarray | None = None
    node_noise: np.ndarray | None = None  # the standard error of the sky's in node_factors (N, S - lights, 3)
    level_change: float | None = None

    def bytes(self) -> int:
        """About what it holds beyond the scene."""
        held = (self.patch_factors, self.node_factors, self.node_noise, self.solver, self.near_field, self.sharp)
        return _held_bytes(held) + _base_bytes(self.light.mesh)


class BakeSession:
    """Bakes that keep what depends on the geometry alone (patches and nodes, the rays' scene,
    form factors, each light's shadows per unit of its intensity, the near field's pairs), so
    that a scene whose colours alone changed (reflectance and emission, a light's power or
    colour, the sky's colour, the environment's strength) is re-solved with them instead of
    baked afresh: ``bake`` chooses, and ``change`` says why it would not re-solve.

        session = BakeSession(**knobs)
        first = session.bake(scene)         # a bake, and what it can reuse
        again = session.bake(recoloured)    # a re-solve: again.stats["resolved"] is True

    A re-solve solves on the first bake's last patches (its refinement levels are not redone)
    and finds the form factors kept (progressive's columns while they fit ``column_cache``;
    Jacobi's and Gauss-Seidel's matrix; where the final gather's rays land; Monte Carlo's
    particles' paths, read with the new colours unless surfaces grew brighter or the light moved:
    ``montecarlo.ParticlePaths.reusable``); the hierarchical solver links again. It matches a
    fresh bake of the new colours within the bake's error estimate (tests/core/test_session.py;
    docs/methods.md, "Re-solves"). ``keep=False``: bakes that keep nothing (``core.bake``).
    """

    def __init__(self, method: str = "raycast", solver: str = "progressive", keep: bool = True, **knobs) -> None:
        BakeSettings(method=method, solver=solver, **knobs)  # refused here, not at the first bake
        self.method, self.solver, self.knobs, self.keep = method, solver, knobs, keep
        self._kept: _Kept | None = None

    def change(self, scene: Scene) -> str | None:
        """Why ``bake(scene)`` would bake afresh, in words; None when it re-solves."""
        kept = self._kept  # read once: a bake on its thread may replace it
        if kept is None:
            return "nothing was baked yet"
        change = geometry_change(kept.scene, scene)
        if change is None and regions_split(kept.panels, scene):
            change = "colours differ now inside a flat region whose triangles were merged"
        return change

    @property
    def kept_bytes(self) -> int:
        """About the memory the session holds for re-solves."""
        kept = self._kept  # read once: a bake on its thread may replace it
        return 0 if kept is None else kept.bytes()

    def bake(self, scene: Scene, progress: ProgressCallback | None = None) -> BakeResult:
        """``core.bake``'s result for ``scene``, re-solved when only its colours changed since
        this session's last bake afresh (then ``stats["resolved"]`` is True). The bake runs on a
        worker thread; ``progress`` is called from this one (``progress.relayed``). NumPy's
        huge-page advice is withheld meanwhile where the kernel would stall on it
        (``util.hugepages``)."""
        with without_huge_page_advice():
            result, kept = relayed(lambda report: self._baked(scene, report), progress)
        self._kept = kept  # only for a bake not cancelled, not even at its last report
        return result

    def _baked(self, scene: Scene, progress: ProgressCallback | None) -> tuple[BakeResult, _Kept | None]:
        """The bake, and what the session keeps after it."""
        if self.change(scene) is None:
            return self._resolve(scene, progress), self._kept
        self._kept = None  # nothing stale is held while the new bake runs
        return self._first(scene, progress)

    def _first(self, scene: Scene, progress: ProgressCallback | None) -> tuple[BakeResult, _Kept | None]:
        method = self.method
        settings = resolved(BakeSettings(method=method, solver=self.solver, **self.knobs), scene.extent)
        channels = 1 if scene.is_grey else 3
        has_direct = bool(scene.lights) or bool(scene.sky.any()) or scene.environment is not None
        stages = Stages(progress)
        span = _spans(settings, has_direct, first=True)
        mesh, panels = stages.run("discretising", span["discretise"], discretised, scene, settings.patch_size,
                                  math.radians(settings.crease_angle), settings.merge_flat, timer="discretise")
        settings = with_monte_carlo(settings, mesh.patch_count, mesh.node_count, scene.extent)
        engine = stages.run("preparing rays", span["rays"], lambda _report: FormFactorEngine(
            mesh, method, settings.hemicube_resolution, settings.rays_per_form_factor, settings.seed,
            probing=settings.probe_rays, light_means=settings.solver == "progressive" and bool(
                settings.monte_carlo_rays)), timer="setup")
        direct = DirectLighting(scene.lights, scene.sky, engine.visibility, settings.rays_per_form_factor,
                                settings.seed, scene.environment)
        kept = _Kept(scene, settings, panels)
        light = ArrivingLight(engine, direct, channels, kept=kept.sharp if self.keep else None)
        patch_factors = np.zeros((mesh.patch_count, direct.source_count, 3))
        node_factors = np.zeros((mesh.node_count, direct.source_count, 3))
        node_noise = np.zeros((mesh.node_count, direct.source_count - len(direct.lights), 3))
        if has_direct:
            patch_factors, node_factors, node_noise = stages.run("direct light", span["direct"], _direct_light, light,
                                                                 timer="direct_light")
        node_direct = light.combined(node_factors)
        with stages.within(span["solve"]):
            # a bake that keeps nothing lets the solver's form factors and particles go with it
            solution = solve(light, patch_factors, node_direct, settings, stages, kept.solver if self.keep else {})
        kept.light, kept.patch_factors, kept.node_factors = solution.light, solution.patch_factors, node_factors
        kept.node_noise = node_noise
        kept.level_change = solution.level_change
        result = self._finish(scene, settings, panels, solution, node_direct, kept, stages, span)
        return result, kept if self.keep else None

    def _resolve(self, scene: Scene, progress: ProgressCallback | None) -> BakeResult:
        kept = self._kept
        settings = kept.settings
        first = kept.light
        stages = Stages(progress)
        span = _spans(settings, first.has_direct, first=False)
        mesh = resurfaced(first.mesh, kept.panels, scene)
        light = ArrivingLight(first.engine.with_surfaces(mesh), first.direct, 1 if scene.is_grey else 3,
                              intensities(kept.scene, scene), kept.sharp)
        node_direct = light.combined(kept.node_factors)
        with stages.within(span["solve"]):
            solution = solve(light, kept.patch_factors, node_direct, dataclasses.replace(settings, refinement_levels=0),
                             stages, kept.solver)
        solution.level_change = kept.level_change
        return self._finish(scene, settings, kept.panels, solution, node_direct, kept, stages, span)

    def _finish(self, scene: Scene, settings: BakeSettings, panels: Panels | None, solution: Solution,
                node_direct: np.ndarray, kept: _Kept, stages: Stages, span: dict) -> BakeResult:
        """The stages after the solve: near field, direct light at the corners, corner colours,
        the error estimate and the statistics."""
        light, radiosity, node_lighting = solution.light, solution.radiosity, solution.node_lighting
        mesh, near_errors, near_stats = light.mesh, None, None
        if settings.near_field and solution.near_change is None:  # else a final gather read the near patches
            node_lighting, near_errors, near_stats = stages.run(
                "near field", span["near field"], near_field_correction, scene, light, radiosity, node_lighting,
                kept.near_field, settings.column_cache if self.keep else 0, timer="near_field")
        sampling_noise = _sampling_noise(light, kept.node_noise)
        if settings.denoise and solution.noise is not None:
            node_lighting = stages.run("denoising", span["denoise"], _denoised, light, node_lighting,
                                       kept.node_factors, np.hypot(solution.noise, sampling_noise),
                                       solution.node_distance, settings.denoise, timer="denoise")
        corner_direct = None
        if settings.split_direct:
            corner_direct = stages.run("direct light at vertices", span["split"], _direct_at_corners, light,
                                       node_direct, node_lighting, timer="split")
        corners = stages.run("per-corner colours", span["corners"], lambda _report: per_corner(
            scene, mesh, radiosity, node_lighting, None if panels is None else panels.triangle_panel),
            timer="reconstruct")
        if solution.near_change is not None:  # what reading the near patches where the rays landed changed
            near_errors = mesh.node_reflectance[:, : light.channels] * np.abs(solution.near_change)
        error = estimate.of_bake(mesh, mesh.node_radiosity(node_lighting), radiosity, light.engine.receiving_points,
                                 self.method, solution.stats, solution.level_change, solution.noise, near_errors,
                                 sampling_noise)
        stages.done()
        stats = {
            "method": self.method,
            "solver": self.solver,
            "settings": dataclasses.asdict(settings),
            "triangles": len(scene.triangles),
            "panels": len(mesh.panel_corners),
            "patches": mesh.patch_count,
            "lights": len(scene.lights),
            "nodes": mesh.node_count,
            "channels": light.channels,
            "near_field": near_stats,
            "seconds": stages.seconds | {"total": sum(stages.seconds.values())},
            "rays_cast": light.engine.rays_cast,
            "peak_memory_estimate": _base_bytes(mesh) + solution.extra_bytes + light.engine.working_bytes()
            + light.engine.visibility.bytes + (kept.bytes() if self.keep else 0),
            "error_estimate": error,
            "resolved": kept is self._kept,
            **solution.stats,
        }
        return BakeResult(*corners, stats, corner_direct)


def _spans(settings: BakeSettings, has_direct: bool, first: bool) -> dict:
    """The progress bar's span of each stage the bake runs (a re-solve: from the solve on)."""
    return spans({name: share for name, share in SHARES.items()
                  if (name != "direct" or has_direct) and (name != "near field" or settings.near_field)
                  and (name != "split" or settings.split_direct) and (name != "denoise" or settings.denoise)
                  and (first or name not in ("discretise", "rays", "direct"))})


def _direct_light(light: ArrivingLight, report) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The lights' and the sky's light per source and unit of its intensity (``DirectLighting``),
    averaged over each patch (P, S, 3) and at each node (N, S, 3), and the standard error of the
    sky's and the environment's sampling at each node (N, S - L, 3), L the lights."""
    mesh = light.mesh
    return (light.factors_on_patches(None, lambda f: report(f / 2)),
            *light.direct.sampled_factors_at(mesh.node_points, mesh.node_normals, lambda f: report(0.5 + f / 2)))


def _sampling_noise(light: ArrivingLight, noise: np.ndarray) -> np.ndarray:
    """(N, C) the standard error of the nodes' light from the sky and the environment, from its
    per unit of each (N, S - L, 3), after the L lights (``DirectLighting.sampled_factors_at``)."""
    lights = len(light.direct.lights)
    return light.direct.combine(noise, light.intensities[lights:])[:, : light.channels]


def _denoised(light: ArrivingLight, node_lighting: np.ndarray, node_factors: np.ndarray, noise: np.ndarray,
              distance: np.ndarray, strength: float, report) -> np.ndarray:
    """(N, C) ``node_lighting`` averaged with the neighbours' by its ``noise`` (N, C) and the
    ``distance`` (N,) its gather's rays went (``reconstruct.denoise``), but for the lights' light,
    which has none: taken from ``node_factors`` (N, S, 3) before and put back after."""
    lights = light.light_parts(node_factors)[0]
    return lights + denoised(light.mesh, node_lighting - lights, noise, distance, strength, report)


def _direct_at_corners(light: ArrivingLight, node_direct: np.ndarray, node_lighting: np.ndarray,
                       _report) -> np.ndarray:
    """(T, 3, 3) the light G_d at each corner straight from the lights and the sky (``node_direct``
    (N, C)) and from the emitting patches (their first shot), at most all of ``node_lighting``."""
    mesh = light.mesh
    emitted = light.engine.emitted_light(mesh.node_points, mesh.node_normals)[:, : light.channels]
    direct = at_corners(mesh, np.minimum(node_direct + emitted, node_lighting))
    return np.ascontiguousarray(np.broadcast_to(direct, direct.shape[:2] + (3,)))


def _held_bytes(value) -> int:
    """The bytes of the arrays in ``value``: arrays, and dicts, sequences and dataclasses of them
    (an array held twice counts twice)."""
    if hasattr(value, "nbytes"):
        return value.nbytes
    if isinstance(value, dict):
        value = list(value.values())
    elif dataclasses.is_dataclass(value):
        value = [getattr(value, item.name) for item in dataclasses.fields(value)]
    return sum(_held_bytes(item) for item in value) if isinstance(value, (list, tuple)) else 0


def _base_bytes(mesh: Discretization) -> int:
    """Rough size of the discretisation and the solver's vectors."""
    return sum(value.nbytes for value in vars(mesh).values() if isinstance(value, np.ndarray)) + 64 * mesh.patch_count
