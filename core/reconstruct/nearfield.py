"""Vertex colours corrected for the variation of radiosity across the patches next to them.

A vertex colour gathers B_n = E_n + rho_n sum_q F(n, q) B_q with one radiosity B_q per patch.
From a vertex on a concave edge or a contact line (the ceiling along the top of a wall, a wall
standing on the floor), up to half of the view is the patch just across the edge, seen almost
entirely at the edge itself; the patch's mean is not its value there (the top of a wall grazed by
the light is darker than the wall's patch). That error falls only linearly with the patch size,
and it was most of the error of the first bakes of a Cornell box (docs/notes/experiments.md).

For each patch q near a node n (centroid within NEAR_REACH of its longest edge, box within
NEAR_REACH of the median longest edge, not pressed under n's own surface: PRESSED_ANGLE) the near
field reads the patch's linear interpolant of its corner colours V_i where the node looks, at the
kernel-weighted centroid of the patch seen from the node (barycentric weights lambda_i, from
exact point-to-triangle form factors of a QUADRATURE_DIVISIONS**2 split of the patch, graded
where one piece dominates; at its centroid when F(n, q) is below QUADRATURE_FLOOR):

    G_n' = G_n + sum_{q near n} F(n, q) (sum_i lambda_i(n, q) V_i - B_q),   V = E + rho G'

(point collocation with linear elements for the near field, constant elements for the far field;
Cohen and Wallace 1993, ch. 3). Corner colours are those of the output nodes where the corner is
a vertex of the input triangle, otherwise of interpolation nodes evaluated there (``points``),
which get the same correction from patches whose corners all have nodes. The colours depend on
each other across an edge, so G' is the fixed point of that map: a contraction, since rho < 1
and the near form factors of a node sum to at most 1.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Callable

import numpy as np

from ..mesh.discretize import Discretization
from ..mesh.nodes import inset
from ..mesh.refine import radiosity_scale
from ..scene import Scene
from ..transport.analytic import point_to_triangle
from ..util import parallel, rows, spatial
from ..util.geometry import barycentric_grid, longest_edges
from ..util.progress import heartbeat

# A patch is near a node whose point lies within this many longest edges of its centroid. Every
# point of a triangle lies within 2/3 of its longest edge of its centroid (a corner is 2/3 of a
# median away), so this holds each patch touching the node and a third of an edge more; farther
# patches changed no error measured, at a cost (docs/notes/experiments.md).
NEAR_REACH = 1.0
# Where a node looks on a patch: the patch split into 4 x 4 pieces, and where one piece holds
# more than PEAKED of the form factor, the 2 it sees most of split again (46 pieces per pair): on
# Sponza's near pairs 2.3 % of the triangle from a 30 x 30 split's reading point (F-weighted),
# against 1.2 % for a uniform 16 x 16 split (256 per pair; docs/notes/experiments.md).
QUADRATURE_DIVISIONS = 4
REFINED = 2
PEAKED = 0.25
# Pairs whose form factor is below this are read at the patch's centroid instead: their correction,
# F (lambda V - B_q), moves by at most F times the spread of the patch's corner colours, and they
# are half of Sponza's pairs but 0.7 % of its near form factor (docs/notes/experiments.md).
QUADRATURE_FLOOR = 1e-3
# Pieces farther than this many of their longest edges from the point are weighed by the point rule
# at their centroid, the nearer ones exactly: on Sponza's near pairs the reading points are as far
# from those of a 30 x 30 exact split as with every piece exact (2.3 % of the triangle), in half the
# time (docs/notes/experiments.md).
EXACT_WITHIN = 2.0
PAIRS_PER_BLOCK = 4096  # pairs per block of that quadrature, spread over the threads
RAY_PAIRS_PER_BLOCK = 1 << 14  # pairs per block of ray-cast form factors, spread over the threads
# Corners of different patches closer than this fraction of the scene's extent share a node.
CORNER_WELD = 1e-7
# The fixed point stops when what it leaves, at most change x r / (1 - r) for a map that shrinks
# each change by r (the last step's ratio), is below this share of the brightest node's light: a
# thousandth of the smallest error of a bake (docs/notes/experiments.md).
ITERATION_TOLERANCE = 1e-6
MAX_ITERATIONS = 200
# Patches below this fraction of the area-mean radiosity of the patches that do not emit are left
# to their constant: their correction would be below it too.
DARK = 1e-2
# A patch whose corners are all within this fraction of its size above a point's tangent plane
# (its own surface: the rounding of a coplanar patch) is not seen from it.
HORIZON = 1e-9
# A patch facing a node's surface (normals within PRESSED_ANGLE of opposite) closer than that
# surface's own faces are long (a plate on a table, a cup on its saucer, a shelf over the floor)
# lies in that surface's shadow where the node looks: its linear interpolant, from corners outside
# the shadow, is no reading there, and the pair is left to the patch's constant.
PRESSED_ANGLE = np.radians(25.0)
# Point-patch pairs the gather at the interpolation nodes may cost (tens of seconds of one core):
# in a large scene (tens of thousands of interpolation nodes) they are left out.
GATHER_BUDGET = 50_000_000

FormFactors = Callable[[np.ndarray, np.ndarray, np.ndarray, np.ndarray], np.ndarray]


@dataclass(frozen=True)
class NearField:
    """Near pairs (K of them) of receivers (the N output nodes, then the M interpolation nodes)
    and patches, with what the correction needs.

    receiver, patch : (K,) int.
    form_factor : (K,) F(receiver -> patch), occlusion included.
    weights : (K, 3) barycentric point of the patch the receiver looks at.
    corner_receiver : (K, 3) int, the receiver holding the colour of the patch's surface at each
        of its corners.
    points, normals : (M, 3) where the interpolation nodes are evaluated.
    owner : (M,) int, the patch each interpolation node lies on (its surface's colours).
    """

    receiver: np.ndarray
    patch: np.ndarray
    form_factor: np.ndarray
    weights: np.ndarray
    corner_receiver: np.ndarray
    points: np.ndarray
    normals: np.ndarray
    owner: np.ndarray

    @property
    def pair_count(self) -> int:
        return len(self.receiver)


def lit_patches(mesh: Discretization, radiosity: np.ndarray, share: float = DARK) -> np.ndarray:
    """(P,) bool: the patches whose ``radiosity`` (P, C) is above ``share`` of the scale of the
    scene's (default DARK: a patch in the dark, inside a closed box or behind a wall, needs no
    interpolation)."""
    return radiosity.max(axis=1) > share * radiosity_scale(mesh, radiosity)


def near_field(scene: Scene, mesh: Discretization, radiosity: np.ndarray, form_factors: FormFactors,
               lit: np.ndarray, interpolate: bool = True) -> NearField:
    """The near pairs of ``mesh`` (discretised from ``scene``) with the patches ``lit`` (P,)
    bool (``lit_patches`` of their ``radiosity`` (P, C)); ``form_factors(points, normals,
    receivers, sources)`` gives occluded point-to-patch form factors pairwise. Without
    ``interpolate`` only the patches whose corners all have output nodes are read as linear (no
    interpolation nodes, as beyond GATHER_BUDGET)."""
    node_count = mesh.node_count
    corner_output = _corner_outputs(mesh)
    receivers, patches = _near_pairs(mesh.node_points, mesh.node_normals, _node_sizes(scene, mesh), mesh, lit)
    # interpolation nodes at the corners of those patches that have no output node, unless
    # gathering at them all would cost more than GATHER_BUDGET point-patch pairs (then only
    # patches whose corners are all output nodes are read as linear); there are at least as many
    # as the points those corners are at, which are cheaper to count than the corners' surfaces.
    # Counted on the pairs that may see each other, before their rays: those left out cost none.
    needed = np.unique(patches)
    missing = corner_output[needed] < 0
    shining = radiosity.any(axis=1).sum()
    interpolate = interpolate and (
        _corner_points(scene, mesh, mesh.patch_corners[needed][missing]) * shining <= GATHER_BUDGET)
    # without interpolation nodes no corner's key is read (once the pairs are whole, no corner
    # lacks an output node): one key for all
    corner_key = _corner_keys(scene, mesh) if interpolate else np.zeros_like(corner_output)
    if not interpolate or len(np.unique(corner_key[needed][missing])) * shining > GATHER_BUDGET:
        whole = (corner_output[patches] >= 0).all(axis=1)
        receivers, patches = receivers[whole], patches[whole]
    receivers, patches, factors = _seen(mesh.node_points, mesh.node_normals, receivers, patches, form_factors)
    needed = np.unique(patches)
    missing = corner_output[needed] < 0
    keys, first = np.unique(corner_key[needed][missing], return_index=True)
    slot = np.full(corner_key.max() + 1 if len(corner_key) else 0, -1)
    slot[keys] = node_count + np.arange(len(keys))
    owner_patch = np.repeat(needed, 3).reshape(-1, 3)[missing][first]
    owner_corner = np.tile(np.arange(3), (len(needed), 1))[missing][first]
    corners = mesh.patch_corners[owner_patch, owner_corner]
    points = corners + inset(mesh.patch_centroids[owner_patch] - corners, scene.extent)
    normals = mesh.patch_normals[owner_patch]
    # the interpolation nodes are corrected by the patches whose corners all have a node
    corner_receiver = np.where(corner_output >= 0, corner_output, slot[corner_key])
    extra_receivers, extra_patches = _near_pairs(points, normals, longest_edges(mesh.patch_corners[owner_patch]), mesh,
                                                 lit)
    complete = (corner_receiver[extra_patches] >= 0).all(axis=1)
    extra = _seen(points, normals, extra_receivers[complete], extra_patches[complete], form_factors)
    receivers = np.concatenate([receivers, node_count + extra[0]])
    patches = np.concatenate([patches, extra[1]])
    factors = np.concatenate([factors, extra[2]])
    all_points = np.concatenate([mesh.node_points, points])
    all_normals = np.concatenate([mesh.node_normals, normals])
    return NearField(
        receiver=receivers,
        patch=patches,
        form_factor=factors,
        weights=_reading_points(all_points[receivers], all_normals[receivers], mesh.patch_corners[patches], factors),
        corner_receiver=corner_receiver[patches],
        points=points,
        normals=normals,
        owner=owner_patch,
    )


def joined(first: NearField, second: NearField) -> NearField:
    """The pairs of ``first`` and ``second``, near fields of one mesh without interpolation
    nodes."""
    assert len(first.points) == len(second.points) == 0
    return replace(first, **{name: np.concatenate([getattr(first, name), getattr(second, name)])
                             for name in ("receiver", "patch", "form_factor", "weights", "corner_receiver")})


def with_pairs(near: NearField, keep: np.ndarray) -> NearField:
    """``near`` with only the pairs ``keep`` (K,) bool."""
    if keep.all():
        return near
    return replace(near, receiver=near.receiver[keep], patch=near.patch[keep], form_factor=near.form_factor[keep],
                   weights=near.weights[keep], corner_receiver=near.corner_receiver[keep])


def corrected_lighting(near: NearField, mesh: Discretization, radiosity: np.ndarray, node_lighting: np.ndarray,
                       point_lighting: np.ndarray) -> tuple[np.ndarray, int]:
    """(N + M, C) the lighting G' of the output nodes, then of the interpolation nodes, with the
    near field read from the patches' linear interpolants, and the iterations the fixed point
    took (MAX_ITERATIONS if it stopped short); ``radiosity`` (P, C) of the patches,
    ``node_lighting`` (N, C) and ``point_lighting`` (M, C) the gathered lighting G of the output
    and interpolation nodes."""
    channels = radiosity.shape[1]
    emission, reflectance = _receiver_surfaces(near, mesh, channels)
    gathered = np.concatenate([node_lighting, point_lighting])
    if near.pair_count == 0:
        return gathered, 0
    # G' = G - sum F B_q + W (E + rho G'), with W (N + M, N + M) the weights F lambda_i summed
    # over the pairs that read receiver j at a corner: per channel, G'_c = base_c + (W rho_c) G'_c
    count = len(gathered)
    entries, entry = np.unique(near.receiver[:, None] * count + near.corner_receiver, return_inverse=True)
    weights = np.bincount(entry.reshape(-1), (near.form_factor[:, None] * near.weights).reshape(-1))
    row, column = entries // count, entries % count  # sorted by row
    base, transfer = np.empty((channels, count)), np.empty((channels, len(entries)))  # channels contiguous
    for c in range(channels):
        base[c] = gathered[:, c] + np.bincount(row, weights * emission[column, c], count) \
            - np.bincount(near.receiver, near.form_factor * radiosity[near.patch, c], count)
        transfer[c] = weights * reflectance[column, c]
    rows_with_entries, row_start = np.unique(row, return_index=True)
    lighting, previous = gathered.T, None
    for iteration in range(1, MAX_ITERATIONS + 1):
        heartbeat()
        # Light is never negative: where the gathered G holds less of the near patches than their
        # exact form factors give them (a noisy Monte Carlo gather, whose rays see them otherwise),
        # taking out the constant part can overshoot; the map clamped at zero is still a contraction.
        updated = base.copy()
        for c in range(channels):  # sums over runs of a row: faster than np.bincount
            updated[c, rows_with_entries] += np.add.reduceat(transfer[c] * lighting[c][column], row_start)
        np.maximum(updated, 0.0, out=updated)
        change = np.abs(updated - lighting).max()
        ratio = change / previous if previous else np.inf  # unknown after the first step
        previous, lighting = change, updated
        left = change * ratio / (1 - ratio) if ratio < 1 else np.inf
        if change == 0 or left <= ITERATION_TOLERANCE * np.abs(lighting).max():
            break
    return lighting.T, iteration


def reading_error(near: NearField, mesh: Discretization, radiosity: np.ndarray, lighting: np.ndarray) -> np.ndarray:
    """(N, C) how far each output node's colour may be from reading its near patches exactly:

        e_n = rho_n sum_{q near n} F(n, q) |mean_i V_i(q) - B_q|

    The linear reading is off by the part of the radiosity across the patch that is not linear;
    its size is the gap between the mean of the corner colours (the linear interpolant's value at
    the centroid) and the patch's own radiosity there, which agree wherever radiosity is linear
    across the patch. ``lighting`` (N + M, C) is ``corrected_lighting``'s. Against converged
    references it bounds the error of the whole bake (tests/core/test_error_estimate.py; the
    ratio on each benchmark scene: docs/results/tradeoffs.md)."""
    channels = radiosity.shape[1]
    emission, reflectance = _receiver_surfaces(near, mesh, channels)
    colours = emission + reflectance * lighting
    gap = np.abs(colours[near.corner_receiver].mean(axis=1) - radiosity[near.patch])
    errors = np.stack([np.bincount(near.receiver, near.form_factor * gap[:, c], len(colours)) for c in range(channels)],
                      axis=1)
    return reflectance[: mesh.node_count] * errors[: mesh.node_count]


def _receiver_surfaces(near: NearField, mesh: Discretization, channels: int) -> tuple[np.ndarray, np.ndarray]:
    """Emission and reflectance (N + M, C) of the output nodes, then the interpolation nodes."""
    return (np.concatenate([mesh.node_emission, mesh.patch_emission[near.owner]])[:, :channels],
            np.concatenate([mesh.node_reflectance, mesh.patch_reflectance[near.owner]])[:, :channels])


def _corner_points(scene: Scene, mesh: Discretization, corners: np.ndarray) -> int:
    """How many points the patch ``corners`` (n, 3) of ``mesh`` are at, welded as
    ``_corner_keys`` welds them."""
    return int(rows.labels(_welded(scene, mesh, corners)).max()) + 1 if len(corners) else 0


def _welded(scene: Scene, mesh: Discretization, corners: np.ndarray) -> np.ndarray:
    """(n, 3) the patch ``corners`` (n, 3) of ``mesh`` rounded to steps of CORNER_WELD of the
    scene's extent."""
    step = max(scene.extent, np.finfo(float).tiny) * CORNER_WELD
    return np.round((corners - mesh.patch_corners.min(axis=(0, 1))) / step)


