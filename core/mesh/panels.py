"""Panels: flat regions of a fine mesh merged into triangles about the patch size.

A wall modelled as a 40 x 40 grid has 3,200 triangles where radiosity needs a few dozen patches:
each input triangle would otherwise be at least one patch, and the solve's cost grows with the
patches times the receivers. Here the triangles of each flat region (one reflectance, emission,
material and sidedness, neighbours across shared edges parallel within PARALLEL) are
simplified by half-edge collapses (Hoppe 1996, "Progressive meshes"), restricted so that the region
does not change: a vertex is removed only from inside its region or from a straight stretch of its
outline, and only onto a neighbour, so every remaining vertex is an input vertex and the region's
outline stays exactly where it was (no gap opens towards the next region). A collapse is taken when
the triangles it changes keep their orientation, a shape no thinner than MIN_SHAPE, edges no longer
than the panel size, and the removed vertex within FLATNESS of their planes; the shortest edges go
first, in passes of collapses whose neighbourhoods do not overlap.

The panels are then cut along contact lines and split into patches like input triangles
(``discretize``); the vertex colours are still evaluated at every input vertex, placed on its
panel (``Panels.corner_panel``, ``corner_weights``), so a fine mesh keeps its detail in the
colours while its patches follow the patch size.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from ..scene import Scene
from ..util import spatial
from ..util.geometry import areas_and_normals, barycentric, longest_edges, triangle_corners
from ..util.overlaps import PARALLEL
from ..util.rows import sorted_labels
from .topology import connected_components, degenerate, weld_corners

# A collapse keeps the vertex it removes within this fraction of each changed triangle's longest
# edge of its plane.
FLATNESS = 1e-2
# An outline vertex is removed only where its neighbours' line passes within this fraction of the
# scene's extent of it (float32 rounding), and within FLATNESS of their distance, so no outline
# moves and no gap opens between regions.
STRAIGHT = 1e-6
# A collapse may not leave a triangle whose area is below this fraction of its longest edge
# squared (equilateral 0.43, half a square 0.25).
MIN_SHAPE = 0.12
# Emitting regions merge up to the panel size over this.
EMITTER_DIVISIONS = 4
# Collapse lengths within this ratio of each other are taken in a scrambled order.
LENGTH_STEP = 0.1


@dataclass(frozen=True)
class Panels:
    """A scene's flat regions remeshed into panels, and where each input corner lies on them.

    scene : the panel triangles, with the surfaces of the input triangles they come from.
    panel_source : (Q,) int, an input triangle each panel comes from (same surface and plane).
    panel_corner_source : (Q, 3) int, an input corner (triangle * 3 + corner) at each panel
        corner, in the panel's region: every panel vertex is an input vertex.
    corner_panel : (T, 3) int, the panel around each corner of each input triangle.
    corner_weights : (T, 3, 3) barycentric weights of each input corner in that panel's corners.
    triangle_panel : (T,) int, the panel that is the input triangle itself (nothing merged into
        it), or -1.
    """

    scene: Scene
    panel_source: np.ndarray
    panel_corner_source: np.ndarray
    corner_panel: np.ndarray
    corner_weights: np.ndarray
    triangle_panel: np.ndarray

    def to_corners(self, panel_values: np.ndarray) -> np.ndarray:
        """(T, 3, C) values at the input corners from (Q, 3, C) values at the panels' corners."""
        return np.einsum("tkc,tkcx->tkx", self.corner_weights, panel_values[self.corner_panel])


