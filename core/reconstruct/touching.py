"""Vertex colours read at the right place on the patches they touch.

A node where surfaces meet (a block's corner standing on the floor, a wall's foot) is evaluated
NODE_INSET of the extent into its own face, a hair from the patch across the edge. From there
almost all of that patch's form factor comes from within a few node heights of the node's foot
on it. The near field (``nearfield``) reads the patch's linear interpolant of its corner colours
at the kernel-weighted centroid of a 4 x 4 split, which at this range puts a few percent of the
weight on the far corners; and where a shadow line leaves the contact point (a block's shadow
starts at its foot), the light around the foot is a wedge, lit on one side and dark on the other,
at every scale, which no linear interpolant shows however small the patches. Both put the
corners where blocks stand on a floor far off (docs/notes/experiments.md).

For each near pair (n, q) where n touches q (a corner of q within TOUCH of q's longest edge) and
F(n, q) >= MIN_FORM_FACTOR, q is taken in polar coordinates about n's foot f on q (clamped into
q), ANGLES directions each to where it leaves q (``_Polar``). The reading point is the
form-factor-weighted centre of q, exact in the radius:

    lambda = barycentric(f + sum_theta M1(theta) e(theta) / sum_theta M0(theta))

(M0, M1 the kernel's zeroth and first moments along each direction), replacing the near field's.
Where the direct light D (G of the lights but the sky, and of the emitting patches) at
PROBE_DIRECTIONS x PROBE_SHELLS points about the foot differs from the linear reading of its
values D_i at q's corners by more than VARIES of the largest, it is read on the polar cells
(each direction cut at SHELL_RADII heights of n over q) one by one, with w_j each cell's share of
the form factor and x_j its middle (D_i read finely, as at the nodes; D(x) coarsely, with the
bake's rays as a patch reads the emitters, since many cells share one correction):

    G_n += F(n, q) rho_q sum_j w_j (D(x_j) - sum_i lambda_i(x_j) D_i)

over the cells with w_j >= MIN_SHARE, for the first MAX_PROBED_PAIRS pairs and MAX_POINTS cells,
the largest form factors first (elsewhere the linear reading of D stands). The indirect light
across q is left to the linear reading.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Protocol

import numpy as np

from ..mesh.discretize import Discretization
from ..util.geometry import areas_and_normals, barycentric, longest_edges, tangent_frames
from . import nearfield
from .nearfield import NearField

TOUCH = 0.05  # a patch corner this share of the patch's longest edge from a node touches it
MIN_FORM_FACTOR = 0.05
VARIES = 0.1
ANGLES = 32  # directions about the foot
# Shells about the foot, in heights of the point over it: finely spaced where most of the form
# factor is (within 64 heights: 1 - 1/64 of a half plane's), coarsely beyond
SHELL_RADII = np.array([0.5, 1, 2, 4, 8, 16, 32, 64, 256, 1024, 4096, 16384, 65536])
SHELLS = len(SHELL_RADII)
FINE_SHELLS = 8  # cut at every direction; beyond, COARSE_GROUP neighbouring directions are one cell
COARSE_GROUP = 4
# Cells where the direct light is tested against the linear reading first: a few directions, at
# 2 and 16 heights from the foot
PROBE_DIRECTIONS = 8
PROBE_SHELLS = (2, 5)
MIN_SHARE = 0.002
# Cells whose direct light is read, per bake (each costs a form factor per light piece or light).
MAX_POINTS = 25_000
# Pairs whose direct light is probed (PROBE_DIRECTIONS x PROBE_SHELLS points each, and their
# corners), the largest form factors first; the others keep the linear reading of it.
MAX_PROBED_PAIRS = 2048
PAIRS_PER_BLOCK = 4096


class DirectLight(Protocol):
    """The direct light G (m, >= C) at points (m, 3) facing unit normals (m, 3), read ``finely``
    or not (``ArrivingLight.sharp``)."""

    def __call__(self, points: np.ndarray, normals: np.ndarray, finely: bool) -> np.ndarray: ...


@dataclass(frozen=True)
class Touching:
    """The geometry of the touching pairs of a NearField: ``near`` with their reading points
    (weights), and for the probed pairs (in blocks) the polar cells' middles (k, cells, 3), shares
    of the form factor (k, cells) and barycentric coordinates on the patch (k, cells, 3)."""

    near: NearField
    probed: list[tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]]

    def restricted(self, keep: np.ndarray) -> Touching:
        """These pairs with only the near pairs ``keep`` (K,) bool (``nearfield.with_pairs``)."""
        if keep.all():
            return self
        index = np.cumsum(keep) - 1  # each kept pair's index among them
        probed = []
        for pairs, middles, shares, where in self.probed:
            chosen = keep[pairs]
            probed.append((index[pairs[chosen]], middles[chosen], shares[chosen], where[chosen]))
        return Touching(nearfield.with_pairs(self.near, keep), probed)


def joined(first: Touching, second: Touching) -> Touching:
    """The touching pairs of ``nearfield.joined(first.near, second.near)``, as ``touching_pairs``
    finds them: the MAX_PROBED_PAIRS largest form factors of the two sets are among each set's own."""
    offset = first.near.pair_count
    near = nearfield.joined(first.near, second.near)
    blocks = first.probed + [(pairs + offset, *rest) for pairs, *rest in second.probed]
    if not blocks:
        return Touching(near, [])
    pairs, middles, shares, where = (np.concatenate(part) for part in zip(*blocks))
    order = np.argsort(-near.form_factor[pairs], kind="stable")[:MAX_PROBED_PAIRS]
    probed = [(pairs[order[start:start + PAIRS_PER_BLOCK]], middles[order[start:start + PAIRS_PER_BLOCK]],
               shares[order[start:start + PAIRS_PER_BLOCK]], where[order[start:start + PAIRS_PER_BLOCK]])
              for start in range(0, len(order), PAIRS_PER_BLOCK)]
    return Touching(near, probed)


