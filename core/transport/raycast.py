"""Ray-cast form factors (Wallace, Elmquist and Haines 1989): the exact unoccluded form factor
from a receiving point to a source patch (``analytic``), times the fraction of the source that
the point sees, estimated with rays to stratified sample points on the source.

Each sample s is weighted by its unoccluded differential kernel cos_r cos_s / (r^2 + A/(pi S))
(the disc approximation of Wallace et al., which keeps the weight finite as r -> 0), so that a
blocked sample counts for what it would have contributed:

    V = sum_s w_s v_s / sum_s w_s,   F = F_analytic * V.

Sample positions are fixed per source patch for a seed (one point per stratum, the strata
shifted by a per-patch Cranley-Patterson rotation), so results do not depend on batching.

Close to an emitting source the kernel's 1 / r^2 makes a few samples weigh for all (a point
under a large sky quad, a ceiling beside a lamp), so there the samples are directions uniform in
the solid angle the source subtends (``geometry.solid_angle_directions``), each weighted by its
cosine at the receiver alone, V = sum_s cos_s v_s / sum_s cos_s: the weights no longer vary by
orders of magnitude, and the visible share converges as the share of a hemisphere's rays would.
"""

from __future__ import annotations

import functools
from typing import Callable

import numpy as np

from ..rays.visibility import RAY_EPSILON, Visibility
from ..util import parallel, streams
from ..util.geometry import GOLDEN, barycentric_grid, longest_edges, solid_angle_directions
from .analytic import point_to_triangle

# An emitting patch whose centroid is closer to a point than CLOSE_REACH of its longest edge is
# sampled from there with rays uniform in its solid angle, none skipped by the probes: the source
# fills much of the point's view, and a blocker near the point (a moulding's lip) hides part of it
# (the tops of a gallery under a large sky triangle: docs/notes/experiments.md, and "The emitters'
# light at the nodes" for the solid angle). CLOSE_RAYS rays (or the bake's rays per form factor, if
# more), all cast; from the points asked about ``finely`` (a bake's nodes, whose colours show the
# emitter's light), two such sets (``joined_shares``), and where either disagrees (a shadow's edge
# crosses the source) CLOSE_MIXED_RAYS more directions (or the bake's rays, if more). The patches'
# light only feeds the bounces: they keep the first ("Fewer rays where they buy nothing").
CLOSE_REACH = 0.75
CLOSE_RAYS = 16
CLOSE_MIXED_RAYS = 128
# Farther off, the points asked about finely sample an emitting patch at two sets of EMITTER_RAYS
# stratified points, all cast, and EMITTER_MIXED_RAYS (or the bake's rays per form factor, if more)
# more where either disagrees. On Sponza, under its sky quad, the nodes' emitter pairs cast alike
# (16 rays, 64 close by) read 2.54 / 2.70 % from path tracing (seeds 0 / 1), with these 2.21 /
# 2.56 % for the shots' 1.8 s more (docs/notes/experiments.md, "The emitters' shadows sampled where
# they fall"). The other points (the patches) keep the bake's rays, probed where the caster probes:
# a thin blocker between the probes is missed there (0.9 of a 1 cm bar's shadow), which two sets
# of the probes' count would mend for 1 s of Sponza's shots and no gain in its error ("A thin bar
# under a far emitter, by who reads it").
EMITTER_RAYS = 9
EMITTER_MIXED_RAYS = 36
# The emitters' samples are cast at most CHUNK_RAYS at a time, about 180 bytes a ray: a block of
# pairs (``formfactors.RAYS_PER_BLOCK`` of the bake's rays) whose pairs all disagree then holds no
# more than its first rays did.
CHUNK_RAYS = 1 << 18
# The patches' sample points are made this many patches at a time on the pool: the same points,
# with a small block's memory (316,328 patches, as the breakfast room's: 0.8 to 1.7 -> 0.4 s).
SAMPLED_PATCHES = 1 << 15


def lattice(count: int) -> np.ndarray:
    """(count, 2) the rank-1 lattice ((i + 1/2) / count, i GOLDEN mod 1) of the unit square."""
    index = np.arange(count)
    return np.stack([(index + 0.5) / count, (index * GOLDEN) % 1.0], axis=1)


def check_ray_count(count: int) -> int:
    """The strata per edge for ``count`` rays, which must be a perfect square."""
    divisions = int(round(np.sqrt(count)))
    if count < 1 or divisions * divisions != count:
        raise ValueError(f"rays per form factor must be a perfect square (1, 4, 9, 16, ...), got {count}")
    return divisions