def panels(scene: Scene, panel_size: float,
           report: Callable[[float], None] = lambda _fraction: None) -> Panels | None:
    """``scene`` with its flat regions simplified into panels no longer than ``panel_size``, or
    None when no triangle can be merged (every panel would be an input triangle); ``report``
    hears the fraction of the vertices settled after each pass of collapses."""
    corners = triangle_corners(scene.vertices, scene.triangles)
    normals = areas_and_normals(corners)[1]
    zero_area = degenerate(corners)
    if zero_area.all():
        return None
    weld = weld_corners(corners, scene.extent)
    region = _regions(scene, normals, weld, zero_area)
    # vertices are per region: regions decimate independently
    vertex_key, local = sorted_labels(np.stack([np.repeat(region, 3), weld.ravel()], axis=1))
    local = local.reshape(-1, 3)
    positions = np.zeros((len(vertex_key), 3))
    positions[local.ravel()] = corners.reshape(-1, 3)
    alive = local[~zero_area].copy()
    owner = np.flatnonzero(~zero_area)  # input triangle each alive triangle came from
    # the vertices of degenerate triangles stay, in every region: those triangles stay as they are
    fixed = np.isin(vertex_key[:, 1], weld[zero_area].ravel())
    flat = STRAIGHT * scene.extent
    # an emitter's patches are where its light is sampled from: larger ones blur the shadows it
    # casts, so emitters merge only up to a finer size
    limit = np.where(scene.emission.any(axis=1), panel_size / EMITTER_DIVISIONS, panel_size)
    removed_any = False
    # a vertex with no valid collapse rests until a collapse changes the triangles around it
    resting = np.zeros(len(positions), dtype=bool)
    settled = 0.0
    while True:
        # a collapse changes only its source's triangles: those of the vertices awake
        awake = np.flatnonzero((~(fixed | resting))[alive].any(axis=1))
        source, target, hopeless = _collapses(alive[awake], positions, normals[owner[awake]], fixed | resting,
                                              limit[owner[awake]], flat)
        resting[hopeless] = True
        settled = max(settled, float((resting | fixed).mean()))  # resting vertices may wake again
        report(settled)
        if len(source) == 0:
            break
        removed_any = True
        changed = np.isin(alive, source).any(axis=1)
        resting[alive[changed].ravel()] = False
        mapping = np.arange(len(positions))
        mapping[source] = target
        alive = mapping[alive]
        keep = (alive[:, 0] != alive[:, 1]) & (alive[:, 1] != alive[:, 2]) & (alive[:, 2] != alive[:, 0])
        alive, owner = alive[keep], owner[keep]
        fixed[source] = True  # removed: never a vertex again
    if not removed_any:
        return None
    # the degenerate triangles stay as they are, so their corners still find their neighbours
    panel_vertices = np.concatenate([alive, local[zero_area]])
    panel_source = np.concatenate([owner, np.flatnonzero(zero_area)])
    unchanged = (alive == local[owner]).all(axis=1)
    corner_panel, corner_weights = _locate(local, positions, panel_vertices, region, panel_source,
                                           np.flatnonzero(~unchanged))
    triangle_panel = np.full(len(corners), -1)
    triangle_panel[owner[unchanged]] = np.flatnonzero(unchanged)
    triangle_panel[zero_area] = len(alive) + np.arange(zero_area.sum())
    input_corner = np.empty(len(positions), dtype=np.int64)
    input_corner[local.ravel()] = np.arange(local.size)
    used, compact = np.unique(panel_vertices, return_inverse=True)
    panel_scene = Scene(positions[used], compact.reshape(-1, 3), scene.reflectance[panel_source],
                        scene.emission[panel_source], material=scene.material[panel_source],
                        two_sided=scene.two_sided[panel_source], lights=scene.lights, sky=scene.sky,
                        environment=scene.environment,
                        casts_shadows=scene.casts_shadows[panel_source], opacity=scene.opacity[panel_source])
    return Panels(panel_scene, panel_source, input_corner[panel_vertices], corner_panel, corner_weights,
                  triangle_panel)


def _regions(scene: Scene, normals, weld, zero_area) -> np.ndarray:
    """(T,) region label: triangles of one surface (reflectance, emission, material, sidedness,
    shadows, opacity)
    joined across shared edges where they are parallel within PARALLEL; a degenerate
    triangle is a region of its own."""
    count = len(normals)
    surface = np.concatenate([scene.reflectance, scene.emission, scene.material[:, None],
                              scene.two_sided[:, None], scene.casts_shadows[:, None], scene.opacity[:, None]],
                             axis=1)
    surface_id = sorted_labels(surface)[1]
    surface_id[zero_area] = surface_id.max() + 1 + np.arange(zero_area.sum())
    triangle = np.tile(np.arange(count), 3)
    ends = np.concatenate([weld[:, [0, 1]], weld[:, [1, 2]], weld[:, [2, 0]]])
    keys = np.concatenate([np.sort(ends, axis=1), surface_id[triangle][:, None]], axis=1)
    order = np.lexsort(keys.T[::-1])
    same = (keys[order][1:] == keys[order][:-1]).all(axis=1)
    a, b = triangle[order][:-1][same], triangle[order][1:][same]
    flat = np.einsum("kx,kx->k", normals[a], normals[b]) >= 1 - PARALLEL
    return connected_components(count, np.stack([a[flat], b[flat]], axis=1))


