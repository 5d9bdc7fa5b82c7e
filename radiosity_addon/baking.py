"""One bake from Blender's point of view, shared by the operator (modal or straight through)
and the ``-c radiosity`` command: read the settings and the evaluated scene, run the core,
write the colours, say what was done."""

from __future__ import annotations

import sys
import time
from dataclasses import dataclass

import bpy

from ..core import BakeResult, BakeSession
from ..core.job import BakeJob
from ..core.rays import default_backend
from ..core.reconstruct.corners import direct_and_indirect
from . import sessions
from .extract import Extraction, extract
from .rendered import read_as_rendered
from .write import Storage, plan, write


# A light group's re-solve takes about this share of the first bake's time (progress shares).
RESOLVE_SHARE = 0.1


@dataclass
class Prepared:
    """A bake ready to run: the extracted scene, the core's arguments and the session that bakes
    it (kept between bakes, or for this bake's light groups alone)."""

    extraction: Extraction
    scene_name: str
    view_layer_name: str
    knobs: dict
    attribute: str
    lighting_only: bool
    copy_changed: bool
    storage: Storage
    separate_direct: bool = False
    session: BakeSession | None = None
    light_groups: tuple[str, ...] = ()

    def attributes(self) -> list[str]:
        """The colour attributes written: the bake's, its direct and indirect parts if asked, then
        one per light group."""
        extra = [f"{self.attribute} Direct", f"{self.attribute} Indirect"] if self.separate_direct else []
        return [self.attribute] + extra + [f"{self.attribute} {group}" for group in self.light_groups]

    def job(self) -> BakeJob:
        return BakeJob.running(lambda progress: run(self, progress))


@dataclass
class Baked:
    """A bake's result, and one per light group (the scene lit by that group's sources alone)."""

    result: BakeResult
    groups: dict[str, BakeResult]


@dataclass
class Outcome:
    summary: str
    notes: list[str]
    written: list[str]


def prepare(scene, view_layer=None, keep: bool | None = None) -> Prepared:
    """Settings of ``scene.radiosity`` and the scene as a render of ``view_layer`` (default: the
    context's) sees it; ValueError for bad input. ``keep``: bake with the session kept for the
    scene (``sessions``; default: in the user interface, not in background mode)."""
    settings = scene.radiosity
    attribute = settings.attribute_name.strip()
    if not attribute:
        raise ValueError("the output attribute name is empty")
    shading_normals = settings.vertex_normals == "SHADING"
    view_layer = view_layer or bpy.context.view_layer
    receivers = None
    if settings.selected_only:
        receivers = {obj.name for obj in view_layer.objects if obj.select_get(view_layer=view_layer)}
        if not receivers:
            raise ValueError("Selected Only is on but no object is selected")
    extraction = read_as_rendered(scene, view_layer, lambda depsgraph: extract(
        depsgraph, settings.two_sided, shading_normals, receivers, settings.instances == "OBJECTS"))
    knobs = settings.core_arguments(extraction.scene.extent) | {"split_direct": settings.separate_direct}
    if settings.method == "hemicube" and (extraction.scene.opacity < 1).any():
        extraction.notes.append("the hemicube takes see-through surfaces (alpha, Transparent BSDF) as opaque: "
                                "ray casting lets light through them")
    if default_backend() != "embree":
        extraction.notes.append("Embree is not available here: rays are traced by the slower NumPy ray caster")
    # fail early, before any work, on targets that cannot be written
    groups = tuple(extraction.light_groups.names()) if settings.light_groups else ()
    if settings.light_groups and not groups:
        extraction.notes.append("Per Light Group is on but no light, emitting object or world is in a light group")
    keep = not bpy.app.background if keep is None else keep
    session = sessions.session_for(scene.name, knobs) if keep else BakeSession(keep=bool(groups), **knobs)
    prepared = Prepared(extraction, scene.name, view_layer.name, knobs, attribute, settings.output == "LIGHTING",
                        settings.modified_topology == "COPY",
                        Storage(settings.color_type, settings.color_domain, settings.exposure, settings.tone),
                        settings.separate_direct, session, groups)
    plan(extraction.targets, prepared.attributes(), prepared.copy_changed)
    return prepared


