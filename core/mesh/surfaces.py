"""New colours on a discretisation made before: the patches and nodes of a re-solve after only
the surfaces' reflectance or emission changed (``bake.BakeSession``)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from ..scene import Scene
from .discretize import Discretization
from .nodes import node_surfaces
from .panels import Panels


def regions_split(panels: Panels | None, scene: Scene) -> bool:
    """Whether ``scene``'s colours differ within a panel of ``panels`` (made from a scene of the
    same geometry): a panel merged triangles of one reflectance and emission, so it must be cut
    again (None: every panel is an input triangle, nothing to split)."""
    if panels is None:
        return False
    source = panels.panel_source[panels.corner_panel]  # (T, 3) the triangle each corner's panel is from
    surfaces = np.hstack([scene.reflectance, scene.emission])
    return bool((surfaces[source] != surfaces[:, None]).any())


def resurfaced(mesh: Discretization, panels: Panels | None, scene: Scene) -> Discretization:
    """``mesh`` with the reflectance and emission of ``scene`` (same geometry and regions: see
    ``regions_split``) on its patches (through the panel each comes from) and nodes."""
    triangle = mesh.patch_triangle if panels is None else panels.panel_source[mesh.patch_triangle]
    node_reflectance, node_emission = node_surfaces(scene, mesh.corner_node, mesh.node_count)
    return replace(mesh, patch_reflectance=scene.reflectance[triangle], patch_emission=scene.emission[triangle],
                   node_reflectance=node_reflectance, node_emission=node_emission)