def _collapses(triangles: np.ndarray, positions: np.ndarray, normals: np.ndarray, fixed: np.ndarray,
               limit: np.ndarray, flat: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """One pass: (sources, targets) of half-edge collapses whose stars do not overlap, and the
    vertices of ``triangles`` (not ``fixed``) that have no valid collapse; no changed triangle may
    have an edge longer than its ``limit`` (per triangle), nor lie further than FLATNESS of its
    size from the vertex it loses; an outline vertex goes only where its outline is straight
    within ``flat``. ``triangles`` need only hold every triangle of the vertices not ``fixed``."""
    empty = np.zeros(0, dtype=np.int64)
    vertex_count = len(positions)
    count = len(triangles)
    star_size = np.bincount(triangles.ravel(), minlength=vertex_count)
    free = np.flatnonzero(~fixed & (star_size > 0))
    interior, on_outline, boundary = _vertex_kinds(triangles, positions, fixed, flat)
    # candidate half-edges u -> v: from an interior vertex to any neighbour, from a straight
    # outline vertex to its outline neighbours
    start = triangles.ravel()
    end = triangles[:, [1, 2, 0]].ravel()
    source = np.concatenate([start, end])
    target = np.concatenate([end, start])
    along_outline = np.concatenate([boundary, boundary])
    keep = interior[source] | (on_outline[source] & along_outline)
    source, target = source[keep], target[keep]
    pair_key = np.unique(source * vertex_count + target)
    source, target = pair_key // vertex_count, pair_key % vertex_count
    if len(source) == 0:
        return empty, empty, free
    # the star of each candidate's source: its triangles, through a vertex -> triangle listing
    corner_triangle = np.repeat(np.arange(count), 3)
    order = np.argsort(triangles.ravel(), kind="stable")
    star_start = np.concatenate([[0], np.cumsum(star_size)])
    sizes = star_size[source]
    candidate = np.repeat(np.arange(len(source)), sizes)
    star = corner_triangle[order][star_start[source][candidate] + spatial.ranks(sizes)]
    moved = triangles[star]
    gone = (moved == target[candidate][:, None]).any(axis=1)
    moved = np.where(moved == source[candidate][:, None], target[candidate][:, None], moved)
    points = positions[moved]
    vectors = np.cross(points[:, 1] - points[:, 0], points[:, 2] - points[:, 0])
    area = np.einsum("kx,kx->k", vectors, normals[star]) / 2
    lost = positions[source[candidate]] - points[:, 0]
    longest = longest_edges(points)
    off_plane = np.abs(np.einsum("kx,kx->k", vectors, lost)) <= FLATNESS * longest * 2 * np.abs(area)
    good = gone | ((area >= MIN_SHAPE * longest ** 2) & (longest <= limit[star]) & off_plane)
    # every changed triangle good, and one left at least (a region never collapses away)
    valid = (np.bincount(candidate, weights=~good, minlength=len(source)) == 0) \
        & (np.bincount(candidate, weights=~gone, minlength=len(source)) > 0)
    hopeless = np.setdiff1d(free, source[valid])
    if not valid.any():
        return empty, empty, hopeless
    # shortest valid edge per source, then those whose stars no better candidate touches; equal
    # lengths (within LENGTH_STEP) in a scrambled order, so that a regular grid yields many
    # winners per pass (Luby's independent sets), not a few along the index order
    length = np.linalg.norm(positions[target] - positions[source], axis=1)
    bucket = np.floor(np.log(np.maximum(length, np.finfo(float).tiny)) / np.log1p(LENGTH_STEP))
    scramble = (source * 2654435761 + target * 40503) % 1000003
    rank = np.empty(len(source), dtype=np.int64)
    rank[np.lexsort((np.arange(len(source)), scramble, bucket))] = np.arange(len(source))
    rank = np.where(valid, rank, np.iinfo(np.int64).max)
    best = np.full(vertex_count, np.iinfo(np.int64).max)
    np.minimum.at(best, source, rank)
    chosen = valid & (rank == best[source])
    claim = np.full(count, np.iinfo(np.int64).max)
    in_chosen = chosen[candidate]
    np.minimum.at(claim, star[in_chosen], rank[candidate][in_chosen])
    # a collapse also touches the triangles around its target's edge to the source: already in
    # the star; and no two winners may share a triangle
    lowest = np.full(len(source), np.iinfo(np.int64).max)
    np.minimum.at(lowest, candidate, claim[star])
    winners = chosen & (lowest == rank)
    return source[winners], target[winners], hopeless


def _vertex_kinds(triangles: np.ndarray, positions: np.ndarray, fixed: np.ndarray, flat: float):
    """(V,) bool interior vertices, (V,) bool straight outline vertices (within ``flat`` of the
    line through their outline neighbours; neither ``fixed``), and (3 T,) bool whether each edge
    (t, k) -> (t, k + 1) is on the outline (used once)."""
    vertex_count = len(positions)
    start = triangles.ravel()
    end = triangles[:, [1, 2, 0]].ravel()
    edge_keys = np.minimum(start, end) * vertex_count + np.maximum(start, end)
    _, edge_index, uses = np.unique(edge_keys, return_inverse=True, return_counts=True)
    boundary = uses[edge_index] == 1
    nonmanifold = np.zeros(vertex_count, dtype=bool)
    nonmanifold[start[uses[edge_index] > 2]] = True
    nonmanifold[end[uses[edge_index] > 2]] = True
    boundary_degree = np.bincount(start[boundary], minlength=vertex_count) \
        + np.bincount(end[boundary], minlength=vertex_count)
    # a boundary vertex's two outline neighbours: the ends of its two boundary edges
    outline_next = np.full(vertex_count, -1)
    outline_previous = np.full(vertex_count, -1)
    outline_next[start[boundary]] = end[boundary]
    outline_previous[end[boundary]] = start[boundary]
    star_size = np.bincount(start, minlength=vertex_count)
    interior = (boundary_degree == 0) & ~nonmanifold & ~fixed & (star_size >= 3)
    on_outline = (boundary_degree == 2) & ~nonmanifold & ~fixed & (outline_next >= 0) & (outline_previous >= 0)
    chosen = np.flatnonzero(on_outline)
    a, b = positions[outline_previous[chosen]], positions[outline_next[chosen]]
    middle = positions[chosen]
    span = b - a
    off_line = np.linalg.norm(np.cross(middle - a, span), axis=1)
    between = (((middle - a) * span).sum(axis=1) > 0) & (((b - middle) * span).sum(axis=1) > 0)
    length = np.linalg.norm(span, axis=1)
    on_outline[chosen] = between & (off_line <= np.minimum(flat, FLATNESS * length) * length)
    return interior, on_outline, boundary


def _locate(local, positions, panel_vertices, region, panel_source, changed):
    """The panel around each input corner and its barycentric weights there: a corner at a panel
    vertex takes that vertex; one at a removed vertex, the panel of its region containing it, one
    of the panels ``changed`` (indices: those that are not an input triangle), as every triangle
    around a removed vertex was."""
    flat = local.ravel()
    # each vertex (of a region): any panel with it as a corner, weight 1 there
    vertex_panel = np.full(len(positions), -1)
    vertex_weights = np.zeros((len(positions), 3))
    for k in range(3):
        vertex_panel[panel_vertices[:, k]] = np.arange(len(panel_vertices))
        vertex_weights[panel_vertices[:, k]] = np.eye(3)[k]
    removed = np.unique(flat[vertex_panel[flat] < 0])
    if len(removed):
        points = positions[removed]
        vertex_region = np.zeros(len(positions), dtype=np.int64)
        vertex_region[flat] = np.repeat(region, 3)
        panel_corners = positions[panel_vertices[changed]]
        pad = FLATNESS * longest_edges(panel_corners)[:, None]  # removed vertices lie within it of a panel
        found_point, found = spatial.points_in_boxes(points, panel_corners.min(axis=1) - pad,
                                                     panel_corners.max(axis=1) + pad)
        found_panel = changed[found]
        same = region[panel_source[found_panel]] == vertex_region[removed][found_point]
        found_point, found, found_panel = found_point[same], found[same], found_panel[same]
        weights = barycentric(points[found_point], panel_corners[found])
        order = np.lexsort((-weights.min(axis=1), found_point))  # per point, the panel it is most inside
        best = order[np.unique(found_point[order], return_index=True)[1]]
        if len(best) != len(removed):
            raise AssertionError("a removed vertex lies in no panel of its region")
        inside = np.clip(weights[best], 0.0, 1.0)
        vertex_panel[removed[found_point[best]]] = found_panel[best]
        vertex_weights[removed[found_point[best]]] = inside / inside.sum(axis=1, keepdims=True)
    return vertex_panel[local], vertex_weights[local]
