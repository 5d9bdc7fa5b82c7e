"""The near-field stage: the nodes' lighting corrected for how radiosity varies across the patches
next to them (``nearfield``), with the detail of the direct light where a shadow starts at a
contact (``touching``)."""

from __future__ import annotations

import numpy as np

from ..mesh.refine import radiosity_scale
from ..scene import Scene
from ..transport.arriving import ArrivingLight
from ..util.progress import Report
from . import nearfield, touching


def near_field_correction(scene: Scene, light: ArrivingLight, radiosity: np.ndarray, node_lighting: np.ndarray,
                          kept: dict, row_budget: int, report: Report) -> tuple[np.ndarray, np.ndarray | None, dict]:
    """The light G (N, C) at ``light``'s nodes, ``node_lighting`` read from the patches'
    ``radiosity`` (P, C) as constants, corrected near each node; each node's bound on the error
    of that reading (N, C; ``nearfield.reading_error``), or None where no pair needed it; and
    what the stage did.

    ``kept``: a dict in which the near pairs with their touching pairs (``touching.Touching``:
    geometry, found again, those of the patches lit now, while no patch outside them is clearly lit),
    the form factors from the interpolation nodes to the patches that shine (while they take at
    most ``row_budget`` bytes) and their direct light per source are kept for a re-solve on the
    same patches (``bake.BakeSession``)."""
    mesh, channels = light.mesh, light.channels
    lit = nearfield.lit_patches(mesh, radiosity)
    # a re-solve keeps the pairs found before; a patch left out then that is now clearly lit
    # (above twice DARK: one about DARK, whose correction would be about that, is left to its
    # constant as DARK ones are) gets its pairs, alone where there are no interpolation nodes
    # (the large scenes, where Monte Carlo's noise lights a few more patches at every bake)
    newly = None if "lit" not in kept else nearfield.lit_patches(mesh, radiosity, 2 * nearfield.DARK) & ~kept["lit"]
    if newly is not None and newly.any() and len(kept["touching"].near.points) == 0:
        added = nearfield.near_field(scene, mesh, radiosity, light.engine.point_form_factors, newly, interpolate=False)
        kept["touching"] = touching.joined(kept["touching"], touching.touching_pairs(added, mesh))
        kept["lit"] = kept["lit"] | newly
    elif newly is None or newly.any():
        kept.clear()
        near = nearfield.near_field(scene, mesh, radiosity, light.engine.point_form_factors, lit)
        kept["touching"], kept["lit"] = touching.touching_pairs(near, mesh), lit
    pairs = kept["touching"].restricted(lit[kept["touching"].near.patch])  # the pairs of the patches lit now
    point_lighting = _point_lighting(light, pairs.near, radiosity, kept, row_budget, report)
    near, direct_detail, detailed_pairs = touching.read_touching(pairs, mesh, light.sharp, channels)
    node_lighting = node_lighting + direct_detail[: mesh.node_count]
    point_lighting = point_lighting + direct_detail[mesh.node_count:]
    lighting, iterations = nearfield.corrected_lighting(near, mesh, radiosity, node_lighting, point_lighting)
    errors = nearfield.reading_error(near, mesh, radiosity, lighting) if near.pair_count else None
    stats = {"pairs": near.pair_count, "interpolation_nodes": len(near.points), "iterations": iterations,
             "direct_detail_pairs": detailed_pairs}
    return lighting[: mesh.node_count], errors, stats


def _point_lighting(light: ArrivingLight, near: nearfield.NearField, radiosity: np.ndarray, kept: dict,
                    row_budget: int, report: Report) -> np.ndarray:
    """(M, C) all the light G at the interpolation nodes: gathered from the patches of
    ``radiosity`` and from the lights and the sky; by the rows and factors in ``kept`` when they
    cover every patch that shines, else measured (and kept there if within ``row_budget``)."""
    engine, points, normals = light.engine, near.points, near.normals
    shining = radiosity.any(axis=1)
    if "rows" in kept and not (shining & ~kept["row_sources"]).any():
        sources = np.flatnonzero(kept["row_sources"])
        return engine.gather_with(kept["rows"], sources, radiosity) + light.combined(kept["point_factors"])
    sources = np.flatnonzero(shining)
    if 8 * len(points) * (len(sources) + 3 * light.direct.source_count) > row_budget:
        return light.total(points, normals, radiosity, report)
    kept["rows"] = engine.gather_rows(points, normals, sources, lambda f: report(f / 2))
    kept["row_sources"] = shining
    kept["point_factors"] = light.direct.factors_at(points, normals, lambda f: report(0.5 + f / 2))
    return engine.gather_with(kept["rows"], sources, radiosity) + light.combined(kept["point_factors"])