def stratified_samples(patch_corners: np.ndarray, count: int, rotation: np.ndarray) -> np.ndarray:
    """(P, count, 3) points on each patch, one in each of ``count`` (a perfect square) congruent
    strata, shifted by a Cranley-Patterson ``rotation`` (P, 1, 2) in [0, 1); a uniform point in a
    triangle is (1 - sqrt(u), sqrt(u) (1 - v), sqrt(u) v). The result has the dtype of
    ``patch_corners``."""
    grid, cells = barycentric_grid(check_ray_count(count))
    strata = grid[cells]  # (count, 3 corners, 3 barycentric)
    base = lattice(count)
    dtype = patch_corners.dtype
    rotation = rotation.astype(dtype)
    uv = (base.astype(dtype) + rotation) % 1.0
    root = np.sqrt(uv[..., 0])
    local = np.stack([1 - root, root * (1 - uv[..., 1]), root * uv[..., 1]], axis=2)  # (P, S, 3)
    barycentric = np.matmul(local.transpose(1, 0, 2), strata.astype(dtype)).transpose(1, 0, 2)
    return np.matmul(barycentric, patch_corners)


def probe_samples(count: int) -> tuple[np.ndarray, np.ndarray]:
    """Indices of the samples (strata of ``stratified_samples``) tested first: for n x n strata
    with n >= 4, the stratum nearest the centre of each of the (n / 2) x (n / 2) coarser strata
    (4 of 16, 16 of 64), spread over the source; the others. Below 16 samples, all are probes."""
    divisions = check_ray_count(count)
    if divisions < 4:
        return np.arange(count), np.zeros(0, dtype=np.int64)
    grid, cells = barycentric_grid(divisions)
    fine = grid[cells].mean(axis=1)
    coarse_grid, coarse_cells = barycentric_grid(divisions // 2)
    coarse = coarse_grid[coarse_cells].mean(axis=1)
    probe = np.unique(np.linalg.norm(fine[None] - coarse[:, None], axis=2).argmin(axis=1))
    return probe, np.setdiff1d(np.arange(count), probe)


class RayCaster:
    """Point-to-patch form factors with ray-cast visibility over a fixed set of patches."""

    def __init__(self, patch_corners, patch_normals, patch_areas, visibility: Visibility, rays: int, seed: int,
                 patch_owners: np.ndarray | None = None, probing: bool = False, emitting: np.ndarray | None = None):
        """``patch_owners`` (P,): the surface (``visibility.owners``) each patch lies on, or None
        for sources that are not among the occluders (area lights). With patches, the points
        asked about must lie on or in front of the surfaces (as a bake's receivers do): the
        walls with the whole scene in front of them are not traced
        (``Visibility.occluded_between_unit``). With ``probing``, the probe samples
        (``probe_samples``: 4 of 16, 16 of 64) are cast first and the rest only where those
        disagree: about half the time of a bake, but a shadow edge that crosses a source between
        the probes is missed (a blocker's form factor 1 % off in tests/core/test_occlusion.py).
        ``emitting`` (P,) bool: the patches sampled in their solid angle from close by; farther
        off from the points asked about finely by two sets of EMITTER_RAYS and max(EMITTER_MIXED_RAYS,
        ``rays``) more where either disagrees (``joined_shares``)."""
        self.corners = patch_corners
        self.normals = patch_normals
        self.owners = patch_owners
        self.visibility = visibility
        self.rays = rays
        unit_corners = (patch_corners - visibility.center) * visibility.scale
        rotations = _rotations(seed, streams.SHOT_SAMPLES, len(unit_corners))
        self._unit_samples = np.concatenate([np.zeros((0, rays, 3), np.float32), *parallel.map_ordered(
            lambda part: stratified_samples(unit_corners[part], rays, rotations[part]).astype(np.float32),
            [slice(start, start + SAMPLED_PATCHES) for start in range(0, len(unit_corners), SAMPLED_PATCHES)])])
        self._unit_normals = patch_normals.astype(np.float32)
        # disc term A / (pi S) of the weight, in the unit space of the visibility module
        self._unit_disc = (patch_areas * visibility.scale**2 / (np.pi * rays)).astype(np.float32)
        self._probe, self._rest = probe_samples(rays) if probing else (np.arange(rays), np.zeros(0, dtype=np.int64))
        emitting = np.zeros(len(patch_corners), dtype=bool) if emitting is None else emitting
        self._emitter_slot = np.full(len(patch_corners), -1)
        self._emitter_slot[emitting] = np.arange(np.count_nonzero(emitting))
        self._close_reach2 = (CLOSE_REACH * longest_edges(patch_corners)) ** 2
        emitters = np.count_nonzero(emitting)
        # the close sources' directions, first and where those disagree: (E, 1, 2) Cranley-Patterson
        # rotations of each one's lattice of the unit square (``_close_uv``)
        self._close_rays = (max(CLOSE_RAYS, rays), max(CLOSE_MIXED_RAYS, rays), max(CLOSE_RAYS, rays))
        self._close_shifts = [_rotations(seed, tag, emitters) for tag in (
            streams.CLOSE_DIRECTIONS, streams.CLOSE_MIXED_DIRECTIONS, streams.CLOSE_SECOND_DIRECTIONS)]

        def sample_set(count: int, tag: int) -> tuple[np.ndarray, np.ndarray, bool]:
            """(E, count, 3) stratified samples of each emitter from the stream ``tag``, (E,) their
            disc term, and False: indexed by emitter (``_emitter_slot``), not by patch."""
            samples = stratified_samples(unit_corners[emitting], count, _rotations(seed, tag, emitters))
            disc = patch_areas[emitting] * visibility.scale**2 / (np.pi * count)
            return samples.astype(np.float32), disc.astype(np.float32), False

        # the first, the more and the second samples of each emitter, read at the points asked
        # about finely (``_fine_form_factors``); from EMITTER_MIXED_RAYS rays on, the more are the
        # bake's rays (indexed by patch)
        more = (self._unit_samples, self._unit_disc, True) if rays >= EMITTER_MIXED_RAYS else \
            sample_set(EMITTER_MIXED_RAYS, streams.EMITTER_MIXED_SAMPLES)
        self._fine_sets = (sample_set(EMITTER_RAYS, streams.EMITTER_SAMPLES), more,
                           sample_set(EMITTER_RAYS, streams.EMITTER_SECOND_SAMPLES))
        self._unit_probes = np.ascontiguousarray(self._unit_samples[:, self._probe])  # (P, probes, 3)
        # sources with another face in their plane over them (``contacts.coplanar_overlaps``)
        # need the first-hit rule below; for the others a ray stopped short of their plane tells
        # the same, faster
        self._contested = None
        if patch_owners is not None:
            contested = np.zeros(max(visibility.owners.max(), patch_owners.max()) + 1, dtype=bool)
            contested[visibility.owners[visibility.coplanar_overlaps]] = True
            self._contested = contested[patch_owners]

    @property
    def sample_bytes(self) -> int:
        return (self._unit_samples.nbytes + self._unit_probes.nbytes
                + sum(values.nbytes for values in self._close_shifts)
                + sum(samples.nbytes + disc.nbytes for samples, disc, by_patch in self._fine_sets if not by_patch))

    def grid_form_factors(self, points: np.ndarray, normals: np.ndarray, sources: np.ndarray,
                          finely: np.ndarray | None = None) -> np.ndarray:
        """(m, k) form factors from every point (m, 3) facing normals (m, 3) to every patch of
        ``sources`` (k,), ``finely`` as for ``form_factors``: those of ``facing_pairs``, the others
        zero."""
        receivers, chosen = self.facing_pairs(points, normals, sources)
        result = np.zeros((len(points), len(sources)))
        result[receivers, chosen] = self.form_factors(points, normals, receivers, sources[chosen], finely)
        return result

    def facing_pairs(self, points: np.ndarray, normals: np.ndarray, sources: np.ndarray,
                     reach: tuple[np.ndarray, np.ndarray] | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Index pairs (i, j), row by row, of the points (m, 3) facing normals (m, 3) and the
        patches ``sources`` (k,) that may see each other, found by matrix products: not the point
        behind the source's plane, nor the source below the point's horizon (most pairs, in a
        room), nor, with ``reach``, the point outside the box (low and high corners (k, 3)) the
        source's light reaches (``reach``)."""
        corners = self.corners[sources]
        seen = points @ self.normals[sources].T > np.einsum("kx,kx->k", corners[:, 0], self.normals[sources])
        heights = normals @ corners.reshape(-1, 3).T  # (m, 3k): corner c of source j at 3 j + c
        highest = np.maximum(np.maximum(heights[:, 0::3], heights[:, 1::3]), heights[:, 2::3])
        seen &= highest > np.einsum("mx,mx->m", points, normals)[:, None]
        if reach is not None:
            for axis in range(3):
                coordinate = points[:, axis, None]
                seen &= (reach[0][:, axis] <= coordinate) & (coordinate <= reach[1][:, axis])
        return np.nonzero(seen)

    def faces(self, points: np.ndarray, normals: np.ndarray, sources: np.ndarray) -> np.ndarray:
        """(n,) bool, pairwise: what ``facing_pairs`` tests without a reach box, for points (n, 3)
        facing normals (n, 3) and the patches ``sources`` (n,)."""
        corners = self.corners[sources]
        ahead = np.einsum("nx,nx->n", points - corners[:, 0], self.normals[sources]) > 0
        highest = np.einsum("ncx,nx->nc", corners, normals).max(axis=1)
        return ahead & (highest > np.einsum("nx,nx->n", points, normals))

    def form_factors(self, points: np.ndarray, normals: np.ndarray, receivers: np.ndarray,
                     sources: np.ndarray, finely: np.ndarray | None = None) -> np.ndarray:
        """(n,) form factors from points[receivers] (facing normals[receivers]) to patches
        ``sources``, pairwise; points (m, 3), normals (m, 3), receivers and sources (n,) int;
        ``finely`` (m,) bool: the points that read the emitting sources with two sets of
        EMITTER_RAYS rays and max(EMITTER_MIXED_RAYS, ``rays``) more where either disagrees, close
        by with CLOSE_MIXED_RAYS more so (``joined_shares``; None: none)."""
        emitting = np.flatnonzero(self._emitter_slot[sources] >= 0)
        if len(emitting) == 0:
            return self._probed_form_factors(points, normals, receivers, sources)
        offset = points[receivers[emitting]] - self.corners[sources[emitting]].mean(axis=1)
        near = np.einsum("kx,kx->k", offset, offset) < self._close_reach2[sources[emitting]]
        close, far = emitting[near], emitting[~near]
        fine = far[:0] if finely is None else far[finely[receivers[far]]]
        result = np.empty(len(receivers))
        rest = np.ones(len(receivers), dtype=bool)
        rest[close], rest[fine] = False, False
        result[rest] = self._probed_form_factors(points, normals, receivers[rest], sources[rest])
        close_finely = np.zeros(len(close), dtype=bool) if finely is None else finely[receivers[close]]
        result[close] = self._close_form_factors(points, normals, receivers[close], sources[close], close_finely)
        result[fine] = self._fine_form_factors(points, normals, receivers[fine], sources[fine])
        return result

    def _probed_form_factors(self, points, normals, receivers, sources) -> np.ndarray:
        """(n,) form factors from the probes, and where they disagree every sample."""
        normal = self.visibility.to_unit_directions(normals[receivers])
        # start RAY_EPSILON off the receiving surface, so a grazing ray cannot re-enter it
        origin = self.visibility.to_unit(points[receivers]) + RAY_EPSILON * normal  # (n, 3)
        # the probe samples first: where they agree (the source wholly seen or wholly hidden, as
        # for most pairs) their verdict stands for every sample; the exact unoccluded form factor
        # only where some are seen (in a large scene most near pairs, and most of what a light
        # shoots, are hidden)
        # (n, s, 3): rays, t in [0, 1]; np.take gathers rows faster than indexing
        offset = np.take(self._unit_probes, sources, axis=0) - origin[:, None, :]
        probed = self._blocked(origin, offset, self._cos_source(offset, sources), sources)
        result = np.zeros(len(receivers))
        some_seen = np.flatnonzero(~(probed >= 1).all(axis=1))
        if len(some_seen) == 0:
            return result
        receivers_seen, sources_seen = receivers[some_seen], sources[some_seen]
        unoccluded = point_to_triangle(points[receivers_seen], normals[receivers_seen], self.corners[sources_seen])
        lit = unoccluded > 0
        mixed = np.flatnonzero(lit & (probed[some_seen] > 0).any(axis=1))
        if len(mixed):
            pairs = some_seen[mixed]
            unoccluded[mixed] *= self._seen_fraction(origin[pairs], normal[pairs], sources[pairs], probed[pairs])
        result[some_seen] = unoccluded
        return result

    def _close_form_factors(self, points, normals, receivers, sources, finely) -> np.ndarray:
        """(n,) form factors to emitting sources close to their points (CLOSE_REACH), from their
        first directions (``_close_rays``), and where ``finely`` (n,) bool from those, a second
        set and, where either disagrees, more (``joined_shares``; ``solid_angle_form_factors``)."""
        first, more, _ = self._close_rays
        result = np.empty(len(receivers))
        finely = finely & (more > first)

        def read(rows, which):
            return self.solid_angle_form_factors(points, normals, receivers[rows], sources[rows],
                                                 self._close_uv(sources[rows], which), mixed=True)

        coarse = np.flatnonzero(~finely)
        for rows in _chunks(len(coarse), first):
            result[coarse[rows]] = read(coarse[rows], 0)[0]
        fine = np.flatnonzero(finely)
        result[fine] = joined_shares(len(fine), first, more, lambda rows, which: read(fine[rows], which))
        return result

    def _close_uv(self, sources: np.ndarray, which: int) -> np.ndarray:
        """(n, S, 2) points of the unit square for each of the emitting ``sources`` (n,): the
        rank-1 lattice of the first (``which`` 0), the more (1) or the second (2) directions'
        count (``_close_rays``), rotated by the source's own shift for them."""
        shifts = self._close_shifts[which][self._emitter_slot[sources]]
        return (lattice(self._close_rays[which])[None] + shifts) % 1.0

    def solid_angle_form_factors(self, points: np.ndarray, normals: np.ndarray, receivers: np.ndarray,
                                 sources: np.ndarray, uv: np.ndarray, mixed: bool = False):
        """(n,) form factors from points[receivers] to patches ``sources`` (n,), pairwise, from
        S directions each uniform in the source's solid angle at the points ``uv`` (n, S, 2) of
        the unit square (``geometry.solid_angle_directions``), every one cast, each weighted by
        its cosine at the point (the module's docstring); with ``mixed``, and (n,) bool: whether
        the directions of weight disagree (``unequally_blocked``)."""
        unoccluded = point_to_triangle(points[receivers], normals[receivers], self.corners[sources])
        disagree = np.zeros(len(receivers), dtype=bool)
        lit = np.flatnonzero(unoccluded > 0)
        receivers, sources = receivers[lit], sources[lit]
        normal = self.visibility.to_unit_directions(normals[receivers])
        origin = self.visibility.to_unit(points[receivers]) + RAY_EPSILON * normal
        # made in the rays' unit space: a scaled scene's alike
        unit_points, unit_corners = ((values - self.visibility.center) * self.visibility.scale
                                     for values in (points[receivers], self.corners[sources]))
        directions, offset = solid_angle_directions(unit_points, unit_corners, uv[lit])
        offset -= RAY_EPSILON * normal[:, None, :]  # from the origin, RAY_EPSILON off the surface
        # from a point this close, many directions aim at the source's edges, along a wall that
        # meets it (a room's corner): a watertight scene stops the rays that graze the seam
        blocked = self._blocked(origin, offset, self._cos_source(offset, sources), sources, watertight=True)
        weight = np.maximum((directions @ normal[:, :, None])[..., 0], 0).astype(np.float64)
        total = weight.sum(axis=1)
        seen = (weight * (1.0 - blocked)).sum(axis=1)  # blocked: bool, or the share see-through surfaces stop
        unoccluded[lit] *= np.where(total > 0, seen / np.where(total > 0, total, 1), 1.0)
        if mixed:
            disagree[lit] = unequally_blocked(blocked, weight > 0)
            return unoccluded, disagree
        return unoccluded

    def _fine_form_factors(self, points, normals, receivers, sources) -> np.ndarray:
        """(n,) form factors to emitting sources from their two first sets of EMITTER_RAYS samples
        and, where either disagrees, their more samples (``joined_shares``)."""
        sets = self._fine_sets
        normal = self.visibility.to_unit_directions(normals[receivers])
        origin = self.visibility.to_unit(points[receivers]) + RAY_EPSILON * normal
        unoccluded = point_to_triangle(points[receivers], normals[receivers], self.corners[sources])
        lit = np.flatnonzero(unoccluded > 0)
        slot = self._emitter_slot[sources]

        def share(rows, which):
            rows = lit[rows]
            samples, disc, by_patch = sets[which]
            index = sources[rows] if by_patch else slot[rows]
            offset = samples[index] - origin[rows, None, :]
            cos_source = self._cos_source(offset, sources[rows])
            blocked = self._blocked(origin[rows], offset, cos_source, sources[rows])
            return _weighted_share(offset, normal[rows], cos_source, blocked, disc[index], disagreeing=True)

        unoccluded[lit] *= joined_shares(len(lit), sets[0][0].shape[1], sets[1][0].shape[1], share)
        return unoccluded

    def _seen_fraction(self, origin, normal, sources, probed) -> np.ndarray:
        """(k,) the weighted share of the samples seen for pairs whose probes (k, probes)
        disagree: the other samples are cast too."""
        offset = np.take(self._unit_samples, sources, axis=0) - origin[:, None, :]  # (k, S, 3)
        cos_source = self._cos_source(offset, sources)  # times -distance
        blocked = np.empty(offset.shape[:2], dtype=probed.dtype)
        blocked[:, self._probe] = probed
        if len(self._rest):
            rest = self._rest
            blocked[:, rest] = self._blocked(origin, offset[:, rest], cos_source[:, rest], sources)
        return _weighted_share(offset, normal, cos_source, blocked, self._unit_disc[sources])

    def _cos_source(self, offset: np.ndarray, sources: np.ndarray) -> np.ndarray:
        """(k, s) cosine at the source times minus the distance, for ray offsets (k, s, 3)."""
        return (offset @ self._unit_normals[sources][:, :, None])[..., 0]

    def _blocked(self, origin, offset, cos_source, sources, watertight: bool = False) -> np.ndarray:
        """(k, s) bool: whether the ray from each origin (k, 3) to each of its samples (k, s, 3
        offsets) is blocked; ``watertight``: traced so (``Visibility``), for samples that aim
        at the edges of their sources, not jittered at random over them."""
        rays = offset.shape[1]
        starts, directions = np.repeat(origin, rays, axis=0), offset.reshape(-1, 3)
        across = np.maximum(-cos_source, np.finfo(np.float32).tiny).reshape(-1)
        # stop RAY_EPSILON short of the source's plane, measured across it: a grazing ray then
        # cannot hit its own source through the rounding of the sample onto float32
        # the samples are jittered at random (``stratified_samples``): the faster scene traces them
        blocked_unit = functools.partial(self.visibility.blocked_unit, jittered=not watertight)
        if self.owners is None:  # a light, which may lie beyond the walls
            return blocked_unit(starts, directions, 1 - RAY_EPSILON / across).reshape(-1, rays)
        # from a point of the surfaces to a patch: a wall with everything in front of it cannot block
        contested = np.repeat(self._contested[sources], rays)
        if not contested.any():
            return blocked_unit(starts, directions, 1 - RAY_EPSILON / across, between=True).reshape(-1, rays)
        blocked = np.zeros(len(starts), dtype=np.float64 if self.visibility.see_through else bool)
        free = np.flatnonzero(~contested)
        blocked[free] = blocked_unit(starts[free], directions[free], 1 - RAY_EPSILON / across[free], between=True)
        chosen = np.flatnonzero(contested)
        blocked[chosen] = self._first_hit_blocked(starts[chosen], directions[chosen], across[chosen],
                                                  np.repeat(self.owners[sources], rays)[chosen], watertight)
        return blocked.reshape(-1, rays)

    def _first_hit_blocked(self, starts, directions, across, owners, watertight: bool = False) -> np.ndarray:
        """(n,) bool for rays towards sources of ``owners`` (n,) that another face shares a
        plane with."""
        # reach RAY_EPSILON past the source's plane and look at what the ray meets first: the
        # source's own surface counts as seen; so does a face in the source's plane that turns
        # its back to the ray (the far side of a two-faced card); a coplanar face turned the
        # same way as the source blocks when it wins the tie (two coincident faces then share
        # the solid angle, as they share a hemicube's pixels, instead of both taking all of it);
        # anything else blocks
        visibility = self.visibility
        first = visibility.first_hit_unit(starts, directions, 1 + RAY_EPSILON / across, jittered=not watertight)
        hit = np.maximum(first, 0)
        blocked = (first >= 0) & (visibility.owners[hit] != owners)
        candidates = np.flatnonzero(blocked)
        hit_normals = visibility.triangle_normals[hit[candidates]]
        turned_away = (directions[candidates] * hit_normals).sum(axis=1) > 0
        target = (starts[candidates] + directions[candidates]).astype(np.float64)  # the sample point
        in_plane = np.abs((target * hit_normals).sum(axis=1) - visibility.unit_plane_offsets[hit[candidates]]) \
            <= 2 * RAY_EPSILON
        blocked[candidates[turned_away & in_plane]] = False
        return blocked


def _rotations(seed: int, tag: int, count: int) -> np.ndarray:
    """(count, 1, 2) Cranley-Patterson rotations of ``count`` patches' strata from the stream
    ``tag`` (``util.streams``)."""
    return streams.generator(seed, tag).random((count, 1, 2))


def _weighted_share(offset, normal, cos_source, blocked, disc, disagreeing: bool = False):
    """(k,) sum_s w_s v_s / sum_s w_s over the samples at ``offset`` (k, S, 3) from the points
    (facing ``normal`` (k, 3)), ``cos_source`` (k, S) the source's cosine times minus the
    distance, ``blocked`` (k, S), ``disc`` (k,) the disc term of the weight; with
    ``disagreeing``, and (k,) bool whether the samples of weight disagree (``unequally_blocked``)."""
    distance2 = np.einsum("ksx,ksx->ks", offset, offset)
    cos_receiver = (offset @ normal[:, :, None])[..., 0]  # times distance
    weight = np.maximum(cos_receiver, 0) * np.maximum(-cos_source, 0)
    weight /= distance2 * (distance2 + disc[:, None])
    weight_sum = weight.sum(axis=1)
    weight[weight_sum <= 0] = 1.0  # no sample above both horizons: count them all alike
    weight_sum[weight_sum <= 0] = offset.shape[1]
    disagree = unequally_blocked(blocked, weight > 0) if disagreeing else None
    if blocked.dtype == bool:
        weight[blocked] = 0
    else:  # the shares of the light that see-through surfaces stop
        weight *= 1.0 - blocked
    share = weight.sum(axis=1) / weight_sum
    return (share, disagree) if disagreeing else share


def unequally_blocked(blocked: np.ndarray, counted: np.ndarray) -> np.ndarray:
    """(k,) bool: whether the samples ``counted`` (k, S) bool are blocked unequally: some blocked
    and some not (``blocked`` (k, S) bool), or stopped in different shares by see-through surfaces
    (float; one even cover stops all alike)."""
    shares = blocked.astype(np.float32)
    return np.where(counted, shares, -1.0).max(axis=1) > np.where(counted, shares, 2.0).min(axis=1)


def joined_shares(count: int, first: int, more: int, read: Callable) -> np.ndarray:
    """(count,) shares of a light seen, each from two sets of ``first`` samples, and ``more`` where
    either set disagrees: ``read(rows, which)`` gives (k,) shares and (k,) bool whether the samples
    disagree for the pairs ``rows`` from set ``which`` (0 the first, 1 the more, 2 the second).
    Each first set decides for the other: the share is the mean of the first set's, joined by the
    more samples (weighed by their counts) where the second disagrees, and the second's, joined so
    where the first disagrees. A set's verdict never decides its own reading, so every reading is
    unbiased: decided by its own samples, a pair whose few samples all miss a thin blocker keeps
    their verdict, and the blocker's shadow is lost on average (a bar 1 cm wide 1 m under a light
    0.6 m wide, 2 m over the floor: 0.6 to 0.9 of it)."""
    shares, disagree = np.empty((2, count)), np.zeros((2, count), dtype=bool)
    for rows in _chunks(count, first):
        for place, which in enumerate((0, 2)):
            shares[place, rows], disagree[place, rows] = read(np.arange(count)[rows], which)
    again = np.flatnonzero(disagree.any(axis=0))
    joined = np.empty(len(again))
    for rows in _chunks(len(again), more):
        joined[rows] = read(again[rows], 1)[0]
    for place in range(2):
        other = disagree[1 - place, again]  # the other set decides
        shares[place, again[other]] = (first * shares[place, again[other]] + more * joined[other]) / (first + more)
    return shares.mean(axis=0)


def _chunks(count: int, rays: int) -> list[slice]:
    """Consecutive slices of ``count`` pairs of ``rays`` rays each, at most CHUNK_RAYS rays a slice."""
    size = max(1, CHUNK_RAYS // rays)
    return [slice(start, start + size) for start in range(0, count, size)]
