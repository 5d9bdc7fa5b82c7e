"""Discretisation: input triangles -> patches (shooters and receivers of the linear system) and
receiver nodes (the points where output colours are evaluated).

Patches are the input triangles, first cut along the lines where other surfaces meet them
(``contacts``), split regularly into congruent sub-triangles no longer than the patch size; the
back of a two-sided triangle is a second set of patches facing the other way.
Receiver nodes are one per distinct (vertex, material, smooth normal): the corners of the input
triangles around a vertex are merged across edges whose faces share a material and meet at less
than the crease angle, so colour may jump at creases and material borders.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Callable

import numpy as np

from . import contacts
from .geometry import ENCLOSING_TOLERANCE, areas_and_normals, enclosing, longest_edges, subdivide, triangle_corners
from .raycast import light_divisions
from .scene import Scene

if TYPE_CHECKING:
    from .simplify import Panels

# A triangle whose area is below this fraction of its longest edge squared is treated as having
# zero area (its normal is rounding noise). An aspect ratio of 1e4 is 1e-4, far above this.
DEGENERATE_AREA_RATIO = 1e-14
# Vertices closer than this fraction of the scene's extent are one vertex for node merging.
WELD_TOLERANCE = 1e-9
# A node is evaluated this fraction of the scene's extent from its vertex towards the centre of its
# faces, inside its own surface, as Cycles bakes a corner 1e-4 x max(1, |coordinates|) inside the
# corner's face (../shared/CYCLES.md), but scaled with the scene: at the vertex itself a surface
# touching it is seen exactly edge-on, and a ray leaving it starts on every face that meets there.
# On Sponza (extent 38 m: 1.5 mm, Cycles' 1.5 mm at 15 m from the origin) a bake is 15.5 % from
# Cycles' answer against 19.3 % at 1e-3 of the way to the faces' centre (0.02 mm on its 3 cm
# mouldings); on the sample Cornell box it changes nothing (0.586 % against 0.585 %).
NODE_INSET = 4e-5
# Corner normals (``Scene.corner_normals``) closer than this (about the angle between them, in
# radians) are one shading normal: a flat-shaded face's normal shifts a corner's light by a part in
# a hundred at most, while the sample Cornell box's twisted walls (flat faces bent by 3e-4) would get
# a node per face at every vertex (539 -> 714 nodes; the 40 x 40 box 10,915 -> 15,753).
SAME_NORMAL = 1e-2
MAX_PATCHES = 4_000_000
# An emitter (a connected set of emitting triangles) is split finer than the patch size until it
# has raycast.MIN_LIGHT_PIECES patches, unless the emitters so split would then be more than this
# share of the patches (many small lights, or a scene that is mostly light): the split is bounded
# by the scene, not by its number of lights.
MAX_EMITTER_SHARE = 0.25


@dataclass(frozen=True)
class Discretization:
    """Patches (P of them) and receiver nodes (N) of a scene; all arrays float64 unless noted.

    patch_corners : (P, 3, 3) corner positions, front-facing by the right-hand rule.
    patch_areas, patch_normals, patch_centroids : (P,), (P, 3), (P, 3).
    patch_reflectance, patch_emission : (P, C) with C = 3 channels.
    patch_triangle : (P,) int, the panel each patch comes from: the input triangle, or with
        ``simplify.Panels`` the merged triangle of a flat region.
    patch_piece : (P,) int, the piece of its input triangle a patch lies in when other surfaces
        cut the triangle (``contacts``; pieces on either side of a contact line differ), else -1.
    front_patch_count : patches [0, F) are front sides, [F, P) the backs of two-sided triangles
        (unless ``discretize`` leaves out the hidden ones).
    back_of_front : (F,) int, index of the back patch of each front patch, or -1.
    node_points, node_normals : (N, 3) where and facing which way each node is evaluated.
    node_reflectance, node_emission : (N, C).
    corner_node : (T, 3) int, node of each corner of each input triangle, -1 where a zero-area
        triangle has no neighbour to take colour from.
    panel_corners : (Q, 3, 3) the corners of the panels patches come from.
    panel_node : (Q, 3) int, the node at each panel corner (``corner_node`` when the panels are
        the input triangles; a panel's corners are input vertices).
    """

    patch_corners: np.ndarray
    patch_areas: np.ndarray
    patch_normals: np.ndarray
    patch_centroids: np.ndarray
    patch_reflectance: np.ndarray
    patch_emission: np.ndarray
    patch_triangle: np.ndarray
    patch_piece: np.ndarray
    front_patch_count: int
    back_of_front: np.ndarray
    node_points: np.ndarray
    node_normals: np.ndarray
    node_reflectance: np.ndarray
    node_emission: np.ndarray
    corner_node: np.ndarray
    panel_corners: np.ndarray
    panel_node: np.ndarray

    @property
    def patch_count(self) -> int:
        return len(self.patch_areas)

    @property
    def node_count(self) -> int:
        return len(self.node_points)


def discretize(scene: Scene, patch_size: float | None = None, crease_angle: float = np.radians(30),
               report: Callable[[float], None] = lambda _fraction: None, cut_contacts: bool = True,
               panels: Panels | None = None, hidden_backs: bool = True) -> Discretization:
    """Split ``scene`` (or its ``panels``, ``simplify``) into patches no longer than
    ``patch_size`` (None: one patch per triangle), after cutting its triangles along contact
    lines (unless not ``cut_contacts``), and group the corners of ``scene``'s triangles into
    receiver nodes (``crease_angle`` in radians); ``report`` hears the fraction done between
    steps. Without ``hidden_backs``, a two-sided triangle with the whole scene in front of it
    (``geometry.enclosing``: a room's wall) gets no back patch: no point of a surface sees its
    back, and light it sent back would reach no surface (a bake's receivers all lie on them)."""
    source = scene if panels is None else panels.scene
    patches = _patches(source, patch_size, cut_contacts, hidden_backs)
    report(0.4)
    # with panels, each node is evaluated on its panel (a vertex of a near-flat region may lie
    # off it by up to simplify.FLATNESS of its size), so its own surface's patches never hide it
    on_panels = None if panels is None else panels.to_corners(triangle_corners(source.vertices, source.triangles))
    nodes = _receiver_nodes(scene, crease_angle, on_panels)
    if panels is None:
        panel_node = nodes["corner_node"]
    else:
        panel_node = nodes["corner_node"].ravel()[panels.panel_corner_source]
    report(1.0)
    return Discretization(**patches, **nodes, panel_corners=triangle_corners(source.vertices, source.triangles),
                          panel_node=panel_node)


def _patches(scene: Scene, patch_size: float | None, cut_contacts: bool, hidden_backs: bool) -> dict:
    corners = triangle_corners(scene.vertices, scene.triangles)
    areas, normals = areas_and_normals(corners)
    degenerate = areas <= DEGENERATE_AREA_RATIO * longest_edges(corners) ** 2
    if degenerate.all():
        raise ValueError("every triangle of the scene has zero area: there is nothing to light")
    if cut_contacts:
        pieces, piece_triangle = contacts.pieces(corners, degenerate)
    else:
        pieces, piece_triangle = corners, np.arange(len(corners))
    piece_degenerate = degenerate[piece_triangle] | (
        areas_and_normals(pieces)[0] <= DEGENERATE_AREA_RATIO * longest_edges(pieces) ** 2)
    divisions = _divisions(pieces, piece_degenerate, patch_size)
    if patch_size is not None:
        divisions *= _emitter_divisions(scene, corners, degenerate, piece_triangle, divisions)
    _check_patch_count(divisions, patch_size)
    front = _split_triangles(pieces, divisions)
    patch_triangle = piece_triangle[front["triangle"]]
    cut = np.bincount(piece_triangle, minlength=len(corners))[piece_triangle] > 1
    patch_piece = np.where(cut, np.arange(len(pieces)), -1)[front["triangle"]]
    sides = [front["corners"]]
    back_of_front = np.full(len(patch_triangle), -1, dtype=np.int64)
    two_sided = scene.two_sided
    if not hidden_backs:
        two_sided = two_sided & ~enclosing(corners, ENCLOSING_TOLERANCE * scene.extent)
    back = np.flatnonzero(two_sided[patch_triangle])
    if len(back):
        back_of_front[back] = len(patch_triangle) + np.arange(len(back))
        sides.append(front["corners"][back][:, ::-1])
        patch_triangle = np.concatenate([patch_triangle, patch_triangle[back]])
        patch_piece = np.concatenate([patch_piece, patch_piece[back]])
    patch_corners = np.concatenate(sides)
    patch_areas, patch_normals = areas_and_normals(patch_corners)
    return dict(
        patch_corners=patch_corners,
        patch_areas=patch_areas,
        patch_normals=patch_normals,
        patch_centroids=patch_corners.mean(axis=1),
        patch_reflectance=scene.reflectance[patch_triangle],
        patch_emission=scene.emission[patch_triangle],
        patch_triangle=patch_triangle,
        patch_piece=patch_piece,
        front_patch_count=len(back_of_front),
        back_of_front=back_of_front,
    )


def _divisions(corners: np.ndarray, degenerate: np.ndarray, patch_size: float | None) -> np.ndarray:
    """(T,) int: edge divisions per triangle, 0 for zero-area triangles (they make no patch)."""
    if patch_size is None:
        divisions = np.ones(len(corners), dtype=np.int64)
    else:
        if not np.isfinite(patch_size) or patch_size <= 0:
            raise ValueError(f"patch_size must be a positive length, got {patch_size}")
        divisions = np.maximum(1, np.ceil(longest_edges(corners) / patch_size)).astype(np.int64)
    divisions[degenerate] = 0
    return divisions


def _check_patch_count(divisions: np.ndarray, patch_size: float | None) -> None:
    total = int((divisions.astype(np.float64) ** 2).sum())
    if total > MAX_PATCHES:
        raise ValueError(
            f"patch_size {patch_size:g} would make {total:,} patches (at most {MAX_PATCHES:,}); "
            "choose a larger patch size"
        )


def _emitter_divisions(scene: Scene, corners: np.ndarray, degenerate: np.ndarray, piece_triangle: np.ndarray,
                       divisions: np.ndarray) -> np.ndarray:
    """(pieces,) int: how many times more to divide each piece's edges: for the pieces of an
    emitter that ``divisions`` make n patches, raycast.light_divisions(n); 1 elsewhere, and 1
    everywhere if the emitters so split would then be more than MAX_EMITTER_SHARE of the
    patches. An emitter is a connected set of emitting triangles (sharing a vertex)."""
    factor = np.ones(len(piece_triangle), dtype=np.int64)
    emitting = np.flatnonzero(scene.emission.any(axis=1) & ~degenerate)
    if len(emitting) == 0:
        return factor
    weld = weld_corners(corners[emitting], scene.extent)
    count = len(emitting)
    # triangles and vertices as one graph: a triangle joined to its corners' vertices
    links = np.stack([np.repeat(np.arange(count), 3), count + weld.ravel()], axis=1)
    emitter = np.full(len(corners), -1)
    emitter[emitting] = connected_components(count + weld.max() + 1, links)[:count]
    piece_emitter = emitter[piece_triangle]
    chosen = np.flatnonzero(piece_emitter >= 0)
    emitter_patches = np.bincount(piece_emitter[chosen], weights=divisions[chosen] ** 2.0, minlength=count)
    factor[chosen] = light_divisions(emitter_patches)[piece_emitter[chosen]]
    patches = divisions.astype(np.float64) ** 2 * factor**2
    if patches[factor > 1].sum() > MAX_EMITTER_SHARE * patches.sum():
        factor[:] = 1
    return factor


def _split_triangles(corners: np.ndarray, divisions: np.ndarray) -> dict[str, np.ndarray]:
    """Regular split of each triangle into divisions**2 sub-triangles (grouped by count)."""
    parts, parents = [], []
    for n in np.unique(divisions[divisions > 0]):
        chosen = np.flatnonzero(divisions == n)
        parts.append(subdivide(corners[chosen], int(n)))
        parents.append(np.repeat(chosen, n * n))
    order = np.argsort(np.concatenate(parents), kind="stable")
    return {"corners": np.concatenate(parts)[order], "triangle": np.concatenate(parents)[order]}


def _receiver_nodes(scene: Scene, crease_angle: float,
                    corner_points: np.ndarray | None = None) -> dict[str, np.ndarray]:
    """Nodes of the corners of ``scene``'s triangles, evaluated at ``corner_points`` (T, 3, 3)
    (default: the corners themselves) moved into their faces (``inset``), on or in front of each."""
    corners = triangle_corners(scene.vertices, scene.triangles)
    areas, normals = areas_and_normals(corners)
    degenerate = areas <= DEGENERATE_AREA_RATIO * longest_edges(corners) ** 2
    triangle_count = len(corners)
    weld = weld_corners(corners, scene.extent)  # (T, 3) welded vertex id per corner
    labels = _smoothing_groups(weld, scene.material, normals, degenerate, crease_angle, scene.corner_normals)
    valid = ~degenerate
    valid_corners = np.flatnonzero(np.repeat(valid, 3))
    group_ids, corner_group = np.unique(labels.ravel()[valid_corners], return_inverse=True)
    group_count = len(group_ids)
    triangle_of = valid_corners // 3
    weight = areas[triangle_of]
    totals = np.bincount(corner_group, weights=weight, minlength=group_count)

    def mean(values: np.ndarray) -> np.ndarray:
        return np.stack(
            [np.bincount(corner_group, weights=weight * column, minlength=group_count) for column in values.T],
            axis=1,
        ) / totals[:, None]

    if scene.corner_normals is None:
        node_normals = mean(normals[triangle_of])
    else:
        node_normals = mean(scene.corner_normals.reshape(-1, 3)[valid_corners])
    node_normals /= np.linalg.norm(node_normals, axis=1, keepdims=True)
    positions = np.zeros((group_count, 3))
    evaluated = (corners if corner_points is None else corner_points).reshape(-1, 3)[valid_corners]
    positions[corner_group] = evaluated
    towards_faces = mean(corners.mean(axis=1)[triangle_of]) - positions
    towards_faces -= (towards_faces * node_normals).sum(axis=1, keepdims=True) * node_normals
    points = positions + inset(towards_faces, scene.extent)
    # in the tangent plane of a smooth normal the step can leave a concave corner's faces behind
    # (a room's corner shaded smooth: the node would see the room through its walls), so the node
    # is lifted along its normal until it is on or in front of each of its faces
    height = np.einsum("cx,cx->c", normals[triangle_of], points[corner_group] - evaluated)
    facing = np.einsum("cx,cx->c", normals[triangle_of], node_normals[corner_group])
    behind = np.flatnonzero((height < -WELD_TOLERANCE * scene.extent) & (facing > 0))
    lift = np.zeros(group_count)
    np.maximum.at(lift, corner_group[behind], -height[behind] / facing[behind])
    points += lift[:, None] * node_normals
    corner_node = np.full(triangle_count * 3, -1, dtype=np.int64)
    corner_node[valid_corners] = corner_group
    _borrow_neighbour_nodes(corner_node, weld.ravel(), scene.material[np.arange(triangle_count * 3) // 3])
    return {
        "node_points": points,
        "node_normals": node_normals,
        "node_reflectance": mean(scene.reflectance[triangle_of]),
        "node_emission": mean(scene.emission[triangle_of]),
        "corner_node": corner_node.reshape(triangle_count, 3),
    }


def inset(towards_faces: np.ndarray, extent: float) -> np.ndarray:
    """(N, 3) the step from each vertex to where its node is evaluated: NODE_INSET x extent
    along ``towards_faces`` (N, 3) (towards the centre of the node's faces, in its tangent
    plane), at most half the way there (zero where the faces surround the vertex)."""
    length = np.linalg.norm(towards_faces, axis=1, keepdims=True)
    step = np.minimum(NODE_INSET * extent, 0.5 * length)
    return np.divide(towards_faces * step, length, out=np.zeros_like(towards_faces), where=length > 0)


def weld_corners(corners: np.ndarray, extent: float) -> np.ndarray:
    """(T, 3) id per corner; corners at the same position (within WELD_TOLERANCE of the scene's
    ``extent``) share an id."""
    points = corners.reshape(-1, 3)
    step = max(extent, np.finfo(float).tiny) * WELD_TOLERANCE
    keys = np.round((points - points.min(axis=0)) / step).astype(np.int64)
    return np.unique(keys, axis=0, return_inverse=True)[1].reshape(-1, 3)


def _smoothing_groups(weld, material, normals, degenerate, crease_angle, corner_normals=None) -> np.ndarray:
    """(T, 3) label per corner: corners joined across smooth, same-material shared edges: faces
    meeting below ``crease_angle``, or with ``corner_normals`` (T, 3, 3) corners whose normals
    agree within SAME_NORMAL."""
    triangle_count = len(weld)
    start = weld
    end = weld[:, [1, 2, 0]]
    edge_keys = np.stack([np.minimum(start, end), np.maximum(start, end)], axis=2).reshape(-1, 2)
    corner_a = np.arange(triangle_count * 3)  # edge k of triangle t runs from corner k to corner k+1
    corner_b = (corner_a // 3) * 3 + (corner_a % 3 + 1) % 3
    keep = np.repeat(~degenerate, 3) & (edge_keys[:, 0] != edge_keys[:, 1])
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


def connected_components(count: int, pairs: np.ndarray) -> np.ndarray:
    """Label (count,) per item: the smallest item index of its component (min-label propagation
    with pointer jumping)."""
    labels = np.arange(count)
    if len(pairs) == 0:
        return labels
    a, b = pairs.T
    while True:
        low = np.minimum(labels[a], labels[b])
        previous = labels.copy()
        np.minimum.at(labels, a, low)
        np.minimum.at(labels, b, low)
        labels = labels[labels]
        if np.array_equal(labels, previous):
            return labels


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