def _corner_keys(scene: Scene, mesh: Discretization) -> np.ndarray:
    """(P, 3) key of the surface point at each patch corner: equal for the corners of patches of
    one flat surface, side and material that meet there, unless a contact line may run between
    them (radiosity jumps across one)."""
    position = _welded(scene, mesh, mesh.patch_corners.reshape(-1, 3))
    patch = np.repeat(np.arange(mesh.patch_count), 3)
    surface = np.concatenate([np.round(mesh.patch_normals * 1e6), mesh.patch_reflectance, mesh.patch_emission,
                              mesh.patch_piece[:, None]], axis=1)[patch]
    return rows.labels(np.concatenate([position, surface], axis=1)).reshape(-1, 3)


def _corner_outputs(mesh: Discretization) -> np.ndarray:
    """(P, 3) the output node at each patch corner, or -1: a front patch's corner at a vertex of
    its own panel has that vertex's node."""
    output = np.full((mesh.patch_count, 3), -1)
    front = mesh.front_patch_count
    triangle = mesh.patch_triangle[:front]
    vertices = mesh.panel_corners[triangle]  # (F, 3, 3)
    tolerance = 1e-6 * longest_edges(mesh.patch_corners[:front])
    distance = np.linalg.norm(mesh.patch_corners[:front, :, None, :] - vertices[:, None, :, :], axis=3)
    at_vertex = distance <= tolerance[:, None, None]  # (F, patch corner, triangle corner)
    found = at_vertex.any(axis=2)
    node = mesh.panel_node[triangle][np.arange(front)[:, None], at_vertex.argmax(axis=2)]
    output[:front] = np.where(found & (node >= 0), node, -1)
    return output