def touching_pairs(near: NearField, mesh: Discretization) -> Touching:
    """The touching pairs of ``near``, their reading points from their polar moments and the
    polar cells of those that are probed. Pairs are taken PAIRS_PER_BLOCK at a time (the cells of
    one pair take 7 kB)."""
    points = np.concatenate([mesh.node_points, near.points])
    normals = np.concatenate([mesh.node_normals, near.normals])
    triangles = mesh.patch_corners[near.patch]
    distance = np.linalg.norm(triangles - points[near.receiver][:, None], axis=2).min(axis=1)
    touching = np.flatnonzero((distance <= TOUCH * longest_edges(triangles))
                              & (near.form_factor >= MIN_FORM_FACTOR))
    touching = touching[np.argsort(-near.form_factor[touching], kind="stable")]  # the largest first
    weights = near.weights.copy()
    for start in range(0, len(touching), PAIRS_PER_BLOCK):
        pairs = touching[start:start + PAIRS_PER_BLOCK]
        weights[pairs] = _reading_points(points[near.receiver[pairs]], normals[near.receiver[pairs]], triangles[pairs])
    probed, blocks = touching[:MAX_PROBED_PAIRS], []
    for start in range(0, len(probed), PAIRS_PER_BLOCK):
        pairs = probed[start:start + PAIRS_PER_BLOCK]
        receivers, patch_corners = near.receiver[pairs], triangles[pairs]
        middles, shares = _polar_cells(points[receivers], normals[receivers], patch_corners)
        where = barycentric(middles.reshape(-1, 3), np.repeat(patch_corners, middles.shape[1], axis=0))
        blocks.append((pairs, middles, shares, where.reshape(len(pairs), -1, 3)))
    return Touching(replace(near, weights=weights), blocks)