def run(prepared: Prepared, progress) -> Baked:
    """The bake, then a re-solve per light group, with ``progress(fraction, message)`` over all."""
    groups = prepared.light_groups
    share = 1.0 / (1.0 + RESOLVE_SHARE * len(groups))

    def within(start: float, span: float, prefix: str):
        return lambda fraction, message: progress(start + span * fraction, prefix + message)

    session, extraction = prepared.session, prepared.extraction
    result = session.bake(extraction.scene, within(0.0, share, ""))
    span = (1.0 - share) / max(1, len(groups))
    lit_by = {group: session.bake(extraction.lit_by(group), within(share + index * span, span, f"{group}: "))
              for index, group in enumerate(groups)}
    return Baked(result, lit_by)


def run_straight(prepared: Prepared, echo: bool = True, label: str = "") -> Baked:
    """``run`` in one go, printing progress to stderr at most every second when ``echo``, each
    line ``radiosity: {label}{percent}%  {stage}``."""
    last = [0.0]

    def progress(fraction: float, message: str) -> None:
        if echo and time.perf_counter() - last[0] >= 1.0:
            last[0] = time.perf_counter()
            print(f"radiosity: {label}{100 * fraction:5.1f}%  {message}", file=sys.stderr, flush=True)

    return run(prepared, progress)


def finish(prepared: Prepared, baked: Baked) -> Outcome:
    """Write the result (all meshes or none) and describe the bake."""
    targets, notes = plan(prepared.extraction.targets, prepared.attributes(), prepared.copy_changed)
    result = baked.result
    colours = [_output(prepared, result)]
    if result.corner_direct is not None:
        colours += direct_and_indirect(prepared.extraction.scene, result.corner_lighting, result.corner_direct,
                                       prepared.lighting_only)
    colours += [_output(prepared, baked.groups[group]) for group in prepared.light_groups]
    scene = bpy.data.scenes[prepared.scene_name]
    written = write(targets, dict(zip(prepared.attributes(), colours)), scene,
                    scene.view_layers[prepared.view_layer_name], prepared.storage)
    return Outcome(describe(result.stats, len(written), prepared), prepared.extraction.notes + notes, written)


def _output(prepared: Prepared, result: BakeResult):
    return result.corner_lighting if prepared.lighting_only else result.corner_colors


def describe(stats: dict, objects: int, prepared: Prepared) -> str:
    """One line: what was baked, how finely, how long, how far from converged it may be."""
    estimate = stats["error_estimate"]
    left_text = (f", estimated error {100 * estimate['total']:.2g}% (solver {100 * estimate['unshot']:.2g}%, "
                 f"patches {100 * estimate['discretisation']:.2g}%)")
    output = "lighting" if prepared.lighting_only else "radiosity"
    merged = f" merged into {stats['panels']:,} panels" if stats["panels"] != stats["triangles"] else ""
    stopped = ""
    if not stats["converged"]:
        count, unit = (stats["shots"], "shot") if "shots" in stats else (stats["iterations"], "sweep")
        work = f"{count:,} {unit}{'' if count == 1 else 's'}"
        stopped = f", stopped after {work}"
        if "monte_carlo" in stats:
            stopped = f", {work} then Monte Carlo ({stats['monte_carlo']['gather_rays']:,} rays per vertex)"
    verb = "Re-solved" if stats.get("resolved") else "Baked"
    groups = f" and {len(prepared.light_groups)} light group(s)" if prepared.light_groups else ""
    return (f"{verb} {output} into '{prepared.attribute}'{groups} on {objects} object(s): "
            f"{stats['triangles']:,} triangles"
            f"{merged}, {stats['patches']:,} patches, {stats['nodes']:,} vertex colours, "
            f"{stats['lights']} light object(s), {stats['seconds']['total']:.1f} s{stopped}{left_text}")