def _node_sizes(scene: Scene, mesh: Discretization) -> np.ndarray:
    """(N,) the longest edge of the input triangles at each node."""
    sizes = np.zeros(mesh.node_count)
    valid = mesh.corner_node >= 0
    edges = np.repeat(longest_edges(scene.vertices[scene.triangles])[:, None], 3, axis=1)
    np.maximum.at(sizes, mesh.corner_node[valid], edges[valid])
    return sizes


def _near_pairs(points: np.ndarray, normals: np.ndarray, sizes: np.ndarray, mesh: Discretization,
                lit: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(receiver, patch) for each ``lit`` patch whose centroid lies within NEAR_REACH of its
    longest edge of the point, and whose bounding box within NEAR_REACH of the median longest
    edge (a patch much larger than the others is near only the points close to it), which may be
    seen from the point (in front of it, over its horizon) and which is not pressed against the
    point's surface, whose faces are ``sizes`` (n,) long (PRESSED_ANGLE)."""
    lit_patches = np.flatnonzero(lit)
    edges = longest_edges(mesh.patch_corners)
    corners, centroids = mesh.patch_corners[lit_patches], mesh.patch_centroids[lit_patches]
    pad = NEAR_REACH * np.minimum(edges[lit_patches], np.median(edges))[:, None]
    reach = NEAR_REACH * edges[lit_patches]
    # the boxes within reach of each patch: its box grown by the pad, and its centroid's sphere's,
    # cut to what lies in front of it (twice the margin of the test below, against rounding)
    low, high = spatial.in_front(np.maximum(corners.min(axis=1) - pad, centroids - reach[:, None]),
                                 np.minimum(corners.max(axis=1) + pad, centroids + reach[:, None]),
                                 centroids, mesh.patch_normals[lit_patches], 2 * HORIZON * edges[lit_patches])
    nonempty = (low <= high).all(axis=1)
    candidates, low, high = lit_patches[nonempty], low[nonempty], high[nonempty]

    point_axes = [np.ascontiguousarray(points[:, axis]) for axis in range(3)]
    centroid_axes = [np.ascontiguousarray(mesh.patch_centroids[candidates, axis]) for axis in range(3)]
    normal_axes = [np.ascontiguousarray(mesh.patch_normals[candidates, axis]) for axis in range(3)]
    candidate_edges, reach2 = edges[candidates], reach[nonempty] ** 2

    def may_see(receivers: np.ndarray, chosen: np.ndarray) -> np.ndarray:
        # close enough, with the point not on or behind the patch's plane (its own surface, most of
        # them); then the patch neither pressed against the point's surface nor wholly under the
        # point's tangent plane: F = 0 without casting a ray
        offset = [point_axis[receivers] - centroid_axis[chosen]
                  for point_axis, centroid_axis in zip(point_axes, centroid_axes)]
        edge = candidate_edges[chosen]
        height = sum(axis * normal_axis[chosen] for axis, normal_axis in zip(offset, normal_axes))
        result = (sum(axis ** 2 for axis in offset) < reach2[chosen]) & (height > -HORIZON * edge)
        close = np.flatnonzero(result)
        receivers, patches, edge, height = receivers[close], candidates[chosen[close]], edge[close], height[close]
        offset = np.stack([axis[close] for axis in offset], axis=1)
        normal, patch_normal = normals[receivers], mesh.patch_normals[patches]
        cosine = np.einsum("kx,kx->k", normal, patch_normal)
        pressed = (cosine < -np.cos(PRESSED_ANGLE)) & (height < sizes[receivers])
        # the patch's corners rise at most edge x sin(angle between the normals) above its centroid
        # over the point's plane: most candidates (the point's own surface) fail without them. The
        # sine from 1 - cos^2 is off by up to 1.5e-8 where the normals are almost parallel (and the
        # corners lie off the patch's plane by rounding, below HORIZON x edge): 2e-8 more covers both.
        sine = np.sqrt(np.maximum(1.0 - cosine ** 2, 0.0)) + 2e-8
        highest = sine * edge - np.einsum("kx,kx->k", offset, normal)
        maybe = np.flatnonzero((highest > 0.0) & ~pressed)
        corners_above = np.einsum("kcx,kx->kc", mesh.patch_corners[patches[maybe]] - points[receivers[maybe]][:, None],
                                  normal[maybe])
        result[close] = False
        result[close[maybe]] = corners_above.max(axis=1) > HORIZON * edge[maybe]
        return result

    receivers, chosen = spatial.points_in_boxes(points, low, high, may_see)
    return receivers, candidates[chosen]


def _seen(points: np.ndarray, normals: np.ndarray, receivers: np.ndarray, patches: np.ndarray,
          form_factors: FormFactors) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(receiver, patch, F) of the pairs ``receivers``, ``patches`` (k,) whose point sees the
    patch: F > 0 by ``form_factors``."""
    parts = parallel.map_ordered(
        lambda start: form_factors(points, normals, receivers[start:start + RAY_PAIRS_PER_BLOCK],
                                   patches[start:start + RAY_PAIRS_PER_BLOCK]),
        range(0, len(receivers), RAY_PAIRS_PER_BLOCK))
    factors = np.concatenate([np.zeros(0), *parts])
    seen = factors > 0
    return receivers[seen], patches[seen], factors[seen]


def _reading_points(points: np.ndarray, normals: np.ndarray, triangles: np.ndarray,
                    form_factors: np.ndarray) -> np.ndarray:
    """(K, 3) barycentric point where each point reads its near triangle: where it looks
    (``_where_seen``), or the centroid for pairs whose form factor is below QUADRATURE_FLOOR."""
    weights = np.full((len(points), 3), 1 / 3)
    seen = np.flatnonzero(form_factors >= QUADRATURE_FLOOR)
    weights[seen] = _where_seen(points[seen], normals[seen], triangles[seen])
    return weights


def _where_seen(points: np.ndarray, normals: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """(K, 3) barycentric centroid of each triangle weighted by the unoccluded form factor from
    the point: sum over pieces s of F(point -> s) times the centroid of s, over F. The pieces
    are a QUADRATURE_DIVISIONS**2 split; where one piece holds more than PEAKED of the form
    factor (the point close to the triangle), the REFINED largest are split the same way again:
    graded towards where the point looks."""
    grid, cells = barycentric_grid(QUADRATURE_DIVISIONS)
    split = grid[cells]  # (S, 3 corners, 3 barycentric)
    centroids = split.mean(axis=1)

    def block(start: int) -> np.ndarray:
        chunk = slice(start, min(start + PAIRS_PER_BLOCK, len(points)))
        point, normal, triangle = points[chunk], normals[chunk], triangles[chunk]
        count = len(point)
        factors = _piece_form_factors(point, normal, triangle, split[None], 1 / QUADRATURE_DIVISIONS)
        moment, total = factors @ centroids, factors.sum(axis=1)
        peaked = np.flatnonzero(factors.max(axis=1) > PEAKED * total)
        if len(peaked):
            largest = np.argsort(-factors[peaked], axis=1)[:, :REFINED]  # (k, R)
            chosen = split[largest]  # (k, R, 3, 3)
            finer = (split @ chosen[:, :, None]).reshape(len(peaked), -1, 3, 3)  # (k, R, S, 3, 3)
            finer_factors = _piece_form_factors(point[peaked], normal[peaked], triangle[peaked], finer,
                                                QUADRATURE_DIVISIONS ** -2)
            replaced = np.take_along_axis(factors[peaked], largest, axis=1)  # (k, R)
            moment[peaked] += np.einsum("km,kmb->kb", finer_factors, finer.mean(axis=2)) \
                - np.einsum("kr,krb->kb", replaced, centroids[largest])
            total[peaked] += finer_factors.sum(axis=1) - replaced.sum(axis=1)
        return np.divide(moment, total[:, None], out=np.full((count, 3), 1 / 3), where=total[:, None] > 0)

    parts = list(parallel.map_ordered(block, range(0, len(points), PAIRS_PER_BLOCK)))
    return np.concatenate(parts) if parts else np.zeros((0, 3))


def _piece_form_factors(points, normals, triangles, pieces, scale: float) -> np.ndarray:
    """(k, m) unoccluded form factors from each point (k, 3) facing ``normals`` to the m pieces
    (barycentric (k or 1, m, 3, 3), congruent, ``scale`` times the size of the triangle) of its
    triangle (k, 3, 3): exact (``point_to_triangle``) for pieces within EXACT_WITHIN of their
    longest edge of the point, the point rule at their centroid for the others,
    A cos+ cos+ / (pi r^2)."""
    offset = pieces.mean(axis=2) @ triangles - points[:, None]  # (k, m, 3) from the point to each centroid
    distance2 = np.einsum("kmx,kmx->km", offset, offset)
    reach = EXACT_WITHIN * scale * longest_edges(triangles)
    double_area = np.cross(triangles[:, 1] - triangles[:, 0], triangles[:, 2] - triangles[:, 0]) * scale ** 2
    leaving = np.maximum(np.einsum("kmx,kx->km", offset, normals), 0.0)
    arriving = np.maximum(-np.einsum("kmx,kx->km", offset, double_area), 0.0)  # towards the front
    factors = leaving * arriving / (2 * np.pi * np.maximum(distance2, np.finfo(float).tiny) ** 2)
    pair, piece = np.nonzero(distance2 < reach[:, None] ** 2)
    corners = pieces[pair if len(pieces) > 1 else 0, piece] @ triangles[pair]
    factors[pair, piece] = point_to_triangle(points[pair], normals[pair], corners)
    return factors