def read_touching(touching: Touching, mesh: Discretization, direct: DirectLight,
                  channels: int) -> tuple[NearField, np.ndarray, int]:
    """``touching.near`` (the touching pairs' reading points), the change (N + M, C) of the
    lighting G of the output nodes, then of the interpolation nodes, for the detail of the direct
    light, and the number of pairs it changes, from the ``direct`` light (``DirectLight``)."""
    near = touching.near
    points = np.concatenate([mesh.node_points, near.points])
    normals = np.concatenate([mesh.node_normals, near.normals])
    detail = []  # per block: (pair, cell share, cell middle, its barycentric coordinates, corner light)
    for pairs, middles, shares, where in touching.probed:
        corner_light = _corner_light(near, pairs, points, normals, direct, channels)
        misread = _misread(middles, where, shares, mesh.patch_normals[near.patch[pairs]], corner_light, direct,
                           channels)
        rows, cells = np.nonzero((shares >= MIN_SHARE) & misread[:, None])
        detail.append((pairs[rows], shares[rows, cells], middles[rows, cells], where[rows, cells], corner_light[rows]))
    correction = np.zeros((len(points), channels))
    if not detail or not sum(len(part[0]) for part in detail):
        return near, correction, 0
    pair, share, middle, where, corner_light = (np.concatenate(part) for part in zip(*detail))
    # the pairs come largest form factor first: past MAX_POINTS cells, the rest keep the linear reading
    pair, share, middle, where, corner_light = (part[:MAX_POINTS]
                                                for part in (pair, share, middle, where, corner_light))
    patch = near.patch[pair]
    light = direct(middle, mesh.patch_normals[patch], finely=False)[:, :channels]
    linear = np.einsum("kb,kbc->kc", where, corner_light)
    change = (share * near.form_factor[pair])[:, None] * mesh.patch_reflectance[patch, :channels] * (light - linear)
    for channel in range(channels):
        correction[:, channel] = np.bincount(near.receiver[pair], change[:, channel], len(points))
    return near, correction, int(len(np.unique(pair)))


def _corner_light(near: NearField, pairs: np.ndarray, points, normals, direct: DirectLight,
                  channels: int) -> np.ndarray:
    """(k, 3, C) the direct light at the corners of the patches of ``pairs``, where their corner
    colours are evaluated."""
    used, at_corner = np.unique(near.corner_receiver[pairs], return_inverse=True)
    return direct(points[used], normals[used], finely=True)[:, :channels][at_corner.reshape(-1, 3)]


def _misread(middles, where, shares, normals, corner_light, direct: DirectLight, channels: int) -> np.ndarray:
    """(k,) whether the direct light at the probe cells (PROBE_DIRECTIONS directions at
    PROBE_SHELLS) that lie on each patch differs from the linear reading of its corners by more
    than VARIES of the largest of them."""
    step = ANGLES // PROBE_DIRECTIONS
    probes = np.array([a * FINE_SHELLS + s for a in range(0, ANGLES, step) for s in PROBE_SHELLS])
    rows, cells = np.nonzero(shares[:, probes] > 0)
    cells = probes[cells]
    light = direct(middles[rows, cells], normals[rows], finely=False)[:, :channels].sum(axis=1)
    linear = np.einsum("kb,kb->k", where[rows, cells], corner_light[rows].sum(axis=2))
    largest = np.maximum(corner_light.sum(axis=2).max(axis=1), 0.0)
    np.maximum.at(largest, rows, light)
    misread = np.zeros(len(shares), dtype=bool)
    np.logical_or.at(misread, rows, np.abs(light - linear) > VARIES * largest[rows])
    return misread


