"""Patches: input triangles (or panels, ``panels``) -> the shooters and receivers of the linear
system, and the receiver nodes where colours are read (``nodes``), in one ``Discretization``.

Patches are the input triangles, first cut along the lines where other surfaces meet them
(``contacts``), split regularly into congruent sub-triangles no longer than the patch size; the
back of a two-sided triangle is a second set of patches facing the other way. An emitter is split
finer, so that its light is sampled from at least MIN_LIGHT_PIECES pieces; one that reflects
nothing, coarser, to about BLACK_LIGHT_PIECES.
"""

from __future__ import annotations

from concurrent.futures import Future
from dataclasses import dataclass
from typing import Callable

import numpy as np

from ..scene import Scene
from ..util import parallel
from ..util.geometry import (ENCLOSING_TOLERANCE, areas_and_normals, enclosing, longest_edges, subdivide,
                             triangle_corners)
from . import contacts, panels as panelling
from .nodes import grouped_corners, receiver_nodes
from .panels import Panels
from .topology import connected_components, degenerate, weld_corners

MAX_PATCHES = 4_000_000
# A light (an emitting surface, an area light) is sampled from at least this many pieces, each with
# the rays of a form factor, its triangles divided up to MAX_LIGHT_DIVISIONS times per edge: a small
# light is most of a scene's light, and the penumbrae it casts need the finer sampling (a square
# light's penumbra against the exact one: tests/core/test_light_sampling.py).
MIN_LIGHT_PIECES = 16
MAX_LIGHT_DIVISIONS = 4
# An emitter (a connected set of emitting triangles) is split finer than the patch size until it
# has MIN_LIGHT_PIECES patches, unless the emitters so split would then be more than this
# share of the patches (many small lights, or a scene that is mostly light): the split is bounded
# by the scene, not by its number of lights. One that reflects nothing and that the patch size
# splits into more than MIN_LIGHT_PIECES is split coarser, to about BLACK_LIGHT_PIECES (at least):
# its radiosity is its emission everywhere, so its patches only sample its light, and the shots
# from each cost rays at every receiver. Sponza's sky quad: 50 patches of 4 rays -> 18, the shots
# 6.0 -> 3.0 s, the same error (docs/notes/experiments.md, "Sponza's time by stage"); 18 -> 8 at the
# nodes' two sets, the rays 108 -> 89.5 million, the error 2.46 -> 2.38 % (seeds 0 to 3), 2 pieces
# 2.61 / 3.40 % ("Sponza's sky quad in fewer pieces").
MAX_EMITTER_SHARE = 0.25
BLACK_LIGHT_PIECES = 8
# Triangles (or panels) whose longest edge is below this share of the patch size are not cut along
# contact lines, but cut the larger ones (``contacts.pieces``).
SMALLEST_CUT = 0.0625


def light_divisions(pieces: np.ndarray) -> np.ndarray:
    """Divisions per edge for the triangles of lights made of ``pieces`` triangles each (int
    array): ceil(sqrt(MIN_LIGHT_PIECES / pieces)), from 1 to MAX_LIGHT_DIVISIONS."""
    wanted = np.ceil(np.sqrt(MIN_LIGHT_PIECES / np.maximum(np.asarray(pieces, dtype=np.float64), 1)))
    return np.clip(wanted, 1, MAX_LIGHT_DIVISIONS).astype(np.int64)


