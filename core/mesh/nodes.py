"""Receiver nodes: the points where output colours are evaluated, one per distinct (vertex,
material, shading normal). The corners of the input triangles around a vertex are merged across
edges whose faces share a material and a shading normal (or meet below the crease angle), so
colour may jump at creases and material borders."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..scene import Scene
from ..util.geometry import areas_and_normals, triangle_corners
from .topology import WELD_TOLERANCE, connected_components, degenerate, weld_corners

# A node is evaluated this fraction of the scene's extent from its vertex towards the centre of its
# faces, inside its own surface, as Cycles bakes a corner 1e-4 x max(1, |coordinates|) inside the
# corner's face (../shared/CYCLES.md), but scaled with the scene: at the vertex itself a surface
# touching it is seen exactly edge-on, and a ray leaving it starts on every face that meets there.
# A step that shrinks with the faces instead (a fixed share of the way to their centre) puts the
# nodes of small mouldings a hair from the surfaces they touch, and reads them too dark
# (docs/notes/experiments.md).
NODE_INSET = 4e-5
# Corner normals (``Scene.corner_normals``) closer than this (about the angle between them, in
# radians) are one shading normal: a flat-shaded face's normal shifts a corner's light by a part in
# a hundred at most, while a wall twisted by a few 1e-4 radians would otherwise get a node per face
# at every vertex.
SAME_NORMAL = 1e-2


@dataclass(frozen=True)
class CornerGroups:
    """The corners of a scene's triangles grouped into receiver nodes (``grouped_corners``): all a
    node is but the point where it is evaluated (``receiver_nodes``), which waits for the panels."""

    scene: Scene
    corners: np.ndarray  # (T, 3, 3) the triangles' corners
    normals: np.ndarray  # (T, 3) their unit normals
    valid_corners: np.ndarray  # (V,) flat indices of the corners of the triangles with an area
    corner_group: np.ndarray  # (V,) the node of each
    weight: np.ndarray  # (V,) the area of its triangle
    nodes: dict[str, np.ndarray]  # node_normals, node_reflectance, node_emission, corner_node, node_vertex

    @property
    def count(self) -> int:
        return len(self.nodes["node_normals"])

    def mean(self, values: np.ndarray) -> np.ndarray:
        """(N, k) each node's mean of ``values`` (V, k) over its corners, weighted by their areas."""
        return _node_means(self.corner_group, self.weight, self.count, values)