@dataclass(frozen=True)
class _Polar:
    """Polar coordinates about the foot of each point (k of them) on its triangle: x = foot +
    rho (cos theta u + sin theta v) for the ANGLES middle directions theta; the point at
    ``height`` h over the foot; ``reach`` (k, A) where each direction leaves the triangle.
    From the point facing n_p, x - p = rho e(theta) - h n_q, so

        dF = (rho a - h b)+ h / (pi r^4) rho d rho d theta,  a = e . n_p (``towards``, (k, A)),
        b = n_q . n_p (``facing``, (k,)), r^2 = rho^2 + h^2."""

    foot: np.ndarray
    u: np.ndarray
    v: np.ndarray
    height: np.ndarray
    reach: np.ndarray
    towards: np.ndarray
    facing: np.ndarray

    @classmethod
    def about(cls, points: np.ndarray, normals: np.ndarray, triangles: np.ndarray) -> "_Polar":
        plane = areas_and_normals(triangles)[1]
        height = np.maximum(np.einsum("kx,kx->k", points - triangles[:, 0], plane), 1e-9 * longest_edges(triangles))
        foot = np.clip(barycentric(points - height[:, None] * plane, triangles), 0.0, None)
        foot = np.einsum("kb,kbx->kx", foot / foot.sum(axis=1, keepdims=True), triangles)
        u, v = tangent_frames(plane)  # u x v = the plane's normal: the triangle is counter-clockwise in (u, v)
        flat = np.stack([np.einsum("kcx,kx->kc", triangles - foot[:, None], axis) for axis in (u, v)], axis=2)
        cos, sin = np.cos(_THETA), np.sin(_THETA)
        reach = _exit_distances(flat, np.broadcast_to(np.stack([cos, sin], axis=1), (len(points), ANGLES, 2)))
        towards = cos * np.einsum("kx,kx->k", u, normals)[:, None] + sin * np.einsum("kx,kx->k", v, normals)[:, None]
        return cls(foot, u, v, height, reach, towards, np.einsum("kx,kx->k", plane, normals))

    def directions(self) -> np.ndarray:
        """(k, A, 3) the unit vectors e(theta)."""
        return np.cos(_THETA)[None, :, None] * self.u[:, None] + np.sin(_THETA)[None, :, None] * self.v[:, None]

    def moments(self, inner: np.ndarray, outer: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The share of the form factor, and its first moment in rho, of the rings inner < rho <
        outer (arrays (k, A, S)) of each direction's sector of angle 2 pi / ANGLES, exact in rho
        (rho^2 / r^4, rho / r^4 and rho^3 / r^4 have closed antiderivatives) where the kernel is
        positive: rho a > h b."""
        h = self.height[:, None, None]
        a = self.towards[..., None]
        b = self.facing[:, None, None]
        with np.errstate(divide="ignore", invalid="ignore"):
            turn = h * b / a
        low = np.where(a > 0, np.maximum(inner, np.where(b > 0, turn, 0.0)), inner)
        high = np.where(a < 0, np.where(b < 0, np.minimum(outer, turn), 0.0), outer)
        high = np.maximum(np.where((a == 0) & (b >= 0), 0.0, high), low)

        def share(rho):
            r2 = rho * rho + h * h
            return a * 0.5 * (np.arctan(rho / h) / h - rho / r2) + h * b / (2 * r2)

        def moment(rho):
            r2 = rho * rho + h * h
            return a * 0.5 * (np.log(r2) + h * h / r2) - h * b * 0.5 * (np.arctan(rho / h) / h - rho / r2)

        scale = h * (2 / ANGLES)  # h / pi times the sector's angle
        return (np.maximum(scale * (share(high) - share(low)), 0.0),
                np.maximum(scale * (moment(high) - moment(low)), 0.0))


_THETA = 2 * np.pi * (np.arange(ANGLES) + 0.5) / ANGLES


def _reading_points(points: np.ndarray, normals: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """(k, 3) barycentric coordinates of the centre of each triangle (k, 3, 3) weighted by the
    unoccluded form factor from each point (k, 3) facing ``normals``: sum over directions of
    the first moment along e(theta), over the form factor (a linear reading is read there)."""
    polar = _Polar.about(points, normals, triangles)
    zero = np.zeros_like(polar.reach)[..., None]
    share, moment = polar.moments(zero, polar.reach[..., None])
    total = share.sum(axis=(1, 2))
    offset = np.einsum("ka,kax->kx", moment[..., 0], polar.directions())
    centre = polar.foot + np.divide(offset, total[:, None], out=np.zeros_like(offset), where=total[:, None] > 0)
    return barycentric(centre, triangles)


def _polar_cells(points: np.ndarray, normals: np.ndarray, triangles: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(k, m, 3) the middles of m cells of each triangle (k, 3, 3) in polar coordinates about
    the foot of each point (k, 3) on it, and (k, m) each cell's share of the unoccluded form
    factor from the point facing ``normals``: ANGLES directions, each cut at SHELL_RADII heights
    from the foot up to where it leaves the triangle; beyond FINE_SHELLS, the cells of
    COARSE_GROUP neighbouring directions are one, at their share-weighted centre (far from the
    foot each holds little and the light changes slowly)."""
    count = len(points)
    polar = _Polar.about(points, normals, triangles)
    radii = polar.height[:, None] * SHELL_RADII  # (k, S)
    bounds = np.minimum(np.concatenate([np.zeros((count, 1)), radii], axis=1)[:, None, :], polar.reach[..., None])
    bounds[..., -1] = polar.reach  # (k, A, S + 1): the last shell reaches the edge
    shares = polar.moments(bounds[..., :-1], bounds[..., 1:])[0]  # (k, A, S)
    middle = np.sqrt(bounds[..., 1:] * bounds[..., :-1])
    middle[..., 0] = bounds[..., 1] / 2
    middles = polar.foot[:, None, None] + middle[..., None] * polar.directions()[:, :, None]  # (k, A, S, 3)
    outer_shares = shares[:, :, FINE_SHELLS:].reshape(count, -1, COARSE_GROUP, SHELLS - FINE_SHELLS)
    outer_middles = middles[:, :, FINE_SHELLS:].reshape(count, -1, COARSE_GROUP, SHELLS - FINE_SHELLS, 3)
    outer_total = outer_shares.sum(axis=2)
    outer_centre = np.divide(np.einsum("kagc,kagcx->kacx", outer_shares, outer_middles), outer_total[..., None],
                             out=outer_middles.mean(axis=2), where=outer_total[..., None] > 0)
    middles = np.concatenate([middles[:, :, :FINE_SHELLS].reshape(count, -1, 3), outer_centre.reshape(count, -1, 3)],
                             axis=1)
    shares = np.concatenate([shares[:, :, :FINE_SHELLS].reshape(count, -1), outer_total.reshape(count, -1)], axis=1)
    total = shares.sum(axis=1, keepdims=True)
    return middles, np.divide(shares, total, out=np.zeros_like(shares), where=total > 0)


def _exit_distances(flat: np.ndarray, directions: np.ndarray) -> np.ndarray:
    """(k, F) how far each ray from the origin along unit ``directions`` (k, F, 2) runs inside
    the triangle ``flat`` (k, 3, 2) that holds the origin: the nearest crossing of an edge
    (0 where it leaves at once, the origin on the edge). A ray leaves a counter-clockwise
    triangle through the edges E it crosses outwards, d x E > 0."""
    start = flat[:, None]  # (k, 1, 3, 2)
    along = np.roll(flat, -1, axis=1)[:, None] - start  # edges (k, 1, 3, 2)
    d = directions[:, :, None]  # (k, F, 1, 2)
    denominator = d[..., 0] * along[..., 1] - d[..., 1] * along[..., 0]  # d x E
    with np.errstate(divide="ignore", invalid="ignore"):
        distance = (start[..., 0] * along[..., 1] - start[..., 1] * along[..., 0]) / denominator  # (A x E) / (d x E)
        position = (start[..., 0] * d[..., 1] - start[..., 1] * d[..., 0]) / denominator  # (A x d) / (d x E)
    tolerance = 1e-9
    valid = (denominator > 0) & (position >= -tolerance) & (position <= 1 + tolerance) & (distance >= 0)
    nearest = np.where(valid, distance, np.inf).min(axis=2)
    return np.where(np.isfinite(nearest), nearest, 0.0)
