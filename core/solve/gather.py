"""The final gather (Lischinski, Tampieri and Greenberg 1993): the light arriving where colours are
evaluated, read from the patches' radiosity after the shots and Monte Carlo (``montecarlo``).

G(x) = sum_j F(x, j) V_j = E[V at the first hit of a cosine-distributed ray from x], estimated
from K stratified directions (``gather_hits``, ``GatherHits.read``): a point so averages K
patches' values, and their noise with them, and the spread of its samples gives the standard
error of its estimate.

A patch's value is its mean. Seen from close by, the mean is not what a point sees: from a vertex
on a concave edge half the view is the patch across the edge, darker in the corner than its mean,
or brighter beside an emitter, and a small patch's mean is pooled with its neighbours'
(``montecarlo.pools``). So a ray that meets patch j nearer than NEAR_HIT times j's longest edge
reads the radiosity where it landed, at y, by SECOND_RAYS rays of its own from y (the secondary
final gather of photon mapping: Jensen, "Global illumination using photon maps", 1996):

    B_j(y) = E_j + rho_j (L_j + sum_q F(y, q) B_q),

L_j the direct light of the lights at y (``DirectLighting``, one shadow ray per light, up to
MAX_NEAR_LIGHTS point, spot and sun lights; a scene with more, with area lights or with an
environment, which no ray meets, reads its near patches by the near field instead:
``gather_hits``'s ``near``); the light of the emitting surfaces E_q is sampled at y as
well (next-event estimation, weighted against the rays that meet them: ``emitters``), and rays
that leave the scene read the uniform sky. The light and the shade of the corner are so read
where the ray landed, which the near field (``reconstruct.nearfield``) does with linear
interpolants of the patch's corner colours (a cut piece of a triangle has none): this replaces it
where Monte Carlo carries the light (docs/notes/experiments.md, "A second gather where the rays
land close").

The rays of their own from the points where one node's rays landed close (on Sponza 17 points of
4 rays on average at 64 rays, most on the same few surfaces) are drawn as one set: a rank-1 lattice of all
of them, shifted at random (``_lattice_points``), so that together they cover the directions as
evenly as strata would; each ray stays uniform, and the estimate unbiased. On the breakfast room
a bake's error fell by 0.23 points on average, 7 of 8 bakes lower (docs/notes/experiments.md,
"Sponza's time by stage").

Those rays' own rays may land close again: in a crack, under a cup on its saucer, the patches q
around y are lit, on the whole, quite unlike the few millimetres the rays see of them. So each of
them that lands at y' nearer than DEEP_HIT times its patch's longest edge is followed in turn, one
ray from y' reading B_q(y') the same way, up to NEAR_BOUNCES bounces from the gather's ray (a path
traced until it lands far enough for the patch's mean to stand for what it meets).

The nodes of one vertex (a surface shaded flat gives each face its own) gather together
(``node_pools``): node i reads the rays of all k of them, the ray r of any weighed by the balance
heuristic of multiple importance sampling (Veach and Guibas 1995),

    G_i = 1 / (k K) sum_r w_i(d_r) V(r),   w_i(d) = max(0, n_i . d) / (1 / k sum_j max(0, n_j . d)),

unbiased since every direction node i sees is one its own rays are drawn in, but for the few
millimetres between the nodes: not where a surface lies that close (a crevice). On Sponza as
Blender shades it flat (2.9 nodes per vertex) one bake's noise fell from 2.77 to 2.27 % of the
light (docs/notes/experiments.md, "The nodes of one vertex gather together").

The patches that few particles reached read their own light by a gather too (``patch_hits``,
``patch_light``): X_p = U_p + rho_p sum_q F(p, q) X_q over stratified points of p, in place of
their pool's mean (``montecarlo.pools``), which is unbiased only over the whole pool. Their rays
that land close are followed as the nodes' are (by one ray each, then bounce by bounce): the
pools' means are not the light of the few millimetres such a ray sees either. On the breakfast
room a saucer under a cup read a sixteenth of the light path tracing finds where the cup's rays
land on it, its 9 rays having met the cup's foot at the mean of a pool of darker faces turned the
same way (docs/notes/experiments.md, "The sky through a blind").

The hits are geometry only: a re-solve reads them again with other colours.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Callable

import numpy as np

from ..mesh.discretize import Discretization
from ..rays.visibility import Visibility
from ..transport.direct import DirectLighting
from ..util import parallel, streams
from ..util.geometry import GOLDEN, cosine_directions, longest_edges, uniform_points
from ..util.progress import Report, quiet
from .emitters import Emitters
from .montecarlo import Surfaces

# Points per block of work on the thread pool, and more where each casts fewer rays than
# RAYS_PER_BLOCK / POINTS_PER_BLOCK (a patch's points cast one each), so that a block's rays
# outweigh its steps in Python and the threads keep busy.
POINTS_PER_BLOCK = 1 << 11
RAYS_PER_BLOCK = 1 << 17
# A ray that lands nearer than NEAR_HIT times its patch's longest edge is read by SECOND_RAYS rays
# from where it landed, or by one in a gather of more than MANY_RAYS rays, whose number averages
# their noise (the choices measured on Sponza: docs/notes/experiments.md, "A second gather where the
# rays land close").
NEAR_HIT = 0.5
SECOND_RAYS = 4
MANY_RAYS = 256
# A bounce's ray that lands nearer than DEEP_HIT times its patch's longest edge is followed by one ray
# of its own, up to NEAR_BOUNCES bounces from the gather's ray: a patch's mean misreads the light
# between surfaces millimetres apart (docs/notes/experiments.md, "Following the rays that land close
# again", which has 1 to 32 bounces and DEEP_HIT from 0.02 to 0.5).
NEAR_BOUNCES = 8
DEEP_HIT = 0.25
# The lights' light is kept at each such ray, 4 bytes per light: beyond this many lights the near
# field reads the near patches instead.
MAX_NEAR_LIGHTS = 8
# The final gather is made again at the nodes whose neighbours' gathers hold REGATHER_SHARE of the
# variance (``noisy_nodes``), with the smallest square of rays that brings a node's own to about
# REGATHER_FACTOR times the first gather's, while that square is at most REGATHER_MAX_RAYS; the two
# estimates are averaged by their rays (``regather_rays``): on Sponza, from 64 rays, most of the gain
# of 4 times the rays everywhere for half its time; from 256, 0.1 % for 20 s more (docs/notes/
# experiments.md, "An adaptive final gather"); 196 rays added to the first 64 took what 256 replacing
# them did, for 2 s less ("Sponza's time by stage; a black emitter's patches; the gather again added
# to the first").
REGATHER_SHARE = 0.9
REGATHER_FACTOR = 4
REGATHER_MAX_RAYS = 256
# A patch that fewer than SPARSE_HITS particles landed on reads its light by PATCH_RAYS rays, one from
# each of as many stratified points of it (``patch_hits``, ``patch_light``), not by its pool: on
# Sponza, against path tracing at such patches, the pools read 0.28 to 1.13 times the light on
# average, such a gather 1.01 to 1.09 (docs/notes/experiments.md, "A gather at the patches the
# particles seldom reach", which also has 4 and 16 rays; with their close landings followed, 4
# rays left the breakfast room 0.5 points worse: "The sky through a blind").
SPARSE_HITS = 32
PATCH_RAYS = 9
# The gathers' random streams (``util.streams.GATHER_RAYS`` with the seed and the block): at the
# nodes, at the nodes gathered again, at the patches.
NODE_STREAM, AGAIN_STREAM, PATCH_STREAM = 2, 3, 4
# The nodes of a vertex whose normals differ by at most POOL_ANGLE (degrees) gather together, unless
# more than POOL_NEAR_SHARE of the POOL_PROBES rays of one of them land nearer than POOL_PARALLAX
# times the nodes' distance apart: there each node sees its own few millimetres (a crevice), and
# the light changes across them. A pool holds at most POOL_SIZE nodes (a fan's apex: several).
POOL_ANGLE = 30.0
POOL_SIZE = 16
POOL_PROBES = 16
POOL_PARALLAX = 20.0
POOL_NEAR_SHARE = 0.25
# Rays times nodes weighed at once where the nodes of a vertex gather together (bounds a block's memory).
POOLED_PER_CHUNK = 1 << 20


@dataclass(frozen=True)
class Gathered:
    """light (n, C): the estimate of G = sum_j F(x, j) V_j at each point of the patches' values V
    (``GatherHits.read``); standard_error (n, C): its standard error, from the spread of the
    point's samples; near_change (n, C) or None: what reading the near rays' patches where they
    landed changed in ``light``, sum over them of (that reading - V_j) / K, or of a pool's k K rays
    weighed (``_pooled``; None: not read so)."""

    light: np.ndarray
    standard_error: np.ndarray
    near_change: np.ndarray | None = None

    @staticmethod
    def of(samples: np.ndarray) -> Gathered:
        """The mean of ``samples`` (n, k, C) over their k, with its standard error (their spread
        over sqrt(k); with one sample, its own size)."""
        count = samples.shape[1]
        mean = samples.sum(axis=1) / count
        if count == 1:
            return Gathered(mean, np.abs(samples[:, 0]))
        deviation = samples - mean[:, None]  # the spread by einsum: twice as fast as np.std
        return Gathered(mean, np.sqrt(np.einsum("nkc,nkc->nc", deviation, deviation) / (count - 1) / count))

    @staticmethod
    def on_threads(block: Callable[[int], Gathered], starts: range, channels: int, report: Report) -> Gathered:
        """``block(start)`` for each of ``starts`` on the thread pool, joined in order, each reported."""
        parts = []
        for part in parallel.map_ordered(block, starts):
            parts.append(part)
            report(len(parts) / len(starts))
        return Gathered.joined(parts, channels)

    @staticmethod
    def joined(parts: list[Gathered], channels: int) -> Gathered:
        """The estimates of ``parts`` one after another."""
        if not parts:
            return Gathered(np.zeros((0, channels)), np.zeros((0, channels)))
        changed = all(part.near_change is not None for part in parts)
        return Gathered(np.concatenate([part.light for part in parts]),
                        np.concatenate([part.standard_error for part in parts]),
                        np.concatenate([part.near_change for part in parts]) if changed else None)


def regather_rays(rays: int) -> int:
    """The rays of the gather made again at a noisy node (``noisy_nodes``): the smallest square of at
    least (REGATHER_FACTOR - 1) x ``rays``, or 0 (none made) where that is over REGATHER_MAX_RAYS."""
    more = int(np.ceil(np.sqrt((REGATHER_FACTOR - 1) * rays))) ** 2
    return more if more <= REGATHER_MAX_RAYS else 0


def check_gather_rays(count: int) -> int:
    """The strata per side for ``count`` final-gather rays, which must be a perfect square."""
    side = int(round(np.sqrt(max(count, 0))))
    if count < 1 or side * side != count:
        raise ValueError(f"Monte Carlo rays must be a perfect square (1, 4, 9, 16, ...), got {count}")
    return side


@dataclass(frozen=True)
class Bounce:
    """The rays of one bounce from where rays of the level before landed close to their patch.

    near : (m,) int32 or int64 the rays of the level before so followed (sorted flat indices into
        its rays: a gather's ``patches``, or the last bounce's).
    patches : (m, k) int32 where the k rays from each of their landing points stopped (-1: the back
        of a one-sided face or nothing, read as 0; -2: they left the scene, read as the sky).
    share : (m, k) float32 the share of those patches' emission that the rays count
        (``emitters.Emitters.met_share``; 1 where a patch emits nothing).
    lamp : (m,) int32 an emitting patch sampled from each landing point (-1: none), and
    lamp_weight : (m,) float32 its weight (``emitters.Emitters.sample``).
    light_factors : (m, L) float32 the L lights' light at each landing point, per unit of their
        intensities (one shadow ray each: ``DirectLighting.light_samples_of_block``, the same in
        every channel).
    """

    near: np.ndarray
    patches: np.ndarray
    share: np.ndarray
    lamp: np.ndarray
    lamp_weight: np.ndarray
    light_factors: np.ndarray

    @staticmethod
    def empty(rays: int, lights: int, index_type=np.int64) -> Bounce:
        """A bounce of ``rays`` rays per ray followed, with ``lights`` lights, that follows none."""
        return Bounce(np.zeros(0, index_type), np.zeros((0, rays), np.int32), np.zeros((0, rays), np.float32),
                      np.zeros(0, np.int32), np.zeros(0, np.float32), np.zeros((0, lights), np.float32))

    @staticmethod
    def joined(parts: list[Bounce], before: list[int]) -> Bounce:
        """``parts`` of consecutive blocks one after another, each one's ``near`` moved on by the
        rays of the level before in the blocks before it (``before``, one count per part)."""
        offsets = np.cumsum([0] + before[:-1])
        near = np.concatenate([part.near + offset for part, offset in zip(parts, offsets)])
        return Bounce(near, *(np.concatenate([getattr(part, name) for part in parts])
                              for name in ("patches", "share", "lamp", "lamp_weight", "light_factors")))


@dataclass(frozen=True)
class GatherHits:
    """Where the rays of a final gather landed (``gather_hits``), to be read with any colours.

    patches : (n, K) int32 the patch each ray of each point stopped at (-1: none), the points in
        the order ``order``.
    bounces : the ``Bounce`` of the rays followed from where these landed close, then from where
        those landed close, and so on (empty where none are: ``gather_hits``'s ``near``).
    blocks : (b + 1,) the first row of each block of work, and n.
    order : (n,) the points as given of the rows (None: as given).
    pools, normals, stream : where points gather together, the pool of each row (n,) (rows of one
        pool are consecutive, in one block), its normal (n, 3), and the seed, stream and first
        index of the rays' random numbers, from which their directions are made again
        (``_ray_points``); None where each gathers alone.
    mean_distance : (n,) the harmonic mean of the distances each point's rays went to the surfaces
        they met, the points as given (inf where none met one): how far off what it sees lies (Ward,
        Rubinstein and Clear 1988), or None.
    """

    patches: np.ndarray
    bounces: tuple[Bounce, ...] = ()
    blocks: np.ndarray | None = None
    order: np.ndarray | None = None
    pools: np.ndarray | None = None
    normals: np.ndarray | None = None
    stream: tuple[int, int, int] | None = None
    mean_distance: np.ndarray | None = None

    def read(self, far: np.ndarray, opacity: np.ndarray | None = None, own: np.ndarray | None = None,
             reflectance: np.ndarray | None = None, radiosity: np.ndarray | None = None,
             emission: np.ndarray | None = None, sky: np.ndarray | None = None,
             lights: np.ndarray | None = None) -> Gathered:
        """The estimate at each point of the light arriving from the patches, with its standard
        error. A ray that stopped at j far from the point reads ``far`` (P, C); a ray followed by a
        bounce (``near``) reads where it landed

            own_j + rho_j A,   A = mean_k R_k + w E_lamp + sum_l f_l I_l,

        ``own`` (P, C) what j gives beyond the light it reflects from the surfaces, the sky and the
        lights, ``reflectance`` rho (P, C), w E of the emitter sampled and the lights'
        ``light_factors`` f_l at their intensities ``lights`` I (L, C) (None: no lights). The
        bounce's ray k that met patch q counts the share s_k of its emission E (``emission``,
        (P, C)) and reads R_k = B_q - (1 - s_k) E_q of ``radiosity`` B (P, C), or where it landed,
        if it is followed in turn, s_k E_q + rho_q A' (A' that of the next bounce), or ``sky``
        (C,) (None: none) where it left the scene. What that changes at each point is its
        ``near_change``. What a ray reads at a patch counts 1 / ``opacity`` (P,) there (None: all
        1): it stopped there with that chance (``Surfaces.hit``). Points that gather together
        (``pools``) each weigh the rays of all (the module's docstring)."""
        if self.bounces and len(self.bounces[0].near) and any(
                value is None for value in (own, reflectance, radiosity, emission)):
            raise ValueError("rays read where they landed need own, reflectance, radiosity and emission")
        far = _padded(far, opacity)
        if self.bounces:
            own, scale = _padded(own, opacity), _padded(reflectance, opacity)
            open_sky = np.zeros(far.shape[1]) if sky is None else sky
            second = _padded(radiosity, opacity, open_sky)
            emitted, lamps = _padded(emission, opacity, np.zeros_like(open_sky)), _padded(emission, None)
        rays = self.patches.shape[1]

        def arriving_at_bounces(low: int, high: int) -> tuple[np.ndarray, tuple[int, int]]:
            """For the gather's flat rays ``low:high``: the span ``first:last`` of the first
            bounce's ``near`` that follows some of them, and A (last - first, C) where each of
            those landed, read from the last bounce up."""
            spans = []
            for bounce in self.bounces:
                # bounds of near's dtype: a list would be int64, and near (int32) copied to match at every call
                first, last = np.searchsorted(bounce.near, np.array([low, high], dtype=bounce.near.dtype))
                spans.append((first, last))
                low, high = first * bounce.patches.shape[1], last * bounce.patches.shape[1]
            arriving = None
            for depth in reversed(range(len(self.bounces))):
                bounce, (first, last) = self.bounces[depth], spans[depth]
                met = bounce.patches[first:last]
                share = bounce.share[first:last].astype(np.float64)
                values = np.take(second, met, axis=0)  # as second[met], several times faster
                shining = np.nonzero(share < 1)  # rays that met an emitter (elsewhere the share is 1)
                values[shining] -= (1 - share[shining])[:, None] * emitted[met[shining]]
                if arriving is not None and len(arriving):  # the rays followed by the next bounce
                    deeper, (after, until) = self.bounces[depth + 1], spans[depth + 1]
                    followed = deeper.near[after:until] - first * met.shape[1]
                    patch = met.reshape(-1)[followed]
                    values.reshape(-1, values.shape[2])[followed] = \
                        share.reshape(-1)[followed, None] * emitted[patch] + scale[patch] * arriving
                arriving = _mean_of_rays(values) + bounce.lamp_weight[first:last, None] * lamps[bounce.lamp[first:last]]
                if lights is not None and len(lights):
                    arriving += bounce.light_factors[first:last].astype(np.float64) @ lights
            return arriving, spans[0]

        blocks = _block_starts(len(self.patches)) if self.blocks is None else self.blocks

        def block(index: int) -> Gathered:
            start, stop = blocks[index], blocks[index + 1]
            hits = self.patches[start:stop]
            samples = np.take(far, hits, axis=0)  # as far[hits], several times faster
            changes = np.zeros_like(samples)  # what reading where each ray landed changed
            if self.bounces:
                arriving, (first, last) = arriving_at_bounces(start * rays, stop * rays)
            if self.bounces and last > first:
                ray = self.bounces[0].near[first:last] - start * rays
                patch = hits.reshape(-1)[ray]
                reading = own[patch] + scale[patch] * arriving
                changes.reshape(-1, samples.shape[2])[ray] = reading - far[patch]
                samples.reshape(-1, samples.shape[2])[ray] = reading
            if self.pools is None:
                return replace(Gathered.of(samples), near_change=changes.mean(axis=1) if self.bounces else None)
            seed, stream, first = self.stream
            points, _ = _ray_points(seed, stream, first + start, stop - start, rays)
            pooled = _pooled(self.pools[start:stop], self.normals[start:stop], points, samples, changes)
            return pooled if self.bounces else replace(pooled, near_change=None)

        parts = list(parallel.map_ordered(block, range(len(blocks) - 1)))
        gathered = Gathered.joined(parts, far.shape[1])
        if self.order is None:
            return gathered
        return Gathered(*(None if rows is None else _unsorted(rows, self.order)
                          for rows in (gathered.light, gathered.standard_error, gathered.near_change)))


def _mean_of_rays(values: np.ndarray) -> np.ndarray:
    """(m, C) the mean over the k (few) rays of ``values`` (m, k, C), summed ray by ray: several
    times faster than ``mean(axis=1)`` over so short an axis."""
    total = values[:, 0].copy()
    for ray in range(1, values.shape[1]):
        total += values[:, ray]
    return total / values.shape[1]


def _pooled(pools: np.ndarray, normals: np.ndarray, uv: np.ndarray, samples: np.ndarray,
            changes: np.ndarray) -> Gathered:
    """The estimates of consecutive points that gather together (the module's docstring): the
    rows of one ``pools`` (m,) label each weigh every ray of all, by the balance heuristic of their
    ``normals`` (m, 3) over the rays' directions (from their points ``uv`` (m, K, 2) of the unit
    square), the ``samples`` V (m, K, C) read there: G_i = sum_r w_i V_r / (k K), with the
    standard error of that mean, SE^2 = (sum_r w_i^2 V_r^2 - k K G_i^2) / ((k K - 1) k K), and,
    as ``near_change``, the ``changes`` (m, K, C) that reading where they landed made, weighed alike."""
    count, rays, channels = samples.shape
    starts = np.flatnonzero(np.r_[True, pools[1:] != pools[:-1]])
    sizes = np.diff(np.r_[starts, count])
    light, error, change = (np.empty((count, channels)) for _ in range(3))
    for size in np.unique(sizes):
        groups = starts[sizes == size]
        per_chunk = max(1, POOLED_PER_CHUNK // (size * size * rays))
        for first in range(0, len(groups), per_chunk):
            members = (groups[first:first + per_chunk, None] + np.arange(size)).ravel()
            if size == 1:
                alone = Gathered.of(samples[members])
                light[members], error[members] = alone.light, alone.standard_error
                change[members] = changes[members].mean(axis=1)
                continue
            directions = cosine_directions(normals[members], uv[members])
            directions = directions.reshape(-1, size * rays, 3)  # (g, k K, 3): a pool's rays
            cosines = np.maximum(np.einsum("gix,grx->gir", normals[members].reshape(-1, size, 3), directions), 0)
            weight = cosines / cosines.mean(axis=1, keepdims=True)  # (g, k, k K); each ray is above its own plane
            total = size * rays
            read = samples[members].reshape(-1, total, channels)  # (g, k K, C)
            mean = np.matmul(weight, read).reshape(-1, channels) / total
            squares = np.matmul(weight * weight, read * read).reshape(-1, channels)
            light[members] = mean
            error[members] = np.sqrt(np.maximum(squares - total * mean ** 2, 0) / (total - 1) / total)
            changed = np.matmul(weight, changes[members].reshape(-1, total, channels))
            change[members] = changed.reshape(-1, channels) / total
    return Gathered(light, error, change)


def _ray_points(seed: int, stream: int, index: int, count: int, rays: int) -> tuple[np.ndarray, np.random.Generator]:
    """(count, rays, 2) the points of the unit square of the cosine-distributed directions of a
    block of ``count`` points' ``rays`` rays (a perfect square), one in each of their congruent
    squares (jittered strata), the first numbers of the block's random stream (``seed``,
    ``stream``, ``index`` of its first point), and that stream, to draw the rest from."""
    rng = streams.generator(seed, streams.GATHER_RAYS, stream, index)
    cells, side = _strata(rays)
    return cells[None] + rng.random((count, rays, 2)) / side, rng


def _unsorted(rows: np.ndarray, order: np.ndarray) -> np.ndarray:
    """``rows`` (n, ...) of the points ``order`` (n,) back in the points' own order."""
    result = np.empty_like(rows)
    result[order] = rows
    return result


def _block_starts(count: int, pools: np.ndarray | None = None, rays: int = RAYS_PER_BLOCK) -> np.ndarray:
    """(b + 1,) the first point of each block of about max(POINTS_PER_BLOCK, RAYS_PER_BLOCK / ``rays``)
    of ``count`` points of ``rays`` rays each, and ``count``; with ``pools`` (count,) sorted labels,
    each block starting where a pool does."""
    starts = np.arange(0, count, max(POINTS_PER_BLOCK, RAYS_PER_BLOCK // max(rays, 1)))
    if pools is not None and count:
        pool_starts = np.flatnonzero(np.r_[True, pools[1:] != pools[:-1]])
        found = np.searchsorted(pool_starts, starts)
        starts = np.unique(pool_starts[found[found < len(pool_starts)]])
    return np.r_[starts, count].astype(np.int64)


def _padded(values: np.ndarray, opacity: np.ndarray | None, outside: np.ndarray | None = None) -> np.ndarray:
    """``values`` (P, C) over ``opacity`` (P,) (None: 1), read at index -1 (no patch) as 0 and,
    with ``outside`` (C,), at -2 (out of the scene) as that: (P + 1, C) or (P + 2, C)."""
    if opacity is not None:
        values = np.divide(values, opacity[:, None], out=np.zeros_like(values), where=opacity[:, None] > 0)
    rows = [values] + ([] if outside is None else [outside[None]]) + [np.zeros((1, values.shape[1]))]
    return np.concatenate(rows)


def gather_hits(mesh: Discretization, visibility: Visibility, points: np.ndarray, normals: np.ndarray,
                rays: int, seed: int = 0, report: Report = quiet, stream: int = NODE_STREAM,
                near: bool = True, lights: DirectLighting | None = None, first: int = 0,
                pools: np.ndarray | None = None, second_rays: int | None = None,
                distances: bool = False) -> GatherHits:
    """Where ``rays`` (a perfect square) cosine-distributed rays from each of ``points`` (n, 3)
    facing unit ``normals`` (n, 3) stop (from one uniform point in each of the rays congruent
    squares of the unit square: jittered strata; through see-through surfaces by chance,
    ``Surfaces.hit``), and with ``near``, the ``Bounce`` from where each that landed nearer than
    NEAR_HIT times its patch's longest edge did: ``second_rays`` rays of its own (None: SECOND_RAYS,
    one beyond MANY_RAYS rays), an emitting patch sampled (``emitters``) and the light of
    ``lights``' lights there; then the bounce of one ray from where each of those landed nearer
    than DEEP_HIT times its patch's longest edge, and so on, NEAR_BOUNCES bounces at most.
    ``stream``: the random numbers' (``NODE_STREAM``, ``AGAIN_STREAM`` for points gathered a second
    time: ``noisy_nodes``, ``PATCH_STREAM``), drawn per block of points from the index of its
    first, ``first`` that of ``points[0]``. Points of one ``pools`` (n,) label (the nodes of one
    vertex: ``node_pools``; None: none) gather together (the module's docstring); the points are
    then taken in the order of their labels, and a block's index is its first's in that order.
    With ``distances``, the hits keep each point's ``GatherHits.mean_distance``."""
    order = None
    if pools is not None:
        order = np.argsort(pools, kind="stable")
        points, normals, pools = points[order], normals[order], pools[order]
    blocks = _block_starts(len(points), pools, rays)
    surfaces, emitters = Surfaces(mesh, visibility), Emitters(mesh)
    edges = longest_edges(mesh.patch_corners)
    reach, deep_reach = NEAR_HIT * edges, DEEP_HIT * edges
    if second_rays is None:
        second_rays = SECOND_RAYS if rays <= MANY_RAYS else 1
    index_type = np.int32 if second_rays * len(points) * rays <= np.iinfo(np.int32).max else np.int64
    light_count = 0 if lights is None else len(lights.lights)
    depth = NEAR_BOUNCES if near else 0
    followers = [second_rays] + [1] * (depth - 1)  # each bounce's rays per ray

    def block(index: int) -> tuple[np.ndarray, list[Bounce], np.ndarray | None]:
        start = blocks[index]
        chosen = slice(start, blocks[index + 1])
        count = len(points[chosen])
        uv, rng = _ray_points(seed, stream, first + start, count, rays)
        directions = cosine_directions(normals[chosen], uv)
        origins = np.repeat(points[chosen], rays, axis=0)
        patch, landed = surfaces.hit(origins, directions.reshape(-1, 3), np.repeat(normals[chosen], rays, axis=0),
                                     rng)
        patches, bounces, offset = patch.astype(np.int32).reshape(count, rays), [], start * rays
        point_distance = None
        if distances:
            went = landed - origins
            point_distance = _harmonic_mean(np.sqrt(np.einsum("ij,ij->i", went, went)), patch >= 0, count)
        for level in range(depth):
            went = landed - origins
            distance = np.sqrt(np.einsum("ij,ij->i", went, went))  # faster than np.linalg.norm on rows of 3
            limit = (reach if level == 0 else deep_reach)[np.maximum(patch, 0)]
            close = np.flatnonzero((patch >= 0) & (distance < limit))
            bounce, origins, patch, landed = _bounce(surfaces, emitters, lights, landed[close], patch[close],
                                                     followers[level], rng,
                                                     (streams.BOUNCES, stream, first + start, level),
                                                     close // rays if level == 0 else None)
            bounces.append(replace(bounce, near=(close + offset).astype(index_type)))
            offset = 0  # the deeper bounces' are moved on when the blocks are joined
        return patches, bounces, point_distance

    parts = []
    for done, part in enumerate(parallel.map_ordered(block, range(len(blocks) - 1)), 1):
        parts.append(part)
        report(done / (len(blocks) - 1))
    patches = np.concatenate([part[0] for part in parts]) if parts else np.zeros((0, rays), np.int32)
    bounces = []
    for level in range(depth):
        levels = [part[1][level] for part in parts] or [Bounce.empty(followers[level], light_count, index_type)]
        before = [0] * len(levels) if level == 0 else [len(part[1][level - 1].patches.reshape(-1)) for part in parts]
        bounces.append(Bounce.joined(levels, before))
    point_distance = None
    if distances:
        point_distance = np.concatenate([part[2] for part in parts]) if parts else np.zeros(0)
    if pools is None:
        return GatherHits(patches, tuple(bounces), blocks, mean_distance=point_distance)
    return GatherHits(patches, tuple(bounces), blocks, order, pools, normals, (seed, stream, first),
                      None if point_distance is None else _unsorted(point_distance, order))


def _harmonic_mean(distance: np.ndarray, met: np.ndarray, count: int) -> np.ndarray:
    """(count,) the harmonic mean of each point's rays' ``distance`` (count x rays,) over those that
    ``met`` a surface (inf where none did)."""
    nearness = np.divide(1.0, distance, out=np.zeros_like(distance), where=met & (distance > 0))
    mean_nearness = nearness.reshape(count, -1).mean(axis=1)
    return np.divide(1.0, mean_nearness, out=np.full(count, np.inf), where=mean_nearness > 0)


def _bounce(surfaces: Surfaces, emitters: Emitters, lights: DirectLighting | None, at: np.ndarray,
            patches: np.ndarray, rays: int, rng: np.random.Generator, light_key: tuple[int, ...],
            groups: np.ndarray | None = None) -> tuple[Bounce, np.ndarray, np.ndarray, np.ndarray]:
    """The ``Bounce`` (its ``near`` left empty) of ``rays`` (a perfect square) stratified
    cosine-distributed rays from each of the points ``at`` (m, 3) on ``patches`` (m,), on the side
    that faces back along the ray that landed there; and the rays' origins (m k, 3), the patch each
    stopped at (m k,: -1 none, -2 out of the scene) and where (m k, 3). ``light_key``: the lights'
    random stream (``DirectLighting.light_samples_of_block``). ``groups`` (m,) sorted labels: the
    rays of the points of one are drawn together (``_lattice_points``; None: each point's in its
    own strata)."""
    facing = surfaces.mesh.patch_normals[patches]
    lamp, lamp_weight = emitters.sample(surfaces.visibility, at, facing, rng, rays)
    origins, normals = np.repeat(at, rays, axis=0), np.repeat(facing, rays, axis=0)
    met, landed, share = np.zeros(0, np.int64), np.zeros((0, 3)), np.ones(0)
    if len(at):
        if groups is None:
            cells, side = _strata(rays)
            uv = cells[None] + rng.random((len(at), rays, 2)) / side
        else:
            uv = _lattice_points(groups, rays, rng)
        met, landed = surfaces.hit_or_sky(origins, cosine_directions(facing, uv).reshape(-1, 3), normals, rng)
        share = emitters.met_share(origins, normals, met, landed, rays)
    light_count = 0 if lights is None else len(lights.lights)
    factors = np.zeros((len(at), light_count), np.float32)
    if len(at) and light_count:
        factors = lights.light_samples_of_block(at, facing, light_key)[:, :, 0].astype(np.float32)
    bounce = Bounce(np.zeros(0, np.int64), met.astype(np.int32).reshape(len(at), rays),
                    share.astype(np.float32).reshape(len(at), rays), lamp.astype(np.int32),
                    lamp_weight.astype(np.float32), factors)
    return bounce, origins, met, landed


def _lattice_points(groups: np.ndarray, rays: int, rng: np.random.Generator) -> np.ndarray:
    """(m, k) points of the unit square for k = ``rays`` rays from each of m points, those of one
    label of ``groups`` (m,), sorted, drawn together: the T = c k rays of a group of c points are
    the rank-1 lattice ((i + 1/2) / T, i phi) mod 1, phi = (sqrt(5) - 1) / 2, shifted by one
    uniform vector per group (a Cranley-Patterson rotation: each point is uniform, and together
    they are spread as evenly as strata), point r's rays the i = j c + r, j < k, one in each k-th
    of the first coordinate (of the radius, ``cosine_directions``)."""
    starts = np.flatnonzero(np.r_[True, groups[1:] != groups[:-1]])
    sizes = np.diff(np.r_[starts, len(groups)])
    group = np.repeat(np.arange(len(starts)), sizes)
    size, rank = sizes[group][:, None], (np.arange(len(groups)) - starts[group])[:, None]
    index = np.arange(rays)[None] * size + rank  # (m, k)
    shift = rng.random((len(starts), 2))[group]
    return np.stack([((index + 0.5) / (size * rays) + shift[:, None, 0]) % 1.0,
                     (index * GOLDEN + shift[:, None, 1]) % 1.0], axis=2)


def _strata(count: int) -> tuple[np.ndarray, int]:
    """(K, 2) the lower corners of the K = ``count`` (a perfect square) congruent squares of the
    unit square that jittered samples are drawn in, and the squares per side."""
    side = check_gather_rays(count)
    return np.stack(np.divmod(np.arange(count), side), axis=1) / side, side


def gather(mesh: Discretization, visibility: Visibility, points: np.ndarray, normals: np.ndarray,
           values: np.ndarray, rays: int, seed: int = 0, report: Report = quiet) -> Gathered:
    """The final gather of patch ``values`` (P, C) at ``points`` (n, 3) facing unit ``normals``
    (n, 3), each patch read as its value (no second rays): sum_j F(x, j) values_j."""
    return gather_hits(mesh, visibility, points, normals, rays, seed, report, near=False).read(
        values, mesh.patch_opacity)


def patch_hits(mesh: Discretization, visibility: Visibility, patches: np.ndarray, rays: int = PATCH_RAYS,
               seed: int = 0, report: Report = quiet, near: bool = True,
               lights: DirectLighting | None = None) -> GatherHits:
    """Where one cosine-distributed ray from each of ``rays`` (a perfect square) jittered stratified
    points of each of ``patches`` (k,) stopped (``gather_hits`` of the k x rays points, patch by
    patch), and with ``near`` the bounces from where those landed close, of one ray each
    (``lights`` as for ``gather_hits``): read by ``patch_light``."""
    cells, side = _strata(rays)
    rng = streams.generator(seed, streams.PATCH_GATHER_POINTS)
    uv = cells[None] + rng.random((len(patches), rays, 2)) / side
    # broadcast, not np.repeat, which holds the GIL while it copies (0.1 s on the breakfast room's
    # 312,000 patches: the bake's caller heard nothing meanwhile)
    points = uniform_points(mesh.patch_corners[patches][:, None], uv).reshape(-1, 3)
    normals = np.broadcast_to(mesh.patch_normals[patches][:, None], (len(patches), rays, 3)).reshape(-1, 3)
    return gather_hits(mesh, visibility, points, normals, 1, seed, report, stream=PATCH_STREAM, near=near,
                       lights=lights, second_rays=1)


def patch_light(hits: GatherHits, rays: int, **read) -> np.ndarray:
    """(k, C) the light arriving over each of the k patches of ``patch_hits``' ``hits`` (``rays``
    points each): sum_q F(p, q) X_q, the mean over its points of ``GatherHits.read`` with ``read``
    (far: X; where rays landed close, as the final gather reads them)."""
    light = hits.read(**read).light
    return light.reshape(-1, rays, light.shape[1]).mean(axis=1)


def pools_of(vertex: np.ndarray, normals: np.ndarray, max_angle: float = POOL_ANGLE) -> np.ndarray:
    """(N,) the pool each node gathers in: nodes of one ``vertex`` (N,) whose unit ``normals``
    (N, 3) lie within ``max_angle`` (degrees) of the first such node's (by index), which labels it,
    POOL_SIZE at most (the next ones a pool of their own, labelled by its first)."""
    labels = np.full(len(vertex), -1)
    order = np.argsort(vertex, kind="stable")
    limit = np.cos(np.radians(max_angle))
    while (left := order[labels[order] < 0]).size:
        first = np.r_[True, vertex[left][1:] != vertex[left][:-1]]
        lead = left[first][np.cumsum(first) - 1]  # the first node left at each vertex
        near = (np.einsum("ij,ij->i", normals[left], normals[lead]) >= limit) | first
        labels[left[near]] = lead[near]
    # at most POOL_SIZE nodes a pool: the rest of a large one in pools of their own, in order
    by_pool = np.argsort(labels, kind="stable")
    starts = np.r_[True, labels[by_pool][1:] != labels[by_pool][:-1]]
    leads = (np.arange(len(by_pool)) - np.flatnonzero(starts)[np.cumsum(starts) - 1]) % POOL_SIZE == 0
    labels[by_pool] = by_pool[leads][np.cumsum(leads) - 1]
    return labels


def pooled(labels: np.ndarray) -> np.ndarray:
    """(N,) bool: the nodes whose pool (``labels`` (N,), ``pools_of``) holds others too."""
    return np.bincount(labels, minlength=len(labels))[labels] > 1


def node_pools(mesh: Discretization, visibility: Visibility, seed: int = 0) -> np.ndarray | None:
    """(N,) the pool each node gathers in (``pools_of``), each node alone in a pool where POOL_PROBES
    stratified cosine-distributed rays of one of its nodes find a surface near (the constants'
    comment); None without ``Discretization.node_vertex``."""
    if mesh.node_vertex is None:
        return None
    labels = pools_of(mesh.node_vertex, mesh.node_normals)
    shared = np.flatnonzero(pooled(labels))
    if not len(shared):
        return labels
    apart = np.zeros(len(labels))  # an upper bound of the distance between the nodes of each pool
    np.maximum.at(apart, labels[shared], 2 * np.linalg.norm(mesh.node_points[shared] - mesh.node_points[labels[shared]],
                                                            axis=1))
    reach = POOL_PARALLAX * apart[labels[shared]]
    surfaces, (cells, side) = Surfaces(mesh, visibility), _strata(POOL_PROBES)

    def near_share(start: int) -> np.ndarray:
        """The share of the probes of nodes ``shared[start:start + POINTS_PER_BLOCK]`` that land
        within their ``reach``."""
        chosen = slice(start, start + POINTS_PER_BLOCK)
        points, normals = mesh.node_points[shared[chosen]], mesh.node_normals[shared[chosen]]
        rng = streams.generator(seed, streams.POOL_PROBES, start)
        directions = cosine_directions(normals, cells[None] + rng.random((len(points), POOL_PROBES, 2)) / side)
        origins = np.repeat(points, POOL_PROBES, axis=0)
        lift = np.repeat(normals, POOL_PROBES, axis=0)
        patch, landed = surfaces.hit_or_sky(origins, directions.reshape(-1, 3), lift, None)
        went = landed - origins  # -2: no surface met (-1, the back of a one-sided face, counts)
        near = (patch != -2) & (np.einsum("ij,ij->i", went, went) < np.repeat(reach[chosen], POOL_PROBES) ** 2)
        return near.reshape(-1, POOL_PROBES).mean(axis=1)

    shares = np.concatenate(list(parallel.map_ordered(near_share, range(0, len(shared), POINTS_PER_BLOCK))))
    alone = np.isin(labels, labels[shared[shares > POOL_NEAR_SHARE]])
    labels[alone] = np.flatnonzero(alone)
    return labels


def noisy_nodes(variance: np.ndarray, corner_node: np.ndarray, share: float = REGATHER_SHARE) -> np.ndarray:
    """(k,) sorted indices of the nodes whose final gather is made again: the fewest whose predicted
    variances hold ``share`` of their sum, a node's prediction the mean ``variance`` (N,) of the
    nodes it shares a triangle with (``corner_node`` (T, 3), -1 none), or its own if it has none.
    Not its own otherwise: a node whose samples happened to agree (no ray met a rare bright patch)
    would be left out, and the nodes left out would read dark on average; chosen by its
    neighbours, a node's estimate, first or second, is unbiased."""
    nodes = len(variance)
    whole = corner_node[(corner_node >= 0).all(axis=1)].astype(np.int64)
    node, other = whole.ravel(), np.roll(whole, 1, axis=1).ravel()  # each triangle's edges
    pairs = np.unique(np.concatenate([node * nodes + other, other * nodes + node]))  # both ways, once
    node, other = np.divmod(pairs, nodes)
    node, other = node[node != other], other[node != other]
    count = np.bincount(node, minlength=nodes)
    summed = np.bincount(node, variance[other], minlength=nodes)
    predicted = np.where(count > 0, summed / np.maximum(count, 1), variance)
    total = predicted.sum()
    if total <= 0 or share <= 0:
        return np.zeros(0, dtype=np.int64)
    order = np.argsort(-predicted, kind="stable")
    held = np.cumsum(predicted[order]) / total
    return np.sort(order[: min(np.searchsorted(held, share) + 1, len(order))])