def grouped_corners(scene: Scene, crease_angle: float) -> CornerGroups:
    """The corners of ``scene``'s triangles grouped into nodes (``crease_angle`` in radians), with
    each node's normal, vertex and surface."""
    corners = triangle_corners(scene.vertices, scene.triangles)
    areas, normals = areas_and_normals(corners)
    zero_area = degenerate(corners)
    triangle_count = len(corners)
    weld = weld_corners(corners, scene.extent)  # (T, 3) welded vertex id per corner
    labels = _smoothing_groups(weld, scene.material, normals, zero_area, crease_angle, scene.corner_normals)
    valid_corners = np.flatnonzero(np.repeat(~zero_area, 3))
    group_ids, corner_group = np.unique(labels.ravel()[valid_corners], return_inverse=True)
    group_count = len(group_ids)
    node_vertex = np.zeros(group_count, dtype=np.int64)
    node_vertex[corner_group] = weld.ravel()[valid_corners]
    corner_node = np.full(triangle_count * 3, -1, dtype=np.int64)
    corner_node[valid_corners] = corner_group
    _borrow_neighbour_nodes(corner_node, weld.ravel(), scene.material[np.arange(triangle_count * 3) // 3])
    triangle_of = valid_corners // 3
    weight = areas[triangle_of]
    if scene.corner_normals is None:
        shading = normals[triangle_of]
    else:
        shading = scene.corner_normals.reshape(-1, 3)[valid_corners]
    node_normals = _node_means(corner_group, weight, group_count, shading)
    node_normals /= np.linalg.norm(node_normals, axis=1, keepdims=True)
    # as node_surfaces reads them, from the grouping at hand: a triangle's corners' nodes are theirs
    reflectance, emission = (_node_means(corner_group, weight, group_count, values[triangle_of])
                             for values in (scene.reflectance, scene.emission))
    return CornerGroups(scene, corners, normals, valid_corners, corner_group, weight, {
        "node_normals": node_normals, "node_reflectance": reflectance, "node_emission": emission,
        "corner_node": corner_node.reshape(triangle_count, 3), "node_vertex": node_vertex})


def _node_means(corner_group: np.ndarray, weight: np.ndarray, count: int, values: np.ndarray) -> np.ndarray:
    """(count, k) each node's mean of ``values`` (V, k) over its corners ``corner_group`` (V,),
    weighted by ``weight`` (V,)."""
    totals = np.bincount(corner_group, weights=weight, minlength=count)
    return np.stack([np.bincount(corner_group, weights=weight * column, minlength=count) for column in values.T],
                    axis=1) / totals[:, None]


def receiver_nodes(groups: CornerGroups, corner_points: np.ndarray | None = None) -> dict[str, np.ndarray]:
    """The nodes of ``groups`` (``grouped_corners``), evaluated at ``corner_points`` (T, 3, 3)
    (default: the corners themselves) moved into their faces (``inset``), on or in front of each."""
    corners, normals, corner_group = groups.corners, groups.normals, groups.corner_group
    extent = groups.scene.extent
    node_normals = groups.nodes["node_normals"]
    triangle_of = groups.valid_corners // 3
    positions = np.zeros((groups.count, 3))
    evaluated = (corners if corner_points is None else corner_points).reshape(-1, 3)[groups.valid_corners]
    positions[corner_group] = evaluated
    towards_faces = groups.mean(corners.mean(axis=1)[triangle_of]) - positions
    towards_faces -= (towards_faces * node_normals).sum(axis=1, keepdims=True) * node_normals
    points = positions + inset(towards_faces, extent)
    # in the tangent plane of a smooth normal the step can leave a concave corner's faces behind
    # (a room's corner shaded smooth: the node would see the room through its walls), so the node
    # is lifted along its normal until it is on or in front of each of its faces
    height = np.einsum("cx,cx->c", normals[triangle_of], points[corner_group] - evaluated)
    facing = np.einsum("cx,cx->c", normals[triangle_of], node_normals[corner_group])
    behind = np.flatnonzero((height < -WELD_TOLERANCE * extent) & (facing > 0))
    lift = np.zeros(groups.count)
    np.maximum.at(lift, corner_group[behind], -height[behind] / facing[behind])
    points += lift[:, None] * node_normals
    return {"node_points": points, **groups.nodes}


def node_surfaces(scene: Scene, corner_node: np.ndarray, node_count: int) -> tuple[np.ndarray, np.ndarray]:
    """(N, 3) reflectance and (N, 3) emission of each node: the means of its corners' triangles',
    weighted by their areas (``corner_node`` (T, 3); zero-area triangles have no weight)."""
    corners = triangle_corners(scene.vertices, scene.triangles)
    areas = areas_and_normals(corners)[0]
    valid_corners = np.flatnonzero(np.repeat(~degenerate(corners), 3))
    group, triangle_of = corner_node.ravel()[valid_corners], valid_corners // 3
    weight = areas[triangle_of]
    return (_node_means(group, weight, node_count, scene.reflectance[triangle_of]),
            _node_means(group, weight, node_count, scene.emission[triangle_of]))


def inset(towards_faces: np.ndarray, extent: float) -> np.ndarray:
    """(N, 3) the step from each vertex to where its node is evaluated: NODE_INSET x extent
    along ``towards_faces`` (N, 3) (towards the centre of the node's faces, in its tangent
    plane), at most half the way there (zero where the faces surround the vertex)."""
    length = np.linalg.norm(towards_faces, axis=1, keepdims=True)
    step = np.minimum(NODE_INSET * extent, 0.5 * length)
    return np.divide(towards_faces * step, length, out=np.zeros_like(towards_faces), where=length > 0)


def _smoothing_groups(weld, material, normals, zero_area, crease_angle, corner_normals=None) -> np.ndarray:
    """(T, 3) label per corner: corners joined across smooth, same-material shared edges: faces
    meeting below ``crease_angle``, or with ``corner_normals`` (T, 3, 3) corners whose normals
    agree within SAME_NORMAL."""
    triangle_count = len(weld)
    start = weld
    end = weld[:, [1, 2, 0]]
    edge_keys = np.stack([np.minimum(start, end), np.maximum(start, end)], axis=2).reshape(-1, 2)
    corner_a = np.arange(triangle_count * 3)  # edge k of triangle t runs from corner k to corner k+1
    corner_b = (corner_a // 3) * 3 + (corner_a % 3 + 1) % 3
    keep = np.repeat(~zero_area, 3) & (edge_keys[:, 0] != edge_keys[:, 1])
    edge_ids = np.flatnonzero(keep)
    order = edge_ids[np.lexsort((edge_keys[edge_ids, 1], edge_keys[edge_ids, 0]))]
    first, second = order[:-1], order[1:]
    same_edge = (edge_keys[first] == edge_keys[second]).all(axis=1)
    first, second = first[same_edge], second[same_edge]
    tri_a, tri_b = first // 3, second // 3
    cosine = (normals[tri_a] * normals[tri_b]).sum(axis=1)
    # faces folded back over each other (more than 90 degrees) never share a node: their mean
    # normal would be meaningless (the two sides of a two-sided card cancel exactly)
    smooth = (material[tri_a] == material[tri_b]) & (cosine > -1e-9)
    if corner_normals is None:
        smooth &= cosine >= np.cos(crease_angle) - 1e-12
    first, second = first[smooth], second[smooth]
    # corner of triangle b at each endpoint of the shared edge: match by welded vertex
    pairs = []
    for corner_first in (corner_a[first], corner_b[first]):
        vertex = weld.ravel()[corner_first]
        base = (second // 3) * 3
        match = np.full(len(second), -1)
        for k in range(3):
            match = np.where(weld.ravel()[base + k] == vertex, base + k, match)
        pairs.append(np.stack([corner_first, match], axis=1))
    pairs = np.concatenate(pairs) if pairs else np.zeros((0, 2), dtype=np.int64)
    pairs = pairs[pairs[:, 1] >= 0]
    if corner_normals is not None:
        flat = corner_normals.reshape(-1, 3)
        pairs = pairs[np.linalg.norm(flat[pairs[:, 0]] - flat[pairs[:, 1]], axis=1) <= SAME_NORMAL]
    return connected_components(triangle_count * 3, pairs).reshape(-1, 3)


def _borrow_neighbour_nodes(corner_node: np.ndarray, weld: np.ndarray, material: np.ndarray) -> None:
    """Give each corner of a zero-area triangle the node of another corner at the same vertex,
    preferring one of the same material (in place)."""
    missing = np.flatnonzero(corner_node < 0)
    if len(missing) == 0:
        return
    known = np.flatnonzero(corner_node >= 0)
    for prefer_material in (True, False):
        keys_known = weld[known] * (material.max() + 1) + material[known] if prefer_material else weld[known]
        keys_missing = weld[missing] * (material.max() + 1) + material[missing] if prefer_material else weld[missing]
        order = np.argsort(keys_known, kind="stable")
        position = np.searchsorted(keys_known[order], keys_missing)
        position = np.minimum(position, len(order) - 1)
        found = keys_known[order][position] == keys_missing
        corner_node[missing[found]] = corner_node[known[order][position[found]]]
        missing = missing[~found]
