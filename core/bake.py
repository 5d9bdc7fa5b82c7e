"""bake(): a Scene in, colours per triangle corner out, through the stages of the pipeline."""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field

import numpy as np

from .mesh.discretize import Discretization, discretised
from .reconstruct import estimate
from .reconstruct.corners import at_corners, per_corner
from .reconstruct.correction import near_field_correction
from .scene import Scene
from .settings import BakeSettings, resolved
from .solve.levels import solve
from .transport.arriving import ArrivingLight
from .transport.direct import DirectLighting
from .transport.formfactors import FormFactorEngine
from .util.progress import ProgressCallback, Stages, spans

# Each stage's share of the progress bar: about what it takes of a typical bake.
SHARES = {"discretise": 2, "rays": 2, "direct": 6, "solve": 87, "near field": 3, "split": 2, "corners": 0}


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
    settings = resolved(BakeSettings(method=method, solver=solver, **knobs), scene.extent, len(scene.triangles))
    channels = 1 if scene.is_grey else 3
    has_direct = bool(scene.lights) or bool(scene.sky.any()) or scene.environment is not None
    stages = Stages(progress)
    span = spans({name: share for name, share in SHARES.items()
                  if (name != "direct" or has_direct) and (name != "near field" or settings.near_field)
                  and (name != "split" or settings.split_direct)})

    mesh, panels = stages.run("discretising", span["discretise"], discretised, scene, settings.patch_size,
                              math.radians(settings.crease_angle), settings.merge_flat, timer="discretise")
    engine = stages.run("preparing rays", span["rays"], lambda _report: FormFactorEngine(
        mesh, method, settings.hemicube_resolution, settings.rays_per_form_factor, settings.seed,
        probing=settings.probe_rays), timer="setup")
    light = ArrivingLight(engine, DirectLighting(scene.lights, scene.sky, engine.visibility,
                                                 settings.rays_per_form_factor, settings.seed,
                                                 scene.environment), channels)
    patch_direct = np.zeros((mesh.patch_count, channels))
    node_direct = np.zeros((mesh.node_count, channels))
    if has_direct:
        patch_direct, node_direct = stages.run("direct light", span["direct"], _direct_light, light, timer="direct_light")
    with stages.within(span["solve"]):
        solution = solve(light, patch_direct, node_direct, settings, stages)
    light, radiosity, node_lighting = solution.light, solution.radiosity, solution.node_lighting
    mesh, near_errors, near_stats = light.mesh, None, None
    if settings.near_field:
        node_lighting, near_errors, near_stats = stages.run("near field", span["near field"], near_field_correction,
                                                            scene, light, radiosity, node_lighting, timer="near_field")
    corner_direct = None
    if settings.split_direct:
        corner_direct = stages.run("direct light at vertices", span["split"], _direct_at_corners, light, node_direct,
                                   node_lighting, timer="split")
    corners = stages.run("per-corner colours", span["corners"], lambda _report: per_corner(
        scene, mesh, radiosity, node_lighting, None if panels is None else panels.triangle_panel), timer="reconstruct")
    error = estimate.of_bake(mesh, mesh.node_radiosity(node_lighting), radiosity, light.engine.receiving_points,
                             method, solution.stats, solution.level_change, solution.noise, near_errors)
    stages.done()
    stats = {
        "method": method,
        "solver": solver,
        "settings": dataclasses.asdict(settings),
        "triangles": len(scene.triangles),
        "panels": len(mesh.panel_corners),
        "patches": mesh.patch_count,
        "lights": len(scene.lights),
        "nodes": mesh.node_count,
        "channels": channels,
        "near_field": near_stats,
        "seconds": stages.seconds | {"total": sum(stages.seconds.values())},
        "rays_cast": light.engine.rays_cast,
        "peak_memory_estimate": _base_bytes(mesh) + solution.extra_bytes + light.engine.working_bytes(),
        "error_estimate": error,
        **solution.stats,
    }
    return BakeResult(*corners, stats, corner_direct)


def _direct_light(light: ArrivingLight, report) -> tuple[np.ndarray, np.ndarray]:
    """The lights' and the sky's light, averaged over each patch (P, C) and at each node (N, C)."""
    mesh = light.mesh
    return (light.on_patches(None, lambda f: report(f / 2)),
            light.from_lights(mesh.node_points, mesh.node_normals, lambda f: report(0.5 + f / 2)))


def _direct_at_corners(light: ArrivingLight, node_direct: np.ndarray, node_lighting: np.ndarray,
                       _report) -> np.ndarray:
    """(T, 3, 3) the light G_d at each corner straight from the lights and the sky (``node_direct``
    (N, C)) and from the emitting patches (their first shot), at most all of ``node_lighting``."""
    mesh = light.mesh
    emitted = light.engine.emitted_light(mesh.node_points, mesh.node_normals)[:, : light.channels]
    direct = at_corners(mesh, np.minimum(node_direct + emitted, node_lighting))
    return np.ascontiguousarray(np.broadcast_to(direct, direct.shape[:2] + (3,)))


def _base_bytes(mesh: Discretization) -> int:
    """Rough size of the discretisation and the solver's vectors."""
    return sum(value.nbytes for value in vars(mesh).values() if isinstance(value, np.ndarray)) + 64 * mesh.patch_count
