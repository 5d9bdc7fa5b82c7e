"""Monte Carlo transport of the light that progressive refinement has not shot: for scenes too
large to shoot to convergence, where every shot costs a form factor at every receiver.

After the shots, patch q still holds unshot radiosity U_q. What it will add, with all its later
bounces, is X = U + rho F X. ``trace`` estimates X on the patches by particle tracing (the
collision estimator of stochastic radiosity: Pattanaik and Mudur 1993; Bekaert, "Hierarchical and
stochastic algorithms for radiosity", 1999, ch. 4): N particles leave the patches, patch q
chosen with probability p_q proportional to A_q sum_c |U_q,c| (systematically, so each patch gets
within one of N p_q; or mixed with the final gather's view importance, ``view_importance``, so
that light that never reaches what the gather reads, as the sky's on a room's outside walls,
sends few particles), from a uniform point, in a cosine-distributed direction, each carrying the
power A_q U_q / (N p_q); a particle drawn inside a solid or a pocket that passes through q, on
the far side from where q received its light, is absorbed there (``_same_side``). The expected
power reaching j from unit power leaving q is F_qj, and A_q F_qj = A_j F_jq, so
X_j = U_j + rho_j W_j / A_j with W_j the power that arrives at j; the particle goes on with the
weight rho_j w / s_j with probability s_j = max_c rho_j,c (Russian roulette), else stops. W / A
is read over pools of neighbouring patches that face the same way, lie in one layer and on the
same side of their triangles (``pools``), each holding MIN_HITS particles' hits: unbiased over
the pool, a pool's noise about 1 / sqrt(MIN_HITS) and falling as particles are added (pools
shrink).

The paths (``trace_paths``) are kept apart from the colours that weight them
(``ParticlePaths.future``), so that a re-solve with other reflectances or other unshot light reads
them again instead of tracing (importance sampling of the paths: ``ParticlePaths.reusable``).

The final gather (``gather``) then reads X where colours are evaluated.

Rays go through ``Visibility.nearest``, whose triangles must be the mesh's front patches (index
p is patch p); a ray meeting a front patch from behind lands on its back patch
(``Discretization.back_of_front``), on a face lying over it that faces the ray (a card of two
one-sided faces), or nowhere.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..mesh.discretize import Discretization
from ..rays.visibility import MAX_LAYERS, RAY_EPSILON, Visibility
from ..util import parallel, rows, streams
from ..util.geometry import barycentric, cosine_directions, uniform_points
from ..util.progress import Report, quiet
from ..util.spatial import ranks, runs

# Particles per block of work on the thread pool.
PARTICLES_PER_BLOCK = 1 << 15
# Particles a pool of ``pools`` must receive, and its layers' depth (LAYERS_PER_CELL per spacing):
# more hits per pool blur more and were no better on the benchmark scenes (docs/notes/experiments.md).
MIN_HITS = 8
LAYERS_PER_CELL = 4
# Particles per patch per final-gather ray (``bake``'s monte_carlo_rays), and at least
# MIN_PARTICLES_PER_PATCH (``particle_count``): the patches' noise and the gather's fall together as
# the rays grow (tests/core/test_montecarlo.py), but in a room lit through its windows the gather of
# a vertex in a crevice (a cup's foot on its saucer) reads a few small patches, whose noise is its
# error, however few its rays (docs/notes/experiments.md, "Where the breakfast room's error is").
# Sent where the gather reads (``view_importance``), 8 per patch did as well as 16 in less time
# (docs/notes/experiments.md, "Particles sent where the final gather reads").
PARTICLES_PER_RAY = 1 / 16
MIN_PARTICLES_PER_PATCH = 8
# With a view importance (``view_importance``), this share of the particles is sent by power alone
# and the rest by power times its root (``_sampling``): a defensive mixture, so that every source of
# light sends at least this share of what it would by power (its variance at most 1 / POWER_SHARE times).
POWER_SHARE = 0.5
# Importons (``view_importance``) per particle: the importance only steers where particles leave.
IMPORTONS_PER_PARTICLE = 1 / 16
# Bounces an importon takes at most: Z is then the importance of paths of that many bounces. In the
# breakfast room's pockets of reflectance 0.999 a few importons bounced 3,000 to 4,000 times, a
# handful at a time on one thread (the GIL), 3.2 s of a 60 s bake; at 64 the tracing takes 0.8 s
# and the error from path tracing at seeds 0 to 7 moved by -0.34 +- 0.33 points
# (docs/notes/experiments.md, "Importons' paths cut short").
IMPORTON_BOUNCES = 64
# Paths traced for other colours are read again (``ParticlePaths.reusable``) while the second moment
# of the power their particles carry is at most this times that of particles traced for the colours
# (so the noise at most sqrt(1.25) = 1.12 times; tests/core/test_session.py measures it).
REUSE_MOMENT = 1.25


class Surfaces:
    """Where the rays of ``trace`` and the final gather (``gather``) land: the patch hit, on the
    side hit."""

    def __init__(self, mesh: Discretization, visibility: Visibility) -> None:
        front = mesh.front_patch_count
        if len(visibility.triangle_normals) != front:
            raise ValueError(f"the rays' triangles must be the {front} front patches, "
                             f"got {len(visibility.triangle_normals)}")
        self.mesh, self.visibility = mesh, visibility
        self._normals = mesh.patch_normals[:front]
        self._offsets = (self._normals * mesh.patch_corners[:front, 0]).sum(axis=1)
        first, second = visibility.coplanar_pairs
        order = np.argsort(first, kind="stable")
        self._partners = second[order]
        self._partner_start = np.searchsorted(first[order], np.arange(front + 1))

    def hit(self, origins: np.ndarray, directions: np.ndarray, lift: np.ndarray,
            rng: np.random.Generator | None = None) -> tuple[np.ndarray, np.ndarray]:
        """The patch each ray meets first (-1: none, or the back of a one-sided surface) and the
        point (n, 3) where it meets its plane. Of coincident faces (a card made of two one-sided
        faces back to back) the ray lands on one that faces it, whichever the tracer returned.
        With ``rng``, a ray goes on through a see-through surface (either side) with the chance
        1 - its opacity, up to MAX_LAYERS times: it so stops at patch j with the chance opacity_j
        of all that reaches it, and what it reads or brings there counts 1 / opacity_j
        (``gather``, ``trace``)."""
        patch, points, _ = self._traced(origins, directions, lift, rng)
        return patch, points

    def hit_or_sky(self, origins: np.ndarray, directions: np.ndarray, lift: np.ndarray,
                   rng: np.random.Generator | None) -> tuple[np.ndarray, np.ndarray]:
        """``hit``, the patch -2 where the ray met no surface at all (it leaves the scene, to the sky)."""
        patch, points, front = self._traced(origins, directions, lift, rng)
        patch[front < 0] = -2
        return patch, points

    def _traced(self, origins: np.ndarray, directions: np.ndarray, lift: np.ndarray,
                rng: np.random.Generator | None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``hit``'s patches and points, and the front triangle each ray last met (-1: none). The
        rays are drawn at random (the particles', the gathers'): ``Visibility`` traces them as
        ``jittered``."""
        front = self.visibility.nearest(origins, directions, lift, jittered=True)
        patch, points = self._landing(origins, directions, front)
        if rng is None or not self.visibility.see_through:
            return patch, points, front
        deciding = np.flatnonzero(front >= 0)  # rays at a surface, to stop there or go on
        for _ in range(MAX_LAYERS):
            crossing = deciding[rng.random(len(deciding)) >= self.visibility.opacity[front[deciding]]]
            if len(crossing) == 0:
                break
            going = directions[crossing]
            front[crossing] = self.visibility.nearest(points[crossing], going, going, jittered=True)
            patch[crossing], points[crossing] = self._landing(points[crossing], going, front[crossing])
            deciding = crossing[front[crossing] >= 0]
        return patch, points, front

    def opaque_hit(self, origins: np.ndarray, directions: np.ndarray,
                   lift: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``hit`` without ``rng`` (every surface stops the ray), and (n,) bool: whether each ray
        met no surface at all (it leaves the scene, to the sky)."""
        patch, points, front = self._traced(origins, directions, lift, None)
        return patch, points, front < 0

    def _landing(self, origins: np.ndarray, directions: np.ndarray,
                 front: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``hit``'s patches and points for the front triangles ``front`` the rays met."""
        hit = front >= 0
        index = np.maximum(front, 0)
        normals = np.take(self._normals, index, axis=0)  # rows: several times faster than self._normals[index]
        facing = np.einsum("ij,ij->i", directions, normals)
        patch = np.where(facing < 0, front, self.mesh.back_of_front[index])
        patch[~hit] = -1
        # the ray's parameter at the hit triangle's plane (not parallel to it, since it met it)
        slope = np.where(np.abs(facing) > 1e-12, facing, 1e-12)
        distance = (self._offsets[index] - np.einsum("ij,ij->i", origins, normals)) / slope
        points = origins + np.maximum(distance, 0.0)[:, None] * directions
        behind = np.flatnonzero(hit & (patch < 0) & self.visibility.coplanar_overlaps[index])
        if len(behind):
            patch[behind] = self._coincident(index[behind], points[behind], directions[behind])
        return patch, points

    def _coincident(self, triangles: np.ndarray, points: np.ndarray, directions: np.ndarray) -> np.ndarray:
        """For rays that met the back of one-sided ``triangles`` at ``points``: the patch of a
        face lying over it there (``Visibility.coplanar_pairs``) on the side facing the ray, or -1."""
        counts = self._partner_start[triangles + 1] - self._partner_start[triangles]
        ray = np.repeat(np.arange(len(triangles)), counts)
        partner = self._partners[np.repeat(self._partner_start[triangles], counts) + ranks(counts)]
        side = np.where((directions[ray] * self._normals[partner]).sum(axis=1) < 0, partner,
                        self.mesh.back_of_front[partner])
        weights = barycentric(points[ray], self.mesh.patch_corners[partner])
        inside = (side >= 0) & (weights >= -1e-9).all(axis=1)
        result = np.full(len(triangles), -1)
        chosen, first = np.unique(ray[inside], return_index=True)
        result[chosen] = side[inside][first]
        return result


def particle_count(patches: int, rays: int) -> int:
    """The particles ``trace`` sends for ``patches`` patches read by a final gather of ``rays``
    rays: rays x PARTICLES_PER_RAY per patch, at least MIN_PARTICLES_PER_PATCH."""
    return int(patches * max(rays * PARTICLES_PER_RAY, MIN_PARTICLES_PER_PATCH))


def trace(mesh: Discretization, visibility: Visibility, unshot: np.ndarray, reflectance: np.ndarray,
          particles: int, seed: int = 0, report: Report = quiet) -> np.ndarray:
    """(P, C) the particle-tracing estimate of X = U + rho F X for ``unshot`` U (P, C) and
    ``reflectance`` rho (P, C), from ``particles`` paths (see the module docstring), the power
    arriving read over pools of patches (``pools``)."""
    paths = trace_paths(mesh, visibility, unshot, reflectance, particles, seed, report)
    return paths.future(mesh, unshot, reflectance)


@dataclass(frozen=True)
class ParticlePaths:
    """Where the particles of ``trace_paths`` landed, bounce after bounce, to be read with the
    colours they were traced for or others (``future``).

    sources : (n,) int32 the patch each particle left.
    landings : (L,) int32 the patch of each landing, bounce 0's first, then bounce 1's, ...
    came_from : (L,) int32 for a landing of bounce 0 the particle, after it the landing of the
        bounce before from which the particle went on.
    bounce_starts : (G + 1,) where each bounce's landings start in ``landings``.
    sampling : (P,) the chance p_q that a particle leaves patch q (summing to 1).
    survival : (P,) the chance s_q that a particle that landed on q goes on.
    stops : (P,) the chance that a particle meeting q stops there (its opacity).
    pool : (P,) the pool each patch reads the power arriving over (``pools`` of its landings).
    importance : (P,) the view importance the sampling followed (``view_importance``), or None.
    """

    sources: np.ndarray
    landings: np.ndarray
    came_from: np.ndarray
    bounce_starts: np.ndarray
    sampling: np.ndarray
    survival: np.ndarray
    stops: np.ndarray
    pool: np.ndarray
    importance: np.ndarray | None = None

    def future(self, mesh: Discretization, unshot: np.ndarray, reflectance: np.ndarray,
               report: Report = quiet) -> np.ndarray:
        """(P, C) the estimate of X = U + rho W / A that these paths give for ``unshot`` U (P, C)
        and ``reflectance`` rho (P, C), W / A the power arriving per unit area (``arriving``)."""
        return unshot + reflectance * self.arriving(mesh, unshot, reflectance, report)

    def arriving(self, mesh: Discretization, unshot: np.ndarray, reflectance: np.ndarray,
                 report: Report = quiet) -> np.ndarray:
        """(P, C) W / A, the power per unit area that these paths bring to each patch, read over
        the pools, for ``unshot`` U (P, C) leaving the patches and ``reflectance`` rho (P, C): a particle
        leaving q carries A_q U_q / (n p_q); each time it goes on from j its weight is multiplied
        by rho_j / (opacity_j s_j), and where it stops at j it brings its weight / opacity_j. It
        is unbiased for any U and rho (importance sampling of the paths) where p_q > 0 wherever
        U_q != 0 and s_j > 0 wherever rho_j != 0, with the opacities the paths were traced
        through; ``reusable`` says whether it is about as precise as paths traced for them.
        The channels go on the thread pool, bounce by bounce (the weights of one bounce held)."""
        power = np.zeros_like(unshot)
        np.divide(mesh.patch_areas[:, None] * unshot, self.sampling[:, None] * len(self.sources), out=power,
                  where=self.sampling[:, None] > 0)
        onward = np.zeros_like(reflectance)
        np.divide(reflectance, (self.stops * self.survival)[:, None], out=onward, where=self.survival[:, None] > 0)
        bounces = self.bounce_starts

        def arrived(channel: int) -> np.ndarray:
            """(P,) the power of ``channel`` the particles brought to each patch."""
            going_on = np.ascontiguousarray(onward[:, channel])
            total = np.zeros(mesh.patch_count)
            weight = None
            for bounce, (start, end) in enumerate(zip(bounces[:-1], bounces[1:])):
                before = self.came_from[start:end]  # particles, then the landings of the bounce before
                if bounce == 0:
                    weight = power[self.sources[before], channel]
                else:
                    weight = weight[before - bounces[bounce - 1]] * going_on[self.landings[before]]
                landed = self.landings[start:end]
                total += np.bincount(landed, weight / self.stops[landed], minlength=mesh.patch_count)
            return total

        channels = []
        for channel in parallel.map_ordered(arrived, range(unshot.shape[1])):
            channels.append(channel)
            report(len(channels) / unshot.shape[1])
        return read_pools(mesh, np.stack(channels, axis=1), self.pool)

    def reusable(self, mesh: Discretization, unshot: np.ndarray, reflectance: np.ndarray) -> bool:
        """Whether ``future`` of ``unshot`` (P, C) and ``reflectance`` (P, C) on ``mesh`` (the
        patches and opacities the paths were traced on) is unbiased and about as precise as that
        of paths traced for them: no particle's weight grows where it goes on (rho_j / opacity_j
        <= s_j), and each lit channel's shares a_q of the power leaving the patches are sampled
        with a second moment sum_q a_q^2 / p_q at most REUSE_MOMENT times that of the chances
        paths traced for them would have."""
        opacity = np.ones(mesh.patch_count) if mesh.patch_opacity is None else np.maximum(mesh.patch_opacity, 1e-12)
        if len(self.sampling) != mesh.patch_count or not np.array_equal(opacity, self.stops):
            return False
        if (reflectance > (self.stops * self.survival)[:, None] * (1 + 1e-12)).any():
            return False
        shares = _power_shares(mesh, unshot)
        if (shares[self.sampling <= 0] > 0).any():
            return False
        fresh = _sampling(shares, self.importance)
        if fresh is None:
            return True
        lit = shares.sum(axis=0) > 0
        now = (shares[:, lit] ** 2 / np.where(self.sampling > 0, self.sampling, 1.0)[:, None]).sum(axis=0)
        best = (shares[:, lit] ** 2 / np.where(fresh > 0, fresh, 1.0)[:, None]).sum(axis=0)
        return bool((now <= REUSE_MOMENT * best).all())


def _power_shares(mesh: Discretization, unshot: np.ndarray) -> np.ndarray:
    """(P, C) each patch's share of the power leaving the patches, channel by channel (A_q |U_q|
    over its sum): light scaled per channel (a light's colour or strength) has the same shares."""
    power = mesh.patch_areas[:, None] * np.abs(unshot)
    total = power.sum(axis=0)
    return power / np.where(total > 0, total, 1.0)


def _sampling(shares: np.ndarray, importance: np.ndarray | None = None) -> np.ndarray | None:
    """(P,) the chance of each patch to send a particle, None if there is no light: by power, its
    shares of the power (P, C) summed over the channels (each lit channel counts alike) over their
    sum; with a view ``importance`` Z (P,), POWER_SHARE of that and the rest by power times sqrt(Z).
    The root because the bake's error sums the variances of many readings, not the variance of
    their sum: a particle from q adding c to each of m readings adds m c to Z_q but m c^2 to their
    summed second moment S_q, and p_q proportional to A_q U_q sqrt(S_q) minimises the summed variance
    (sqrt(m) c, as sqrt(Z_q) for c alike; by Z_q itself, the breakfast room's crevices, read by
    many nodes, drew most particles, and it did worse: docs/notes/experiments.md)."""
    weights = shares.sum(axis=1)
    total = weights.sum()
    if total <= 0:
        return None
    by_power = weights / total
    if importance is None:
        return by_power
    viewed = weights * np.sqrt(importance)
    seen = viewed.sum()
    return by_power if seen <= 0 else POWER_SHARE * by_power + (1 - POWER_SHARE) * viewed / seen


def view_importance(mesh: Discretization, visibility: Visibility, viewed: np.ndarray, reflectance: np.ndarray,
                    particles: int, seed: int = 0, report: Report = quiet,
                    receiving: np.ndarray | None = None) -> np.ndarray:
    """(P,) the view importance Z of the patches: what a unit of power leaving patch q adds, with
    all its bounces, to ``viewed`` V (P,), how often the final gather reads each patch (its rays
    landing there). Power w arriving at j adds w (rho_j V_j / A_j + rho_j Z_j) = w Y_j, so
    Z_q = sum_j F_qj Y_j; by reciprocity (A_q F_qj = A_j F_jq) that is the power per unit area
    arriving at q from patches of radiosity Y = rho V / A + rho Z, which ``particles`` importons,
    traced as particles with unshot rho V / A, estimate (Pattanaik and Mudur, "Adjoint equations
    and random walks for illumination computation", 1995; Bekaert 1999, ch. 6), each of at most
    IMPORTON_BOUNCES bounces (Z of paths that long: it only steers). ``reflectance`` (P, C) is
    averaged over the channels; ``receiving`` as in ``trace_paths``."""
    albedo = reflectance.mean(axis=1, keepdims=True)
    emitted = albedo * (viewed / mesh.patch_areas)[:, None]
    paths = trace_paths(mesh, visibility, emitted, albedo, particles, seed, report, stream=1, receiving=receiving,
                        max_bounces=IMPORTON_BOUNCES)
    return paths.arriving(mesh, emitted, albedo)[:, 0]


def trace_paths(mesh: Discretization, visibility: Visibility, unshot: np.ndarray, reflectance: np.ndarray,
                particles: int, seed: int = 0, report: Report = quiet, importance: np.ndarray | None = None,
                stream: int = 0, receiving: np.ndarray | None = None,
                max_bounces: int | None = None) -> ParticlePaths:
    """The paths of ``particles`` particles carrying ``unshot`` U (P, C) between patches of
    ``reflectance`` rho (P, C) (see the module docstring), to be read by ``ParticlePaths.future``;
    sent by power, or by power and a view ``importance`` (P,) (``_sampling``). ``stream``
    separates the random numbers of tracings with one ``seed``. ``receiving`` (P, 3): where each
    patch received its light (``receivers``); a particle drawn at a point that an opaque surface
    passing through the patch parts from there (``_same_side``) is then absorbed where it
    starts, so a patch sends its light only from the side it was lit on. ``max_bounces``: a
    particle lands at most that many times (None: until Russian roulette stops it)."""
    surfaces = Surfaces(mesh, visibility)
    sampling = _sampling(_power_shares(mesh, unshot), importance)
    if particles <= 0 or sampling is None:
        sampling = np.zeros(mesh.patch_count)
        particles = 0
    # systematic sampling: patch q leaves floor(c_q + offset) - floor(c_{q-1} + offset) particles
    cumulative = np.cumsum(sampling) * particles
    offset = streams.generator(seed, streams.PARTICLE_OFFSET, stream).random()
    counts = np.diff(np.floor(np.concatenate([[0.0], cumulative]) + offset)).astype(np.int64)
    sources = runs(counts).astype(np.int32)  # np.repeat(np.arange(P), counts), without holding the GIL
    # a particle stops at patch j with the chance opacity_j (``Surfaces.hit``) and goes on from it
    # with the chance s_j = max_c rho_j,c / opacity_j (Russian roulette)
    stops = np.ones(mesh.patch_count) if mesh.patch_opacity is None else np.maximum(mesh.patch_opacity, 1e-12)
    survival = (reflectance / stops[:, None]).max(axis=1, initial=0.0)
    starts = range(0, len(sources), PARTICLES_PER_BLOCK)

    def block(start: int) -> list[tuple[np.ndarray, np.ndarray]]:
        """Per bounce, the patches the block's particles landed on and where each came from (for
        bounce 0 its particle in the block, after it its landing of the bounce before)."""
        rng = streams.generator(seed, streams.PARTICLE_BLOCK, stream, start)
        patch = sources[start:start + PARTICLES_PER_BLOCK]
        came_from = np.arange(len(patch))
        normal = mesh.patch_normals[patch]
        point = uniform_points(mesh.patch_corners[patch], rng.random((len(patch), 2)))
        if receiving is not None:
            leaving = np.flatnonzero(_same_side(visibility, point, receiving[patch], normal))
            patch, point, normal, came_from = patch[leaving], point[leaving], normal[leaving], came_from[leaving]
        bounces = []
        while len(patch) and (max_bounces is None or len(bounces) < max_bounces):
            directions = cosine_directions(normal, rng.random((len(patch), 2)))
            patch, point = surfaces.hit(point, directions, normal, rng)
            landed = np.flatnonzero(patch >= 0)
            patch, point = patch[landed], point[landed]
            bounces.append((patch.astype(np.int32), came_from[landed].astype(np.int32)))
            survives = np.flatnonzero(rng.random(len(patch)) < survival[patch])
            patch, point, came_from = patch[survives], point[survives], survives
            normal = mesh.patch_normals[patch]
        return bounces

    blocks = []
    for done, part in enumerate(parallel.map_ordered(block, starts)):
        blocks.append(part)
        report((done + 1) / len(starts))
    landings, came_from, bounce_starts = _joined(blocks, starts)
    del blocks  # joined: not held twice
    return ParticlePaths(sources, landings, came_from, bounce_starts, sampling, survival, stops,
                         pools(mesh, np.bincount(landings, minlength=mesh.patch_count)), importance)


def _same_side(visibility: Visibility, points: np.ndarray, targets: np.ndarray, normals: np.ndarray) -> np.ndarray:
    """(n,) bool: whether the segment from each of ``points`` (n, 3) to its ``targets`` (n, 3),
    both on one patch of unit ``normals`` (n, 3) and lifted RAY_EPSILON off it, meets no opaque
    surface: none passes through the patch between them. A patch straddling a surface that
    passes through it (the parts of a lamp pushed into each other, a post stuck into a floor)
    received its light on one side; from the other, inside a solid or a closed pocket, its
    particles would carry that light where none goes, and a pocket of reflectance near 1 would
    pile it up bounce after bounce. A point beyond a post, lit, is parted from the receiving
    point as well; contact cuts (``mesh.contacts``) leave such crossings to small patches only,
    where few particles start (docs/notes/experiments.md, "Particles leave a patch only on the
    side it was lit on")."""
    starts = visibility.to_unit(points) + RAY_EPSILON * normals
    span = (targets - points) * visibility.scale
    reach = np.sqrt(np.einsum("ij,ij->i", span, span))
    directions = span / np.maximum(reach, np.finfo(float).tiny)[:, None]
    return ~visibility.occluded_unit(starts, directions, reach, jittered=True)


def _joined(blocks: list[list[tuple[np.ndarray, np.ndarray]]],
            starts: range) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The blocks' bounces (``trace_paths``) as one array of landings, bounce by bounce, with
    where each came from numbered over all the particles and all the landings (int32, or int64
    beyond 2**31 - 1 landings)."""
    count = sum(len(patch) for bounces in blocks for patch, _ in bounces)
    index_type = np.int32 if max(count, starts.stop) <= np.iinfo(np.int32).max else np.int64
    landings, came_from, bounce_starts = [], [], [0]
    offsets = np.array(starts, dtype=np.int64)  # where each block's bounce before starts
    for bounce in range(max((len(bounces) for bounces in blocks), default=0)):
        lengths = np.zeros(len(blocks), np.int64)
        for index, bounces in enumerate(blocks):
            if bounce < len(bounces):
                patch, source = bounces[bounce]
                landings.append(patch)
                came_from.append(source.astype(index_type) + offsets[index])
                lengths[index] = len(patch)
        offsets = bounce_starts[-1] + np.concatenate([[0], np.cumsum(lengths)[:-1]])
        bounce_starts.append(bounce_starts[-1] + int(lengths.sum()))
    if not landings:
        return np.zeros(0, np.int32), np.zeros(0, index_type), np.zeros(1, np.int64)
    return np.concatenate(landings), np.concatenate(came_from), np.array(bounce_starts, np.int64)


def read_pools(mesh: Discretization, arrived: np.ndarray, pool: np.ndarray) -> np.ndarray:
    """(P, C) the power ``arrived`` (P, C) per unit area of each patch's ``pool`` (P,) labels."""
    total_area = np.bincount(pool, mesh.patch_areas)
    power = np.stack([np.bincount(pool, arrived[:, c]) for c in range(arrived.shape[1])], axis=1)
    density = np.divide(power, total_area[:, None], out=np.zeros_like(power), where=total_area[:, None] > 0)
    return density[pool]


def pools(mesh: Discretization, hits: np.ndarray, min_hits: float = MIN_HITS) -> np.ndarray:
    """(P,) labels 0, 1, ... of pools of patches that together hold ``min_hits`` of the particles'
    ``hits`` (P,): a patch with that many alone, the others with those of their cell of a grid
    that face about the same way (normals rounded to a lattice of step 1/2), lie in the same
    layer along their normal (n . (c - cell centre) floored in steps of spacing / LAYERS_PER_CELL)
    and on the same side of their triangles (front patches, or the backs of two-sided ones), the
    spacing starting where the mean density gives min_hits per cell (sqrt(min_hits sum A /
    sum hits)) and doubled while a pool is short of them.
    Without pools a tiny patch that one particle reaches reads as a spike (power / tiny area) in
    every gather that meets it. A pool is unbiased over its members, so it must not mix light
    and dark: hence hits, not area (where light is dense pools stay small), layers (a moulding
    lit by the sky is not pooled with faces turned the same way a step behind it in shadow, whose
    darkness it would share) and sides (the back of a cup's outer skin, two-sided, faces the
    cup's inside from within its wall, millimetres behind the inner skin: the inside of a solid,
    where no light goes)."""
    areas = mesh.patch_areas
    pool = np.arange(len(areas))
    if hits.sum() <= 0:
        return pool
    next_pool = len(areas)  # pools are numbered after every patch alone, each round after the last
    short = np.flatnonzero(hits < min_hits)
    low = mesh.patch_centroids.min(axis=0)
    spacing = np.sqrt(min_hits * areas.sum() / hits.sum())
    facing = np.round(mesh.patch_normals * 2).astype(np.int64)
    back = (np.arange(len(areas)) >= mesh.front_patch_count).astype(np.int64)[:, None]
    extent = float(np.ptp(mesh.patch_centroids, axis=0).max())
    while len(short):
        centroids = mesh.patch_centroids[short]
        cell = np.floor((centroids - low) / spacing).astype(np.int64)
        height = np.einsum("ij,ij->i", mesh.patch_normals[short], centroids - low - (cell + 0.5) * spacing)
        layer = np.floor(height / (spacing / LAYERS_PER_CELL)).astype(np.int64)
        group = rows.labels(np.concatenate([cell, facing[short], layer[:, None], back[short]], axis=1))
        pool[short] = next_pool + group
        next_pool += int(group.max()) + 1
        if spacing > extent:
            break
        short = short[np.bincount(group, hits[short])[group] < min_hits]
        spacing *= 2
    return np.unique(pool, return_inverse=True)[1].reshape(-1)
