"""The near-field stage: the nodes' lighting corrected for how radiosity varies across the patches
next to them (``nearfield``), with the detail of the direct light where a shadow starts at a
contact (``touching``)."""

from __future__ import annotations

import numpy as np

from ..scene import Scene
from ..transport.arriving import ArrivingLight
from ..util.progress import Report
from . import nearfield, touching


def near_field_correction(scene: Scene, light: ArrivingLight, radiosity: np.ndarray, node_lighting: np.ndarray,
                          report: Report) -> tuple[np.ndarray, np.ndarray | None, dict]:
    """The light G (N, C) at ``light``'s nodes, ``node_lighting`` read from the patches'
    ``radiosity`` (P, C) as constants, corrected near each node; each node's bound on the error
    of that reading (N, C; ``nearfield.reading_error``), or None where no pair needed it; and
    what the stage did."""
    mesh, channels = light.mesh, light.channels
    near = nearfield.near_field(scene, mesh, radiosity, light.engine.point_form_factors)
    point_lighting = light.total(near.points, near.normals, radiosity, report)
    near, direct_detail, detailed_pairs = touching.read_touching(near, mesh, light.sharp, channels)
    node_lighting = node_lighting + direct_detail[: mesh.node_count]
    point_lighting = point_lighting + direct_detail[mesh.node_count:]
    lighting, iterations = nearfield.corrected_lighting(near, mesh, radiosity, node_lighting, point_lighting)
    errors = nearfield.reading_error(near, mesh, radiosity, lighting) if near.pair_count else None
    stats = {"pairs": near.pair_count, "interpolation_nodes": len(near.points), "iterations": iterations,
             "direct_detail_pairs": detailed_pairs}
    return lighting[: mesh.node_count], errors, stats
