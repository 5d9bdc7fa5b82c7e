"""Per-corner output: the colour B = E + rho G and the lighting G at each corner of each input
triangle from its receiver node (Gouraud-ready), and each triangle's mean radiosity."""

from __future__ import annotations

import numpy as np

from ..mesh.discretize import Discretization
from ..scene import Scene


def per_corner(scene: Scene, mesh: Discretization, radiosity: np.ndarray, node_lighting: np.ndarray,
               triangle_panel: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Corner colours (T, 3, 3) and lighting (T, 3, 3) from the nodes' lighting (N, C), each
    corner's colour with its own triangle's reflectance and emission (a textured surface's vary
    from face to face around a node), and
    triangle means (T, 3) from the front patches of each triangle's panel (``triangle_panel``:
    the panel that is the triangle, -1 where it was merged into a larger one, whose mean is then
    its corners'); RGB float64. A corner without a node (a zero-area triangle with no neighbour)
    shows its triangle's emission and no lighting."""
    count = len(scene.triangles)
    rgb = np.broadcast_to(radiosity, (len(radiosity), 3)) if radiosity.shape[1] == 1 else radiosity
    lighting = np.broadcast_to(node_lighting, (len(node_lighting), 3))
    corner_lighting = at_corners(mesh, lighting)
    corner_colors = scene.emission[:, None, :] + scene.reflectance[:, None, :] * corner_lighting
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


def at_corners(mesh: Discretization, node_values: np.ndarray) -> np.ndarray:
    """(T, 3, C) each corner's node value from ``node_values`` (N, C); 0 where a corner has no node."""
    corner_node = mesh.corner_node
    return np.where((corner_node >= 0)[..., None], node_values[np.maximum(corner_node, 0)], 0.0)


def direct_and_indirect(scene: Scene, corner_lighting: np.ndarray, corner_direct: np.ndarray,
                        lighting_only: bool) -> tuple[np.ndarray, np.ndarray]:
    """The corner colours (T, 3, 3) of the direct light and of the rest, which add up to the bake's:
    G_d and G - G_d with ``lighting_only``, else E + rho G_d and rho (G - G_d) (an emitter's own
    light counts as direct); ``corner_direct`` G_d is ``BakeResult.corner_direct``."""
    indirect = corner_lighting - corner_direct
    if lighting_only:
        return corner_direct, indirect
    reflectance = scene.reflectance[:, None, :]
    return scene.emission[:, None, :] + reflectance * corner_direct, reflectance * indirect