@dataclass(frozen=True)
class Discretization:
    """Patches (P of them) and receiver nodes (N) of a scene; all arrays float64 unless noted.

    patch_corners : (P, 3, 3) corner positions, front-facing by the right-hand rule.
    patch_areas, patch_normals, patch_centroids : (P,), (P, 3), (P, 3).
    patch_reflectance, patch_emission : (P, C) with C = 3 channels.
    patch_triangle : (P,) int, the panel each patch comes from: the input triangle, or with
        ``panels.Panels`` the merged triangle of a flat region.
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
    patch_casts : (P,) bool, which patches cast shadows (``Scene.casts_shadows``), or None: all.
    patch_opacity : (P,) float, the share of the light each patch stops (``Scene.opacity``; 1 for
        those that cast no shadow), or None: all of it.
    node_vertex : (N,) int, the welded vertex each node belongs to (``topology.weld_corners``: the
        nodes of one vertex, split by creases, materials or shading normals, share it), or None.
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
    patch_casts: np.ndarray | None = None
    patch_opacity: np.ndarray | None = None
    node_vertex: np.ndarray | None = None

    @property
    def patch_count(self) -> int:
        return len(self.patch_areas)

    @property
    def front_casts(self) -> np.ndarray | None:
        """(F,) which front patches cast shadows, or None: all (the ray layer's occluders)."""
        return None if self.patch_casts is None else self.patch_casts[: self.front_patch_count]

    @property
    def front_opacity(self) -> np.ndarray | None:
        """(F,) the share of the light each front patch stops, or None: all (the ray layer's)."""
        return None if self.patch_opacity is None else self.patch_opacity[: self.front_patch_count]

    @property
    def node_count(self) -> int:
        return len(self.node_points)

    def patch_radiosity(self, lighting: np.ndarray) -> np.ndarray:
        """(P, C) B = E + rho G of the patches for the light G (P, C) arriving at them."""
        channels = lighting.shape[1]
        return self.patch_emission[:, :channels] + self.patch_reflectance[:, :channels] * lighting

    def node_radiosity(self, lighting: np.ndarray) -> np.ndarray:
        """(N, C) B = E + rho G at the nodes for the light G (N, C) arriving at them."""
        channels = lighting.shape[1]
        return self.node_emission[:, :channels] + self.node_reflectance[:, :channels] * lighting


def discretize(scene: Scene, patch_size: float | None = None, crease_angle: float = np.radians(30),
               report: Callable[[float], None] = lambda _fraction: None, cut_contacts: bool = True,
               panels: Panels | None = None, hidden_backs: bool = True,
               groups: Future | None = None) -> Discretization:
    """Split ``scene`` (or its ``panels``, ``panels.panels``) into patches no longer than
    ``patch_size`` (None: one patch per triangle), after cutting its triangles along contact
    lines (unless not ``cut_contacts``), and group the corners of ``scene``'s triangles into
    receiver nodes (``crease_angle`` in radians); ``report`` hears the fraction done between
    steps. Without ``hidden_backs``, a two-sided triangle with the whole scene in front of it
    (``geometry.enclosing``: a room's wall) gets no back patch: no point of a surface sees its
    back, and light it sent back would reach no surface (a bake's receivers all lie on them).
    ``groups``: the grouping of ``scene``'s corners into nodes (``nodes.grouped_corners``) under
    way on the pool, if it was started (waited for once the patches are made, so that their
    errors come first)."""
    source = scene if panels is None else panels.scene
    patches = _patches(source, patch_size, cut_contacts, hidden_backs)
    report(0.4)
    # with panels, each node is evaluated on its panel (a vertex of a near-flat region may lie
    # off it by up to panels.FLATNESS of its size), so its own surface's patches never hide it
    on_panels = None if panels is None else panels.to_corners(triangle_corners(source.vertices, source.triangles))
    nodes = receiver_nodes(grouped_corners(scene, crease_angle) if groups is None else parallel.waited(groups),
                           on_panels)
    if panels is None:
        panel_node = nodes["corner_node"]
    else:
        panel_node = nodes["corner_node"].ravel()[panels.panel_corner_source]
    report(1.0)
    return Discretization(**patches, **nodes, panel_corners=triangle_corners(source.vertices, source.triangles),
                          panel_node=panel_node)


def discretised(scene: Scene, patch_size: float, crease_angle: float, merge_flat: bool,
                report: Callable[[float], None] = lambda _fraction: None) -> tuple[Discretization, Panels | None]:
    """The patches and nodes a bake solves on, and the panels they were cut from: with
    ``merge_flat`` flat regions of small triangles merged (``panels``; else None), cut into
    patches of ``patch_size``, without the back faces no surface sees (``hidden_backs``);
    ``crease_angle`` in radians."""
    groups = parallel.submit(grouped_corners, scene, crease_angle)  # needs no panels: made beside them
    panels = panelling.panels(scene, patch_size, lambda f: report(f / 2)) if merge_flat else None
    return discretize(scene, patch_size, crease_angle, lambda f: report(0.5 + f / 2), panels=panels,
                      hidden_backs=False, groups=groups), panels


def _patches(scene: Scene, patch_size: float | None, cut_contacts: bool, hidden_backs: bool) -> dict:
    corners = triangle_corners(scene.vertices, scene.triangles)
    zero_area = degenerate(corners)
    if zero_area.all():
        raise ValueError("every triangle of the scene has zero area: there is nothing to light")
    if cut_contacts:
        smallest = 0.0 if patch_size is None else SMALLEST_CUT * patch_size
        pieces, piece_triangle = contacts.pieces(corners, zero_area, smallest)
    else:
        pieces, piece_triangle = corners, np.arange(len(corners))
    piece_degenerate = zero_area[piece_triangle] | degenerate(pieces)
    divisions = _divisions(pieces, piece_degenerate, patch_size)
    if patch_size is not None:
        divisions = _emitter_divisions(scene, corners, zero_area, piece_triangle, divisions)
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
    stops = np.where(scene.casts_shadows, scene.opacity, 1.0)  # a triangle that casts no shadow lets rays by anyway
    return dict(
        patch_corners=patch_corners,
        patch_areas=patch_areas,
        patch_normals=patch_normals,
        patch_centroids=patch_corners.mean(axis=1),
        patch_reflectance=scene.reflectance[patch_triangle],
        patch_emission=scene.emission[patch_triangle],
        patch_casts=None if scene.casts_shadows.all() else scene.casts_shadows[patch_triangle],
        patch_opacity=None if (stops == 1).all() else stops[patch_triangle],
        patch_triangle=patch_triangle,
        patch_piece=patch_piece,
        front_patch_count=len(back_of_front),
        back_of_front=back_of_front,
    )


def _divisions(corners: np.ndarray, zero_area: np.ndarray, patch_size: float | None) -> np.ndarray:
    """(T,) int: edge divisions per triangle, 0 for zero-area triangles (they make no patch)."""
    if patch_size is None:
        divisions = np.ones(len(corners), dtype=np.int64)
    else:
        if not np.isfinite(patch_size) or patch_size <= 0:
            raise ValueError(f"patch_size must be a positive length, got {patch_size}")
        divisions = np.maximum(1, np.ceil(longest_edges(corners) / patch_size)).astype(np.int64)
    divisions[zero_area] = 0
    return divisions


def _check_patch_count(divisions: np.ndarray, patch_size: float | None) -> None:
    total = int((divisions.astype(np.float64) ** 2).sum())
    if total > MAX_PATCHES:
        raise ValueError(
            f"patch_size {patch_size:g} would make {total:,} patches (at most {MAX_PATCHES:,}); "
            "choose a larger patch size"
        )


def _emitter_divisions(scene: Scene, corners: np.ndarray, zero_area: np.ndarray, piece_triangle: np.ndarray,
                       divisions: np.ndarray) -> np.ndarray:
    """(pieces,) int: ``divisions`` (by the patch size), those of each emitter's pieces changed so
    that it has at least MIN_LIGHT_PIECES patches, or about BLACK_LIGHT_PIECES. An emitter that
    ``divisions`` make n patches, fewer than MIN_LIGHT_PIECES, is divided light_divisions(n) times
    more (none is if the emitters so split would then be more than MAX_EMITTER_SHARE of the
    patches); one that reflects nothing and makes more is divided ceil(d sqrt(BLACK_LIGHT_PIECES /
    n)) times where d were asked, which keeps at least BLACK_LIGHT_PIECES patches. An emitter is a
    connected set of emitting triangles (sharing a vertex)."""
    emitting = np.flatnonzero(scene.emission.any(axis=1) & ~zero_area)
    if len(emitting) == 0:
        return divisions
    weld = weld_corners(corners[emitting], scene.extent)
    count = len(emitting)
    # triangles and vertices as one graph: a triangle joined to its corners' vertices
    links = np.stack([np.repeat(np.arange(count), 3), count + weld.ravel()], axis=1)
    emitter = np.full(len(corners), -1)
    emitter[emitting] = connected_components(count + weld.max() + 1, links)[:count]
    piece_emitter = emitter[piece_triangle]
    chosen = np.flatnonzero(piece_emitter >= 0)
    emitter_patches = np.bincount(piece_emitter[chosen], weights=divisions[chosen] ** 2.0, minlength=count)
    factor = np.ones(len(piece_triangle), dtype=np.int64)
    factor[chosen] = light_divisions(emitter_patches)[piece_emitter[chosen]]
    patches = divisions.astype(np.float64) ** 2 * factor**2
    if patches[factor > 1].sum() > MAX_EMITTER_SHARE * patches.sum():
        factor[:] = 1
    result = divisions * factor
    reflecting = np.bincount(emitter[emitting], weights=scene.reflectance[emitting].sum(axis=1), minlength=count) > 0
    coarser = np.flatnonzero((emitter_patches > MIN_LIGHT_PIECES) & ~reflecting)
    scale = np.ones(count)
    scale[coarser] = np.sqrt(BLACK_LIGHT_PIECES / emitter_patches[coarser])
    black = chosen[scale[piece_emitter[chosen]] < 1]
    result[black] = np.ceil(divisions[black] * scale[piece_emitter[black]]).astype(np.int64)
    return result


def _split_triangles(corners: np.ndarray, divisions: np.ndarray) -> dict[str, np.ndarray]:
    """Regular split of each triangle into divisions**2 sub-triangles (grouped by count)."""
    parts, parents = [], []
    for n in np.unique(divisions[divisions > 0]):
        chosen = np.flatnonzero(divisions == n)
        parts.append(subdivide(corners[chosen], int(n)))
        parents.append(np.repeat(chosen, n * n))
    order = np.argsort(np.concatenate(parents), kind="stable")
    return {"corners": np.concatenate(parts)[order], "triangle": np.concatenate(parents)[order]}


