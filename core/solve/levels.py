"""The solve stage: the chosen solver on the patches, level after level of adaptive refinement
(``mesh.refine``), then Monte Carlo for what the shots left (``montecarlo``); the light arriving
at the receiver nodes comes with it."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..mesh import refine
from ..reconstruct import estimate
from ..rays.visibility import Visibility
from ..transport.arriving import ArrivingLight
from ..util.progress import Stages
from . import gather, hierarchical, iterative, montecarlo
from .progressive import ColumnCache, ShootingState, progressive

# A level that will be refined stops at this times the tolerance (no looser than 0.1).
COARSE_TOLERANCE = 10
# With Monte Carlo, the share of the stage's progress the shots take.
SHOTS_SHARE = 0.5


@dataclass
class Solution:
    """The solve stage's result, on its last level's patches.

    light : the ArrivingLight over those patches (its ``mesh`` and ``engine``).
    radiosity : (P, C) of the patches.
    node_lighting : (N, C) the light G arriving at the receiver nodes.
    noise : (N, C) the standard error of ``node_lighting`` where a final gather read what Monte
        Carlo carried, or None.
    near_change : (N, C) what that gather's near rays changed in ``node_lighting`` by reading
        where they landed (``gather.GatherHits.read``), or None where no gather read the patches
        next to the nodes (the near field then does: core/bake.py).
    node_distance : (N,) the harmonic mean distance the final gather's rays from each node went
        (``gather.GatherHits.mean_distance``), or None without that gather.
    level_change : the discretisation estimate from the last refinement level (``estimate``), or None.
    patch_factors : (P, S, 3) each source's direct light over the patches per unit of its intensity.
    stats : the solver's statistics (shots or iterations, ...), with "refinements" and "monte_carlo".
    extra_bytes : the solver's own memory beyond the patches' arrays (cached columns, a matrix).
    """

    light: ArrivingLight
    radiosity: np.ndarray
    node_lighting: np.ndarray
    noise: np.ndarray | None
    level_change: float | None
    patch_factors: np.ndarray
    stats: dict = field(default_factory=dict)
    extra_bytes: int = 0
    near_change: np.ndarray | None = None
    node_distance: np.ndarray | None = None


def solve(light: ArrivingLight, patch_factors: np.ndarray, node_direct: np.ndarray, settings,
          stages: Stages, kept: dict | None = None) -> Solution:
    """Solve on ``light``'s patches, whose mean direct light is ``patch_factors`` (P, S, 3) per
    source (a lit patch starts out as if it emitted what it reflects of it), with
    ``node_direct`` (N, C) at the nodes; ``settings`` a resolved BakeSettings. Each of
    ``settings.refinement_levels`` levels splits the patches where radiosity jumps and goes on
    from where the last one was. ``kept``: a dict in which the form factors computed for the last
    level's patches (progressive's columns, the Jacobi and Gauss-Seidel matrix) are kept, and
    found by a later solve on the same patches (``session``)."""
    patch_direct = light.combined(patch_factors)
    if settings.solver == "hierarchical":
        radiosity, node_lighting, stats, extra = hierarchical.solve(light, patch_direct, node_direct, settings, stages)
        return Solution(light, radiosity, node_lighting, None, None, patch_factors, stats | {"refinements": []}, extra)
    solver = _Levels(light, settings, node_direct, {} if kept is None else kept)
    levels = settings.refinement_levels
    monte_carlo = settings.solver == "progressive" and bool(settings.monte_carlo_rays)
    shots = (0.0, SHOTS_SHARE if monte_carlo else 1.0)
    previous_colors, change, refinements = None, None, []
    for number in range(levels + 1):
        share = (shots[1] - shots[0]) / (1 + levels)
        with stages.within((shots[0] + number * share, shots[0] + (number + 1) * share)):
            if number > 0:
                chosen = refine.to_split(light.mesh, radiosity, colors, math.radians(settings.crease_angle),
                                         settings.refinement_threshold)
                if len(chosen) == 0:
                    break
                light, patch_factors = stages.run(f"refining {number} of {levels}", (0.0, 0.05), solver.refine,
                                                  chosen, patch_factors, timer="refine")
                patch_direct = light.combined(patch_factors)
                refinements.append({"split": int(len(chosen)), "patches": light.mesh.patch_count})
            # a level to be refined needs only roughly where light changes: it stops COARSE_TOLERANCE
            # looser (but no looser than 0.1, or than the tolerance itself)
            tolerance = settings.tolerance
            if number < levels:
                tolerance = max(tolerance, min(tolerance * COARSE_TOLERANCE, 0.1))
            with stages.within((0.05 if number else 0.0, 1.0)):
                radiosity, node_lighting = solver.solve(light.mesh.patch_radiosity(patch_direct), tolerance, stages)
        colors = light.mesh.node_radiosity(node_lighting)
        change = None if previous_colors is None else estimate.level_change(light.mesh, colors, previous_colors)
        previous_colors = colors
    gathered = None
    if monte_carlo and not solver.stats["converged"]:
        with stages.within((SHOTS_SHARE, 1.0)):
            radiosity, node_lighting, gathered = solver.monte_carlo(stages, patch_factors)
    if gathered is None:
        return Solution(solver.light, radiosity, node_lighting, None, change, patch_factors,
                        solver.stats | {"refinements": refinements}, solver.extra_bytes)
    return Solution(solver.light, radiosity, node_lighting, gathered.standard_error, change, patch_factors,
                    solver.stats | {"refinements": refinements}, solver.extra_bytes, gathered.near_change,
                    solver.kept["gather_hits"].mean_distance)


class _Levels:
    """The solve of one discretisation, and how it goes on after the patches are refined:
    progressive refinement resumes its ShootingState, the refined patches' light corrected by a
    gather at their own receiving points; Jacobi and Gauss-Seidel start from the refined
    patches' inherited radiosity."""

    def __init__(self, light: ArrivingLight, settings, node_direct: np.ndarray, kept: dict) -> None:
        self.light, self.settings, self.kept = light, settings, kept
        self.channels, self.node_direct = light.channels, node_direct
        self.state: ShootingState | None = None
        self.radiosity: np.ndarray | None = None  # the explicit solvers' last answer
        self.sources: np.ndarray | None = None  # the patches' own light (P, C) in the last solve
        self.stats: dict = {}
        self.extra_bytes = 0

    def refine(self, chosen: np.ndarray, patch_factors: np.ndarray, report) -> tuple[ArrivingLight, np.ndarray]:
        """Split the patches ``chosen`` (``refine.split``) and move the solve onto them; returns
        the light over the new patches and their mean direct light per source (P, S, 3),
        inherited, then measured again on the new children."""
        mesh, origin = refine.split(self.light.mesh, chosen)
        self.light = light = self.light.refined(self.light.engine.refined(mesh))
        self.kept.clear()  # the form factors were the old patches'
        new = refine.children(origin, len(patch_factors))
        patch_factors = patch_factors[origin]
        if light.has_direct:
            patch_factors[new] = light.factors_on_patches(new)
        sources = mesh.patch_radiosity(light.combined(patch_factors))
        if self.state is not None:
            state = self.state
            patch_count = len(state.unshot)
            inherited = state.radiosity[:patch_count][origin]
            # what the new patches have received is what was shot, B - U: the unshot rest reaches
            # them when it is shot (or carried by montecarlo), not now as well
            shot = (state.radiosity[:patch_count] - state.unshot)[origin]
            gathered = light.gathered(light.engine.receiving_points[new], mesh.patch_normals[new], shot, report)
            corrected = sources[new] + mesh.patch_reflectance[new, : self.channels] * gathered
            unshot = state.unshot[origin]
            unshot[new] += corrected - inherited[new]
            radiosity = inherited.copy()
            radiosity[new] = corrected
            self.state = ShootingState(np.concatenate([radiosity, state.radiosity[patch_count:]]), unshot,
                                       state.shots, state.power_shot, state.power_captured, state.has_shot[origin])
        else:
            self.radiosity = self.radiosity[origin]
        return light, patch_factors

    def solve(self, sources: np.ndarray, tolerance: float, stages: Stages) -> tuple[np.ndarray, np.ndarray]:
        """Patch radiosity (P, C) and the light G arriving at the nodes (N, C), for the patches'
        own light ``sources`` (P, C)."""
        self.sources = sources
        if self.settings.solver != "progressive":
            radiosity = stages.run("form factors", (0.0, 0.35), self._matrix, timer="form_factors")
            radiosity = stages.run("solving", (0.35, 0.7), self._iterate, radiosity, sources, tolerance, timer="solve")
            return radiosity, stages.run("gathering at vertices", (0.7, 1.0), self._gather, radiosity, timer="gather")
        nodes_receive = self.light.engine.method == "raycast"  # the hemicube gathers at them afterwards
        radiosity, node_lighting = stages.run("shooting", (0.0, 1.0 if nodes_receive else 0.8), self._shoot,
                                              sources, tolerance, nodes_receive, timer="solve")
        if not nodes_receive:
            node_lighting = stages.run("gathering at vertices", (0.8, 1.0), self._gather, radiosity, timer="gather")
        return radiosity, node_lighting

    def _shoot(self, sources, tolerance: float, nodes_receive: bool, report):
        engine, settings, channels = self.light.engine, self.settings, self.channels
        mesh = engine.mesh
        if self.state is None:
            self.state = ShootingState.start(sources, self.node_direct if nodes_receive else np.zeros((0, channels)))
        max_shots, first = settings.max_shots, None
        if settings.monte_carlo_rays:  # the emitters shoot, then the rest is left to montecarlo
            max_shots, first = max_shots or 0, mesh.patch_emission.any(axis=1)
        radiosity, node_lighting, stats = progressive(
            engine.shooting_columns, mesh.patch_areas, mesh.patch_reflectance[:, :channels], sources,
            np.ones_like(self.node_direct) if nodes_receive else None,
            self.node_direct if nodes_receive else None,
            tolerance=tolerance, ambient=settings.ambient, max_shots=max_shots,
            cache_bytes=settings.column_cache, report=report, state=self.state, first=first,
            cache=self.kept.setdefault("columns", ColumnCache()),
        )
        self.extra_bytes = max(self.extra_bytes, self.kept["columns"].nbytes)
        self.stats = stats
        return radiosity, node_lighting

    def _matrix(self, report) -> np.ndarray:
        """The P x P form-factor matrix, refused when it would not fit the memory budget."""
        mesh, settings = self.light.mesh, self.settings
        matrix_bytes = 8 * mesh.patch_count**2
        if matrix_bytes > settings.memory_budget:
            raise ValueError(
                f"the {settings.solver} solver needs a {mesh.patch_count:,} x {mesh.patch_count:,} form-factor "
                f"matrix ({matrix_bytes / 2**30:.2f} GiB), over the memory budget of "
                f"{settings.memory_budget / 2**30:.2f} GiB; "
                "use solver='progressive', a larger patch_size, fewer refinement_levels, or raise memory_budget"
            )
        self.extra_bytes = max(self.extra_bytes, matrix_bytes)
        if "matrix" not in self.kept:
            self.kept["matrix"] = self.light.engine.patch_rows(np.arange(mesh.patch_count),
                                                               lambda f: report(f, "matrix"))
        return self.kept["matrix"]

    def _iterate(self, matrix: np.ndarray, sources: np.ndarray, tolerance: float, report) -> np.ndarray:
        """Jacobi or Gauss-Seidel on ``matrix``, from the last level's answer if there was one."""
        settings = self.settings
        iterate = iterative.jacobi if settings.solver == "jacobi" else iterative.gauss_seidel
        mesh = self.light.mesh
        radiosity, stats = iterate(matrix, mesh.patch_reflectance[:, : self.channels], sources,
                                   tolerance, settings.max_iterations, report, self.radiosity)
        bounds = stats.pop("error_bounds")  # (P, C): kept as its RMS, a number the statistics can hold
        self.stats = stats | {"rms_error_bound": estimate.rms_patch_error(mesh, bounds)}
        self.radiosity = radiosity
        return radiosity

    def _particles(self, mesh, visibility: Visibility, particles: int, stages: Stages) -> tuple[np.ndarray, bool]:
        """X (P, C) for the unshot light, from the particles' pools, and whether particles were
        traced for it: the paths of the last bake's particles are read with the colours of this
        one where they are about as good as new ones (``montecarlo.ParticlePaths.reusable``: a
        light's colour or strength, or reflectances that do not grow, changed since), else paths
        are traced, sent by power and the final gather's view importance (``_view_importance``; by
        power alone with the hemicube, which has no final gather), and kept. Where the patches that
        fewer than ``gather.SPARSE_HITS`` particles reached gather their light
        (``gather.patch_hits``) is found and kept with the paths; ``monte_carlo`` reads it."""
        unshot, reflectance = self.state.unshot, mesh.patch_reflectance[:, : self.channels]
        paths = self.kept.get("paths")
        traced = paths is None or not paths.reusable(mesh, unshot, reflectance)
        if traced:
            importance = None if self.light.engine.method == "hemicube" else self._view_importance(
                mesh, visibility, particles, stages)
            paths = self.kept["paths"] = stages.run(
                "tracing particles", (0.3, 0.6), lambda report: montecarlo.trace_paths(
                    mesh, visibility, unshot, reflectance, particles, self.settings.seed, report, importance,
                    receiving=self.light.engine.receiving_points),
                timer="monte_carlo")
        future = stages.run("reading the particles' paths", (0.6, 0.63), lambda report: paths.future(
            mesh, unshot, reflectance, report), timer="paths")
        if traced or "patch_hits" not in self.kept:  # the patches few particles reached, and where their rays went
            sparse = np.flatnonzero(np.bincount(paths.landings, minlength=mesh.patch_count) < gather.SPARSE_HITS)
            near, lights = self._reads_near(), self.light.direct
            self.kept["patch_hits"] = sparse, stages.run(
                "gathering at the patches few particles reached", (0.63, 0.68), lambda report: gather.patch_hits(
                    mesh, visibility, sparse, gather.PATCH_RAYS, self.settings.seed, report, near, lights),
                timer="monte_carlo")
        return future, traced

    def _reads_near(self) -> bool:
        """Whether the gathers read the patches where their rays land close: not under an
        environment, area lights or more than ``gather.MAX_NEAR_LIGHTS`` lights, which those rays
        would not see (the near field (core/bake.py) reads the nodes' near patches then)."""
        direct = self.light.direct
        return (self.settings.near_field and direct.environment is None and not direct.has_area_lights
                and len(direct.lights) <= gather.MAX_NEAR_LIGHTS)

    def _gather(self, radiosity: np.ndarray, report) -> np.ndarray:
        mesh = self.light.mesh
        return self.node_direct + self.light.gathered(mesh.node_points, mesh.node_normals, radiosity, report)

    def monte_carlo(self, stages: Stages, patch_factors: np.ndarray):
        """Patch radiosity (P, C), the light arriving at the nodes (N, C) and the final gather's
        ``gather.Gathered`` (None with the hemicube): the shots so far, plus what the light left
        unshot adds with all its bounces, X = U + rho F X, by particle tracing on the patches and a
        final gather at the nodes (``montecarlo``, ``gather``; with the hemicube, the nodes gather
        the result by hemicube). ``patch_factors`` (P, S, 3): the lights' and the sky's light on
        the patches per source, which the gather reads where its rays land close instead."""
        engine, settings, state = self.light.engine, self.settings, self.state
        mesh = engine.mesh
        visibility = engine.visibility
        # refined: the rays' triangles must be the patches
        if len(visibility.triangle_normals) != mesh.front_patch_count:
            visibility = Visibility(mesh.patch_corners[: mesh.front_patch_count], two_sided=mesh.back_of_front >= 0,
                                    owners=mesh.patch_triangle[: mesh.front_patch_count], casting=mesh.front_casts,
                                    opacity=mesh.front_opacity)
        particles = montecarlo.particle_count(mesh.patch_count, settings.monte_carlo_rays)
        future, traced = self._particles(mesh, visibility, particles, stages)
        shot = state.radiosity[: mesh.patch_count] - state.unshot
        self.stats["monte_carlo"] = {"particles": particles, "gather_rays": settings.monte_carlo_rays,
                                     "traced": traced, "gathered_patches": len(self.kept["patch_hits"][0])}
        reflectance = mesh.patch_reflectance[:, : self.channels]
        lights_part, intensities = self.light.light_parts(patch_factors)
        own = self.sources - shot - reflectance * lights_part
        sky = self.light.sky_parts(patch_factors)
        if sky is not None:
            own -= reflectance * sky[0]

        def read(values: np.ndarray) -> dict:
            """``gather.GatherHits.read``'s arguments for the patches' X ``values`` (P, C)."""
            return {"far": values, "opacity": mesh.patch_opacity, "own": own, "reflectance": reflectance,
                    "radiosity": shot + values, "emission": mesh.patch_emission[:, : self.channels],
                    "sky": None if sky is None else sky[1], "lights": intensities}

        # the patches few particles reached: X_p = U_p + rho_p sum_q F(p, q) X_q by their own rays,
        # read from the pools' X, and where those land close as the final gather reads
        sparse, hits = self.kept["patch_hits"]
        future[sparse] = state.unshot[sparse] + reflectance[sparse] * gather.patch_light(
            hits, gather.PATCH_RAYS, **read(future))
        radiosity = shot + future
        if engine.method == "hemicube":  # the estimate keeps the unshot light's bound
            return radiosity, stages.run("gathering at vertices", (0.68, 1.0), self._gather, radiosity,
                                         timer="gather"), None
        gathered = self._final_gather(mesh, visibility, read(future), stages)
        if visibility is not engine.visibility:  # the refined patches' own, beside the engine's
            self.extra_bytes += visibility.bytes
        return radiosity, state.radiosity[mesh.patch_count:] + gathered.light, gathered

    def _pools(self, mesh, visibility: Visibility) -> np.ndarray | None:
        """The pool each node gathers in (``gather.node_pools``), or None."""
        if "pools" not in self.kept:
            self.kept["pools"] = gather.node_pools(mesh, visibility, self.settings.seed)
        return self.kept["pools"]

    def _gather_hits(self, mesh, visibility: Visibility, stages: Stages) -> gather.GatherHits:
        """Where the final gather's rays from the nodes land (``gather.gather_hits``), kept."""
        if "gather_hits" not in self.kept:
            rays, direct = self.settings.monte_carlo_rays, self.light.direct
            self.kept["gather_hits"] = stages.run(
                "final gather", (0.0, 0.25), lambda report: gather.gather_hits(
                    mesh, visibility, mesh.node_points, mesh.node_normals, rays, self.settings.seed, report,
                    near=self._reads_near(), lights=direct, pools=self._pools(mesh, visibility), distances=True),
                timer="monte_carlo")
        return self.kept["gather_hits"]

    def _view_importance(self, mesh, visibility: Visibility, particles: int, stages: Stages) -> np.ndarray:
        """(P,) how much a unit of power leaving each patch adds to what the final gather reads
        (``montecarlo.view_importance`` of where its rays land, with the reflectances of now)."""
        landed = self._gather_hits(mesh, visibility, stages).patches
        viewed = np.bincount(landed[landed >= 0], minlength=mesh.patch_count).astype(float)
        importons = int(particles * montecarlo.IMPORTONS_PER_PARTICLE)
        return stages.run("tracing the view importance", (0.25, 0.3), lambda report: montecarlo.view_importance(
            mesh, visibility, viewed, mesh.patch_reflectance[:, : self.channels], importons, self.settings.seed,
            report, self.light.engine.receiving_points), timer="monte_carlo")

    def _final_gather(self, mesh, visibility: Visibility, read: dict, stages: Stages) -> gather.Gathered:
        """The final gather at the nodes (N, C) of what the shots left, ``read`` the arguments of
        ``gather.GatherHits.read`` (far: X, what the patches add beyond their shots; near: their
        radiosity where the rays landed, less their shots), with its standard error: made again
        with ``gather.regather_rays`` at the ``gather.noisy_nodes``, whose two estimates are
        averaged weighted by their rays (the choice of the nodes is independent of their own
        first estimate, so the mean stays unbiased). Where the rays land, and the nodes gathered
        again, are kept for a re-solve."""
        rays, seed = self.settings.monte_carlo_rays, self.settings.seed
        direct, near = self.light.direct, self._reads_near()
        cast = self._gather_hits(mesh, visibility, stages)
        first = stages.run("reading the final gather", (0.68, 0.72), lambda _report: cast.read(**read),
                           timer="monte_carlo")
        pools = self.kept.get("pools")
        if "regathered" not in self.kept:
            variance = first.standard_error ** 2  # each channel's share: the same for light scaled per channel
            channel_total = variance.sum(axis=0)
            shares = variance / np.where(channel_total > 0, channel_total, 1.0)
            more = gather.regather_rays(rays)
            nodes = gather.noisy_nodes(shares.sum(axis=1), mesh.corner_node, gather.REGATHER_SHARE) \
                if more else np.zeros(0, dtype=np.int64)
            hits = None if len(nodes) == 0 else stages.run(
                "final gather again where it is noisy", (0.72, 0.97), lambda report: gather.gather_hits(
                    mesh, visibility, mesh.node_points[nodes], mesh.node_normals[nodes], more, seed, report,
                    stream=gather.AGAIN_STREAM, near=near, lights=direct,
                    pools=None if pools is None else pools[nodes]),
                timer="monte_carlo")
            self.kept["regathered"] = nodes, hits
        nodes, hits = self.kept["regathered"]
        self.stats["monte_carlo"]["regathered_nodes"] = len(nodes)
        if pools is not None:
            self.stats["monte_carlo"]["pooled_nodes"] = int(gather.pooled(pools).sum())
        if hits is None:
            return first
        second = stages.run("reading the final gather again", (0.97, 1.0), lambda _report: hits.read(**read),
                            timer="monte_carlo")
        share = hits.patches.shape[1] / (rays + hits.patches.shape[1])  # the second's weight

        def averaged(first_values: np.ndarray, second_values: np.ndarray) -> np.ndarray:
            values = first_values.copy()
            values[nodes] = (1 - share) * first_values[nodes] + share * second_values
            return values

        standard_error = first.standard_error.copy()
        standard_error[nodes] = np.hypot((1 - share) * first.standard_error[nodes], share * second.standard_error)
        change = None if first.near_change is None else averaged(first.near_change, second.near_change)
        return gather.Gathered(averaged(first.light, second.light), standard_error, change)
