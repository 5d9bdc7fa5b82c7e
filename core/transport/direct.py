"""Direct light: what the lights (``scene.lights``) and the sky give at points of the surfaces,
in Blender's units and with Cycles' conventions, measured with Blender 5.0.1 (../shared/CYCLES.md).

Each light adds to the irradiance of a surface point; this module returns it divided by pi,
G = H / pi, so that a diffuse surface of reflectance rho shows rho * G (and the "lighting only"
output is G itself):

    point, power P (W, per channel), at distance r, angle theta:  G = P cos(theta) / (4 pi^2 r^2)
          (with Soft Falloff and a radius R: P cos(theta) / (4 pi^2 (r^2 + R^2)))
    spot: the same times Cycles' cone mask smoothstep((cos a - cos(s/2)) / ((1 - cos(s/2)) b))
          for the angle a off the axis, spot size s and blend b
    sun, strength E (W/m^2):                                    G = E cos(theta) / pi
    area light, power P over area A, one-sided:                 G = P / (pi A) * F(point -> light)
          (with a spread s: F weighted over the light by ``AreaLight.spread_profile``)
    sky, colour C x strength k:                                  G = C k * (share of the
          cosine-weighted hemisphere that sees no surface)
    environment, radiance L(d) from direction d:                 G = mean over cosine-weighted
          directions d that see no surface of L(d)

Every term is times the visibility of the light from the point, by rays through ``Visibility``,
and proportional to its source's intensity (power, strength, colour): the light of each source is
kept per unit of it (``factors_at``, ``patch_factors``), so a re-solve after a light changed only
its colour or strength combines them again without tracing a ray (``combine``).
Lights do not block or reflect light (they are not geometry), as in Cycles. A point or spot
light of radius r lights as its centre does (the irradiance of a uniformly bright sphere is that
of a point of the same power), or with Soft Falloff, as Cycles lights it then, as a disc of
radius r facing the point, whose radiance P / (4 pi^2 r^2) fills a cone of sin^2 = r^2 / (d^2 +
r^2) (``point.h``; checked against a Cycles render: docs/notes/experiments.md, "Soft Falloff"); both
exact while the light is above the point's horizon. Either is seen from a point as the disc of
radius r facing it: its visibility is the share of ``rays`` stratified points of that disc seen,
each weighed by its unoccluded kernel, and a spot's cone mask is taken along each point's ray, as
Cycles does (so a radius softens the cone's edge); a sun of angular diameter a likewise, over
``rays`` directions uniform in the cone of half-angle a / 2; at a point (not a patch's paired
points) two such sets, and MIXED_SAMPLES_PER_RAY times as many more where either disagrees (a
penumbra: ``raycast.joined_shares``).
"""

from __future__ import annotations

import math
from typing import Callable

import numpy as np

from ..mesh.discretize import light_divisions
from ..rays.visibility import RAY_EPSILON, Visibility
from ..scene.lights import AreaLight, Environment, PointLight, SpotLight, SunLight, source_intensities
from ..util import parallel, streams
from ..util.geometry import areas_and_normals, orthonormal_frames, subdivide, tangent_frames
from .analytic import point_to_triangle
from .raycast import RayCaster, joined_shares, lattice, stratified_samples, unequally_blocked

# Evaluation points per block of work (each with up to a few thousand rays).
POINTS_PER_BLOCK = 1024
# Sky directions per point, per ray of a form factor: the sky often shows through a window, a
# small share s of the hemisphere, and n stratified directions see it to about sqrt(s / n) of
# its light: a few hundred directions keep a small window's blotches to a few percent of it.
SKY_RAYS_PER_RAY = 16
# A patch's sky light (from its centroid) takes a quarter of a point's directions: it only sets
# how much light the patch sends on (the particles, and the gather's rays that land far from it,
# which average many patches); where the gather's rays land close the sky is read where they
# landed. On the breakfast room: the patches' sky 11 -> 3 s, the error from path tracing
# 13.1 / 11.6 -> 13.3 / 11.7 % (seeds 0 / 1; docs/notes/experiments.md, "Where the breakfast
# room's time goes").
PATCH_SKY_RAYS_PER_RAY = 4
# A point (not a patch) that sees part of the sky (below) looks again, OUTLINE_LOOKS times: each look
# samples every stratum once more and the strata on the sky's outline (those where its first
# directions differ from a neighbour's, and the ring around them) OUTLINE_SPLIT x OUTLINE_SPLIT
# times, each at points drawn at random within the stratum, so that no look depends on what the
# first directions met (a thin bar they hit is not then stepped around). It takes the mean of the
# looks, and their spread gives its standard error: through the breakfast room's windows, the error
# of 16 rotations of its directions at 60 % of their rays (docs/notes/experiments.md, "Where the
# breakfast room's error is"). The outline's samples are jittered, one at random in each cell of
# the sub-lattice: a sub-lattice shifted as one beats against the slats of a blind, and by the
# breakfast room's windows the nodes' sky light then spread 2.4 to 8.2 % from seed to seed, against
# 1.4 to 4.3 % jittered ("The sky through a blind", same rays).
OUTLINE_SPLIT = 4
OUTLINE_LOOKS = 2
# Whether a point sees part of the sky is told by rays its first directions do not decide: the
# open directions (NEXT_DOOR_RAYS of each) of the NEXT_DOOR_POINTS nearest other points of its block
# that see part of it. One that sees the sky along one of them looks again, its outline around them
# and its own open directions; any other keeps its first directions' mean. So the choice is
# independent of both the first directions and the looks, and the reading unbiased: chosen by its
# own directions, a point whose directions all missed a window seen through less than a stratum
# read none, and under such a skylight a floor read half its light on average
# (``test_a_skylight_seen_through_less_than_a_stratum_reads_its_light_on_average``). The breakfast
# room's error from path tracing 9.82 / 10.12 -> 8.67 / 9.52 % (seeds 0 / 1) for about 4 s more
# (docs/notes/experiments.md, "Embree's faster scene for the random rays").
NEXT_DOOR_RAYS = 16
NEXT_DOOR_POINTS = 3
# An area light of a spread is sampled with SPREAD_SAMPLES_PER_RAY x ``rays`` points of each piece,
# or of the disc its profile leaves lit where that disc is under 1 / NARROW of the light's area
# (``_spread_light``): against the profile integrated finely, the floor 1 m under a 1 m light read
# 0.15 % RMS off at 90 degrees, 0.9 % at 40, 3 % at 20, 10 or 2 (6.5 % at worst, under the light's
# edge, where the disc is cut); docs/notes/experiments.md, "An area light's Spread".
SPREAD_SAMPLES_PER_RAY = 4
NARROW = 8
# A soft light (a point or spot light of a radius, a sun of an angle) is read at a point (not a
# patch's paired points) from two sets of ``rays`` stratified samples, and MIXED_SAMPLES_PER_RAY x
# ``rays`` more where either disagrees (some blocked, some not: a penumbra), as the nodes read an
# emitting patch (``raycast.joined_shares``).
MIXED_SAMPLES_PER_RAY = 4
# Samples (points x pieces x samples of each) of lights of a spread taken at once: bounds a block's
# memory (some 150 bytes each).
SPREAD_SAMPLES = 1 << 18
# The pieces that splitting the area lights (``discretize.light_divisions``) may add, all lights together:
# each piece costs its rays at every point.
MAX_ADDED_LIGHT_PIECES = 256


class DirectLighting:
    """G = H / pi from the lights and the sky at points, with shadows by rays.

    rays : light samples per piece of an area light at a patch (SPREAD_SAMPLES_PER_RAY times as many
        for one of a spread; at the nodes as an emitting patch's: ``raycast.RayCaster``), and per
        soft light (two sets at a point, and more where either disagrees: ``_soft``); as the bake's
        rays per form factor; the sky gets SKY_RAYS_PER_RAY times as many directions per point,
        PATCH_SKY_RAYS_PER_RAY times per patch; seed fixes them. An area light of few triangles is split into at least
        ``discretize.MIN_LIGHT_PIECES`` pieces (its penumbrae need them), unless the splits of all
        of them would add more than MAX_ADDED_LIGHT_PIECES.
    """

    def __init__(self, lights: tuple, sky: np.ndarray, visibility: Visibility, rays: int, seed: int,
                 environment: Environment | None = None) -> None:
        self.lights = lights
        self.sky = np.asarray(sky, dtype=np.float64)
        self.environment = environment
        self.visibility = visibility
        self.rays = rays
        self.seed = seed
        self._area = []
        area_lights = [(index, light) for index, light in enumerate(lights) if isinstance(light, AreaLight)]
        divisions = light_divisions([len(light.triangles) for _, light in area_lights])
        if sum(len(light.triangles) * (n * n - 1) for (_, light), n in zip(area_lights, divisions)) \
                > MAX_ADDED_LIGHT_PIECES:
            divisions[:] = 1
        for (index, light), n in zip(area_lights, divisions):
            pieces = subdivide(light.triangles, int(n))
            areas, normals = areas_and_normals(pieces)
            # no RayCaster where ``_area_lights`` reads the light without one (no shadow, or a spread)
            ray_cast = light.casts_shadow and light.spread >= math.pi
            # read as an emitting patch is (``raycast``): in its solid angle close by, and at the
            # points asked about finely with more rays where its first sets disagree
            caster = RayCaster(pieces, normals, areas, visibility, rays, seed + 1 + index,
                               emitting=np.ones(len(pieces), dtype=bool)) if ray_cast else None
            self._area.append((index, pieces, caster))

    @property
    def light_pieces(self) -> int:
        """The pieces the area lights are sampled from, all together."""
        return sum(len(pieces) for _, pieces, _ in self._area)

    @property
    def empty(self) -> bool:
        return not self.lights and not self.sky.any() and self.environment is None

    @property
    def source_count(self) -> int:
        """S: the lights, then the sky if it shines, then the environment if there is one."""
        return len(self.lights) + int(bool(self.sky.any())) + int(self.environment is not None)

    def intensities(self) -> np.ndarray:
        """(S, 3) what each source's light is proportional to: a light's power (a sun's
        strength), the sky's colour, 1 for the environment (its image is in its factors)."""
        return source_intensities(self.lights, self.sky if self.sky.any() else None,
                                  None if self.environment is None else 1.0)

    def at_points(self, points: np.ndarray, normals: np.ndarray, report: Callable[[float], None]) -> np.ndarray:
        """(m, 3) G at points (m, 3) facing unit normals (m, 3)."""
        return self.combine(self.factors_at(points, normals, report))

    def factors_at(self, points: np.ndarray, normals: np.ndarray, report: Callable[[float], None]) -> np.ndarray:
        """(m, S, 3) G at points (m, 3) facing unit normals (m, 3), per source, per unit of its
        intensity (``combine`` sums them)."""
        return self.sampled_factors_at(points, normals, report)[0]

    def sampled_factors_at(self, points: np.ndarray, normals: np.ndarray,
                           report: Callable[[float], None]) -> tuple[np.ndarray, np.ndarray]:
        """``factors_at``'s (m, S, 3), and the standard error (m, S - L, 3) of the sky's and the
        environment's (after the L lights) where a point sees part of the sky: the spread of the
        OUTLINE_LOOKS looks it averages over the root of their number (zero where all its first
        directions agree, and where its looks happen to)."""
        if self.source_count == 0 or len(points) == 0:
            return np.zeros((len(points), self.source_count, 3)), np.zeros((len(points), self.source_count
                                                                           - len(self.lights), 3))
        return self._in_blocks(points, normals, self._point_block, report, streams.NODES, outputs=2)

    def light_factors_at(self, points: np.ndarray, normals: np.ndarray) -> np.ndarray:
        """(m, L, 3) ``factors_at`` of the L lights alone, without the sky."""
        if not self.lights:
            return np.zeros((len(points), 0, 3))
        factors = self._in_blocks(points, normals, lambda block, block_normals, key: self._sharp(
            block, block_normals, key) + self._area_lights(block, block_normals, finely=True),
                                  lambda _fraction: None, streams.NODES)
        return factors[:, : len(self.lights)]

    @property
    def has_area_lights(self) -> bool:
        return bool(self._area)

    def light_samples_of_block(self, points: np.ndarray, normals: np.ndarray, key: tuple[int, ...]) -> np.ndarray:
        """(m, L, 3) one unbiased estimate of ``light_factors_at`` at each of one block of points
        (of point, spot and sun lights: not area lights), on the calling thread: one shadow ray per
        light and point, a soft light's samples stratified over the points in order (as a patch's
        points are: ``_sharp``'s ``paired``), drawn from the stream of ``key``, the caller's own
        (``util.streams``: a gather's bounces, ``(BOUNCES, stream, block, bounce)``)."""
        return self._sharp(points, normals, key, paired=True)[:, : len(self.lights)]

    def patch_factors(self, corners: np.ndarray, normals: np.ndarray, report: Callable[[float], None]) -> np.ndarray:
        """(P, S, 3) per source and unit intensity, G over patches (P, 3, 3): the mean over
        ``rays`` stratified points of each patch for point, spot and sun lights (their shadows
        are sharp); at the centroid for area lights and the sky, whose light changes smoothly (the
        sky from PATCH_SKY_RAYS_PER_RAY directions per ray)."""
        return self._in_blocks(corners, normals, self._patch_block, report, streams.PATCHES)

    def combine(self, factors: np.ndarray, intensities: np.ndarray | None = None) -> np.ndarray:
        """(m, 3) sum_s factors[:, s] x intensities[s]: the light of the sources (m, S, 3) at
        ``intensities`` (S, 3) (default: the scene's own)."""
        intensities = self.intensities() if intensities is None else intensities
        return np.einsum("msc,sc->mc", factors, intensities) if factors.shape[1] else np.zeros((len(factors), 3))

    def _in_blocks(self, items, normals, block, report, kind: int, outputs: int = 1):
        """``block(items, normals, key)`` over blocks of POINTS_PER_BLOCK items, joined: an array
        (m, S, 3), or a tuple of ``outputs`` arrays (for at least one item); ``key`` (``kind``, the
        index of the block's first item) names the block's random streams (``util.streams``)."""
        if self.source_count == 0 or len(items) == 0:
            return np.zeros((len(items), self.source_count, 3))
        starts = range(0, len(items), POINTS_PER_BLOCK)
        parts = []
        for done, part in enumerate(parallel.map_ordered(
                lambda s: block(items[s: s + POINTS_PER_BLOCK], normals[s: s + POINTS_PER_BLOCK], (kind, s)),
                starts), 1):
            parts.append(part if outputs > 1 else (part,))
            report(done / len(starts))
        joined = tuple(np.concatenate(pieces) for pieces in zip(*parts))
        return joined if outputs > 1 else joined[0]

    def _point_block(self, points, normals, key) -> tuple[np.ndarray, np.ndarray]:
        starts = self.visibility.lifted_unit(points, normals)  # the lights' and the sky's rays alike
        smooth, noise = self._smooth(points, normals, key, outlined=True, starts=starts, finely=True)
        return self._sharp(points, normals, key, starts=starts) + smooth, noise[:, len(self.lights):]

    def _patch_block(self, corners, normals, key) -> np.ndarray:
        rotation = streams.generator(self.seed, streams.PATCH_LIGHT_POINTS, *key).random((len(corners), 1, 2))
        samples = stratified_samples(corners, self.rays, rotation)  # (k, S, 3)
        sharp = self._sharp(samples.reshape(-1, 3), np.repeat(normals, self.rays, axis=0), key, paired=True)
        return sharp.reshape(len(corners), self.rays, *sharp.shape[1:]).mean(axis=1) + self._smooth(
            corners.mean(axis=1), normals, key, sky_rays=PATCH_SKY_RAYS_PER_RAY)[0]

    def _sharp(self, points, normals, key: tuple[int, ...], paired: bool = False,
               starts: np.ndarray | None = None) -> np.ndarray:
        """(m, S, 3) point, spot and sun lights at points: one shadow ray each to a point light
        or along a sun, ``rays`` to points of a light's disc or directions of a sun's cone (one
        each when ``paired``: the points are a patch's ``rays`` stratified samples, the i-th
        paired with the i-th stratum of the light); none from a light that casts no shadow. The
        rays leave from ``starts`` (``Visibility.lifted_unit``; None: made here, once)."""
        result = np.zeros((len(points), self.source_count, 3))
        if starts is None and any(light.casts_shadow or isinstance(light, SpotLight) for light in self.lights):
            starts = self.visibility.lifted_unit(points, normals)
        for index, light in enumerate(self.lights):
            if isinstance(light, SunLight):
                cosine = -(normals @ light.direction)
                lit = np.flatnonzero(cosine > 0)
                if not light.casts_shadow:
                    seen = 1.0
                elif light.angle > 0:
                    seen = self._soft(lit, key, index, paired, points, lambda rows, samples: self._seen_in_cone(
                        starts[rows], -light.direction, light.angle / 2, samples))
                else:
                    towards = np.broadcast_to(-light.direction, (len(lit), 3))
                    seen = self._unblocked(starts[lit], towards[:, None], None, jittered=False)[:, 0]
                result[lit, index] = (cosine[lit] * seen / math.pi)[:, None]
            elif isinstance(light, (PointLight, SpotLight)):
                offset = light.position - points
                distance = np.linalg.norm(offset, axis=1)
                towards = offset / np.maximum(distance, np.finfo(float).tiny)[:, None]
                falloff = distance * distance + (light.radius ** 2 if light.soft_falloff else 0.0)
                strength = np.maximum((normals * towards).sum(axis=1), 0.0) / falloff
                spot = isinstance(light, SpotLight)
                if spot and light.radius > 0:  # the cone widened by the disc as seen from the point
                    widened = light.spot_size / 2 + np.arcsin(np.minimum(light.radius / np.maximum(
                        distance, np.finfo(float).tiny), 1.0))
                    strength[-towards @ light.direction <= np.cos(np.minimum(widened, math.pi))] = 0.0
                elif spot:
                    strength *= light.cone_mask(-towards)
                lit = np.flatnonzero(strength > 0)
                if light.radius > 0 and (spot or light.casts_shadow):
                    seen = self._soft(lit, key, index, paired, points, lambda rows, samples: self._seen_on_disc(
                        points[rows], normals[rows], starts[rows], light, samples, paired))
                elif not light.casts_shadow:
                    seen = 1.0
                else:
                    seen = self._unblocked(starts[lit], offset[lit][:, None], 1.0, jittered=False)[:, 0]
                result[lit, index] = (strength[lit] * seen / (4 * math.pi**2))[:, None]
        return result

    def _soft(self, lit: np.ndarray, key: tuple[int, ...], light: int, paired: bool, points: np.ndarray,
              seen: Callable) -> np.ndarray:
        """(k,) the share of soft light ``light`` that each of the points ``lit`` (k,) of a block gets:
        ``seen(rows, samples)`` ((k',) shares, and (k',) bool whether the samples disagree) from
        ``_light_samples``; at points (not ``paired``) from two sets and more where either
        disagrees (``raycast.joined_shares``)."""
        if paired or self.rays == 1:  # (one sample cannot disagree)
            return seen(lit, self._light_samples(lit, key, light, paired, points[lit]))[0]
        kinds = ("first", "more", "second")
        return joined_shares(len(lit), self.rays, MIXED_SAMPLES_PER_RAY * self.rays, lambda rows, which: seen(
            lit[rows], self._light_samples(lit[rows], key, light, paired, points[lit[rows]], kinds[which])))

    def _light_samples(self, chosen: np.ndarray, key: tuple[int, ...], light: int, paired: bool,
                       points: np.ndarray, kind: str = "first") -> np.ndarray:
        """(k, s, 2) stratified points of the unit square for the ``points`` (k, 3) ``chosen`` (k,)
        of a block: s = ``rays`` strata, each point's rotated (Cranley-Patterson) by numbers made
        from the point itself (``streams.point_uniforms``: a point's light is the same in whatever
        block it is asked); paired, s = 1, the stratum of each point's place among its patch's
        ``rays`` samples, the patch's rotation drawn from the block's stream; ``kind`` "second" or
        "more" (``_soft``): s = ``rays`` or MIXED_SAMPLES_PER_RAY x ``rays`` others, rotated so too."""
        if kind != "first":
            count, tag = (self.rays, streams.POINT_SECOND_TURNS) if kind == "second" else (
                MIXED_SAMPLES_PER_RAY * self.rays, streams.POINT_MIXED_TURNS)
            rotation = streams.point_uniforms(self.seed, tag, light, points, 2)[:, None]
            return (_strata(count)[None] + rotation) % 1.0
        grid = _strata(self.rays)
        if paired:
            rng = streams.generator(self.seed, streams.LIGHT_SAMPLES, *key, light)
            rotation = rng.random((int(chosen.max()) // self.rays + 1 if len(chosen) else 0, 2))
            return ((grid[chosen % self.rays] + rotation[chosen // self.rays]) % 1.0)[:, None]
        rotation = streams.point_uniforms(self.seed, streams.POINT_TURNS, light, points, 2)[:, None]
        return (grid[None] + rotation) % 1.0

    def _seen_on_disc(self, points, normals, starts, light: PointLight | SpotLight, samples,
                      paired: bool) -> tuple[np.ndarray, np.ndarray]:
        """(k,) the share each point gets of its unshaded light, over the samples (k, s, 2) of the
        disc of the light's radius about its position, facing the point: sum k v m / sum k, k the
        unoccluded kernel cos_point cos_disc / r^2 of each sample, v whether the point sees it (1
        for a light that casts no shadow), m a spot's cone mask along the ray from the sample to
        the point (Cycles' ``spot_light_sample`` masks each light sample so: a light's radius
        softens its cone's edge; 1 for a point light). ``paired`` (one sample a point, as a
        patch's points take a stratum each): k v m over the disc's mean kernel, cos theta / (d^2
        + R^2) (its projected solid angle pi R^2 cos theta / (d^2 + R^2) over its area), whose
        mean over the strata is the same share, unbiased. And (k,) bool: whether the samples that
        bring some light (kernel times mask) disagree (``raycast.unequally_blocked``): a spot's
        samples outside its cone, blocked or not, call for no more."""
        towards = light.position - points
        distance2 = np.einsum("kx,kx->k", towards, towards)
        facing = towards / np.maximum(np.sqrt(distance2), 1e-300)[:, None]
        tangent, bitangent = tangent_frames(facing)
        r, angle = light.radius * np.sqrt(samples[..., 0]), 2 * math.pi * samples[..., 1]
        offsets = (light.position + (r * np.cos(angle))[..., None] * tangent[:, None]
                   + (r * np.sin(angle))[..., None] * bitangent[:, None]) - points[:, None]  # (k, s, 3)
        lengths2 = np.einsum("ksx,ksx->ks", offsets, offsets)
        kernel = (np.maximum(np.einsum("ksx,kx->ks", offsets, normals), 0.0)
                  * np.maximum(np.einsum("ksx,kx->ks", offsets, facing), 0.0) / (lengths2 * lengths2))
        share = self._unblocked(starts, offsets, 1.0, jittered=False) if light.casts_shadow \
            else np.ones(offsets.shape[:2])
        mask = light.cone_mask(-offsets / np.sqrt(lengths2)[..., None]) if isinstance(light, SpotLight) else 1.0
        disagree = unequally_blocked(share, (kernel * mask) > 0)  # the shadow's edge, not the cone's
        share = share * mask
        total = kernel.sum(axis=1)
        if paired:
            total = np.maximum(np.einsum("kx,kx->k", normals, facing), 0.0) / (distance2 + light.radius ** 2)
        return np.divide((kernel * share).sum(axis=1), total, out=np.zeros(len(points)), where=total > 0), disagree

    def _seen_in_cone(self, starts, axis, half_angle, samples) -> tuple[np.ndarray, np.ndarray]:
        """(k,) the share of the directions (uniform in solid angle within ``half_angle`` of the
        unit ``axis``, from the samples (k, s, 2)) along which a point whose rays leave from
        ``starts`` (k, 3) sees no surface, and (k,) bool whether they disagree."""
        tangent, bitangent = tangent_frames(np.broadcast_to(axis, (1, 3)))
        cos_theta = 1.0 - samples[..., 0] * (1.0 - math.cos(half_angle))
        sin_theta, phi = np.sqrt(np.maximum(1.0 - cos_theta ** 2, 0.0)), 2 * math.pi * samples[..., 1]
        directions = (cos_theta[..., None] * axis + (sin_theta * np.cos(phi))[..., None] * tangent[0]
                      + (sin_theta * np.sin(phi))[..., None] * bitangent[0])  # (k, s, 3)
        share = self._unblocked(starts, directions, None, jittered=False)
        return share.mean(axis=1), unequally_blocked(share, np.ones(share.shape, dtype=bool))

    def _smooth(self, points, normals, key: tuple[int, ...], outlined: bool = False,
                sky_rays: int = SKY_RAYS_PER_RAY, starts: np.ndarray | None = None,
                finely: bool = False) -> tuple[np.ndarray, np.ndarray]:
        """(m, S, 3) area lights (read ``finely`` or not: ``_area_lights``) and the sky (from ``rays``
        x ``sky_rays`` directions, drawn from the streams of the block's ``key``: ``_in_blocks``);
        ``outlined``, where a point sees the sky
        along its neighbours' open directions (``_sky_next_door``), the mean of OUTLINE_LOOKS looks
        along its outline (``_looked``); and (m, S, 3) the standard error of that mean, from the
        looks' spread (zero elsewhere). The sky's rays leave from ``starts`` (``Visibility.lifted_unit``;
        None: made here)."""
        result = self._area_lights(points, normals, finely)
        noise = np.zeros_like(result)
        if self.sky.any() or self.environment is not None:
            rotation = self._rotation(key, len(points))
            if starts is None:
                starts = self.visibility.lifted_unit(points, normals)
            directions, open_sky = self._open_sky(starts, normals, rotation, sky_rays)
            sky = np.zeros_like(result)
            each = self._each_direction(directions, open_sky)
            sky[:, len(self.lights):] = _joined([along.mean(axis=1) for along in each])
            if outlined:
                looking, next_door = self._sky_next_door(points, starts, normals, rotation, directions, open_sky)
                if len(looking):
                    outline = _outline((open_sky[looking] > 0) | next_door)
                    looks = np.stack([self._looked(starts[looking], normals[looking], rotation[looking], outline,
                                                   self._generator(key, look))
                                      for look in range(1, OUTLINE_LOOKS + 1)])
                    columns = slice(len(self.lights), self.source_count)
                    sky[looking, columns] = looks.mean(axis=0)
                    noise[looking, columns] = looks.std(axis=0, ddof=1) / math.sqrt(OUTLINE_LOOKS)
            result += sky
        return result, noise

    def _sky_next_door(self, points, starts, normals, rotation, directions, open_sky) -> tuple[np.ndarray, np.ndarray]:
        """The points (k,) of a block that see the sky along the open ``directions`` (m, K, 3)
        (``open_sky`` (m, K)) of the NEXT_DOOR_POINTS nearest other points that see part of it
        (NEXT_DOOR_RAYS of each), and (k, K) the strata those directions fall in (``_open_sky``'s,
        at each point's ``rotation`` (m, 2)). Neither depends on a point's own directions."""
        partly = np.flatnonzero((open_sky > 0).any(axis=1) & (open_sky < 1).any(axis=1))
        if len(partly) == 0:
            return np.zeros(0, np.int64), np.zeros((0, open_sky.shape[1]), bool)
        # squared distances (m, p), as |a|^2 + |b|^2 - 2 a.b: no (m, p, 3) differences
        square = np.einsum("mx,mx->m", points, points)
        gap = square[:, None] + square[partly][None, :] - 2.0 * (points @ points[partly].T)
        gap[partly, np.arange(len(partly))] = np.inf  # another point's, not its own
        # the same count of others whether a point is partly open or not: the choice must not
        # depend on its own directions (its own column, infinitely far, is dropped below)
        neighbours = min(NEXT_DOOR_POINTS, len(partly))
        columns = np.argpartition(gap, neighbours - 1, axis=1)[:, :neighbours]  # (m, n)
        nearest = partly[columns]
        opened = (open_sky[nearest] > 0) & np.isfinite(np.take_along_axis(gap, columns, axis=1))[..., None]  # (m, n, K)
        opened &= np.cumsum(opened, axis=2) <= NEXT_DOOR_RAYS
        point, neighbour, stratum = np.nonzero(opened)
        candidate = directions[nearest[point, neighbour], stratum]  # (c, 3) world directions
        facing = np.einsum("cx,cx->c", candidate, normals[point]) > 1e-3
        point, candidate = point[facing], candidate[facing]
        seen = self._unblocked(starts[point], candidate[:, None], None, jittered=True)[:, 0] > 0
        point, candidate = point[seen], candidate[seen]
        # the stratum each direction that got through falls in, at its own point's rotation
        local = np.einsum("cij,cj->ci", _frames(normals[point]), candidate.astype(np.float32))
        u = np.clip(local[:, 0] ** 2 + local[:, 1] ** 2, 0.0, 1.0 - 1e-7)
        angle = np.arctan2(local[:, 1], local[:, 0]) / (2 * math.pi)
        side = int(round(math.sqrt(open_sky.shape[1])))
        across = np.floor(((u - rotation[point, 0]) % 1.0) * side).astype(np.int64) % side
        around = np.floor(((angle - rotation[point, 1]) % 1.0) * side).astype(np.int64) % side
        looking, slot = np.unique(point, return_inverse=True)
        through = np.zeros((len(looking), open_sky.shape[1]), bool)
        through[slot, around * side + across] = True
        return looking, through

    def _looked(self, starts, normals, rotation, outline, generator: np.random.Generator) -> np.ndarray:
        """(m, E, 3) the sky's and the environment's light per unit (E of them) at points, from a
        look at the strata of ``_open_sky`` at ``rotation`` (m, 2): each stratum sampled once, at
        a point drawn from ``generator`` (one shift (m, 2) for all of a point's strata), and those on
        ``outline`` (m, K) once in each cell of an OUTLINE_SPLIT x OUTLINE_SPLIT sub-lattice, at a
        point drawn in the cell (jittered); the mean over the strata of each one's sample or cells."""
        count, strata = outline.shape
        side = int(round(math.sqrt(strata)))
        shift = generator.random((count, 2))
        shares = self._each_direction(*self._open_sky(starts, normals, rotation + (shift - 0.5) / side))
        point, stratum = np.nonzero(outline)
        if len(point):
            cells = (_strata(OUTLINE_SPLIT * OUTLINE_SPLIT) - 0.5 / OUTLINE_SPLIT) / side  # (k, 2) the cells' corners
            jitter = generator.random((len(point), OUTLINE_SPLIT * OUTLINE_SPLIT, 2)) / (OUTLINE_SPLIT * side)
            square = (_strata(strata)[stratum] - 0.5 / side + rotation[point])[:, None] + cells + jitter
            square -= np.floor(square)  # modulo 1
            angle = (2 * math.pi * square[..., 1]).astype(np.float32)  # as the directions are
            fine = _cosine_directions(square[..., 0], np.cos(angle), np.sin(angle), _frames(normals)[point])
            through = self._unblocked(starts[point], fine, None, jittered=True)
            fine_shares = self._each_direction(fine, through)
            for share, fine_share in zip(shares, fine_shares):
                share[point, stratum] = fine_share.mean(axis=1)
        return _joined([share.mean(axis=1) for share in shares])

    def _each_direction(self, directions: np.ndarray, through: np.ndarray) -> list[np.ndarray]:
        """The sky's and the environment's light per unit (E of them, the sources after the lights)
        along each of the cosine-distributed ``directions`` (m, K, 3), from what gets ``through``
        (m, K) along it: the sky's (m, K), alike in every channel, and the environment's (m, K, 3)."""
        through = through.astype(np.float64)
        lights = []
        if self.sky.any():
            lights.append(through)
        if self.environment is not None:
            lights.append(through[..., None] * self.environment.at(directions))
        return lights

    def _area_lights(self, points, normals, finely: bool = False) -> np.ndarray:
        """(m, S, 3) area lights at points, per unit of power: each piece's form factor by shadow
        rays as an emitting patch's (``raycast.RayCaster``: in its solid angle close by; ``finely``,
        as the nodes read, with more rays where its first sets disagree), the exact unoccluded
        form factors for a light that casts no shadow, ``_spread_light`` for a light of a spread;
        times 1 / (pi A)."""
        result = np.zeros((len(points), self.source_count, 3))
        count = len(points)
        for index, pieces, caster in self._area:
            light, sources = self.lights[index], len(pieces)
            receivers, pieces_of = np.repeat(np.arange(count), sources), np.tile(np.arange(sources), count)
            if light.spread < math.pi:
                factor = self._spread_light(points, normals, light, pieces, index)
            elif caster is not None:
                factor = caster.form_factors(points, normals, receivers, pieces_of, np.full(count, finely)).reshape(
                    count, sources).sum(axis=1)
            else:
                factor = point_to_triangle(points[receivers], normals[receivers],
                                           pieces[pieces_of]).reshape(count, sources).sum(axis=1)
            area = areas_and_normals(light.triangles)[0].sum()
            result[:, index] = (factor / (math.pi * area))[:, None]
        return result

    def _spread_light(self, points, normals, light: AreaLight, pieces: np.ndarray, index: int) -> np.ndarray:
        """(m,) F_f = 1/pi integral over the light of f cos_x cos_y v / r^2 dA at each point: its
        form factor weighted by the ``spread_profile`` f, v whether the point sees y (1 for a light
        that casts no shadow). Where the disc that the profile leaves lit, of radius rho = h tan(s
        / 2) about the point's foot on the light's plane (h the point's height over it), is under
        1 / NARROW of the light, samples of that disc (``_spread_disc``; Cycles'
        ``area_light_spread_clamp_light`` samples so); elsewhere samples of each piece
        (``_spread_pieces``). n = SPREAD_SAMPLES_PER_RAY x ``rays`` samples a disc or piece,
        rotated per point, only those of some weight traced, at most SPREAD_SAMPLES at once."""
        count, sources, samples = len(points), len(pieces), self.rays * SPREAD_SAMPLES_PER_RAY
        areas, facing = areas_and_normals(pieces)
        normal, corner = facing[0], pieces[0, 0]  # a Blender area light is flat
        height = (points - corner) @ normal
        radius = height * math.tan(light.spread / 2)
        narrow = (height > 0) & (math.pi * radius**2 < areas.sum() / NARROW)
        turns = streams.point_uniforms(self.seed, streams.POINT_TURNS, index, points, 2 + 2 * sources)
        disc_turn, piece_turn = turns[:, None, :2], turns[:, 2:].reshape(count, sources, 1, 2)
        result = np.zeros(count)
        chunk = max(1, SPREAD_SAMPLES // (samples * sources))
        for first in range(0, count, chunk):
            rows = np.arange(first, min(first + chunk, count))
            disc, wide = rows[narrow[rows]], rows[~narrow[rows] & (height[rows] > 0)]
            if len(disc):
                result[disc] = self._spread_disc(points[disc], normals[disc], light, pieces, height[disc],
                                                 radius[disc], disc_turn[disc], samples)
            if len(wide):
                result[wide] = self._spread_pieces(points[wide], normals[wide], light, pieces, piece_turn[wide],
                                                   samples)
        return result

    def _spread_disc(self, points, normals, light: AreaLight, pieces, height, radius, turn, samples) -> np.ndarray:
        """``_spread_light`` where the lit disc is under 1 / NARROW of the light: (k,) rho^2 / n sum
        (2 r / rho) f k v over n samples of the disc of radius ``radius`` (k,) about each point's
        foot, ``height`` (k,) under it (a rotated rank-1 lattice, uniform in radius and angle: the
        profile falls about linearly to the rim, so the weight 2 r / rho nearly cancels it), those
        off the light's ``pieces`` counting 0."""
        normal = areas_and_normals(pieces)[1][0]
        tangent, bitangent = tangent_frames(normal[None])
        square = (lattice(samples)[None] + turn) % 1.0  # (k, n, 2): each sample a radius of its own
        r, angle = radius[:, None] * square[..., 0], 2 * math.pi * square[..., 1]  # uniform in r: weight 2 r / rho
        feet = points - height[:, None] * normal
        on_plane = (feet[:, None] + (r * np.cos(angle))[..., None] * tangent[0]
                    + (r * np.sin(angle))[..., None] * bitangent[0])  # (k, n, 3)
        lit = _on_triangles(on_plane, pieces)
        offsets = on_plane - points[:, None]
        distance2 = np.einsum("ksx,ksx->ks", offsets, offsets)
        cos_light = height[:, None] / np.sqrt(distance2)
        cos_point = np.maximum(np.einsum("ksx,kx->ks", offsets, normals), 0.0) / np.sqrt(distance2)
        weighted = lit * light.spread_profile(cos_light) * cos_point * cos_light / distance2
        if light.casts_shadow:
            weighted = weighted * self._seen_where(points, normals, offsets, weighted > 0)
        return radius**2 * (2 * square[..., 0] * weighted).mean(axis=1)

    def _spread_pieces(self, points, normals, light: AreaLight, pieces, turn, samples) -> np.ndarray:
        """``_spread_light`` where the lit disc is not under 1 / NARROW of the light: (k,) the sum
        over the ``pieces`` of each one's exact unoccluded form factor times the ratio of sum w f v
        to sum w over n stratified samples of it (Cranley-Patterson ``turn`` (k, K, 1, 2))."""
        count, sources = len(points), len(pieces)
        areas, facing = areas_and_normals(pieces)
        on_light = stratified_samples(np.repeat(pieces[None], count, axis=0).reshape(-1, 3, 3), samples,
                                      turn.reshape(-1, 1, 2)).reshape(count, sources * samples, 3)
        offsets = on_light - points[:, None]  # (k, K n, 3)
        distance2 = np.einsum("ksx,ksx->ks", offsets, offsets)
        distance = np.sqrt(distance2)
        piece = np.arange(sources * samples) // samples
        cos_light = -np.einsum("ksx,sx->ks", offsets, facing[piece]) / distance
        cos_point = np.einsum("ksx,kx->ks", offsets, normals) / distance
        kernel = np.maximum(cos_point, 0) * np.maximum(cos_light, 0) / (distance2 + areas[piece] / (math.pi * samples))
        weighted = kernel * light.spread_profile(cos_light)
        if light.casts_shadow:
            weighted = weighted * self._seen_where(points, normals, offsets, weighted > 0)
        kernel, weighted = (values.reshape(count, sources, samples).sum(axis=2) for values in (kernel, weighted))
        exact = point_to_triangle(np.repeat(points, sources, axis=0), np.repeat(normals, sources, axis=0),
                                  np.tile(pieces, (count, 1, 1))).reshape(count, sources)
        return (exact * np.divide(weighted, kernel, out=np.zeros_like(kernel), where=kernel > 0)).sum(axis=1)

    def _seen_where(self, points, normals, offsets, chosen) -> np.ndarray:
        """(k, n) whether each point (k, 3) sees the ends of its ``offsets`` (k, n, 3) where
        ``chosen`` (k, n) (its rays alone traced), 0 elsewhere."""
        seen = np.zeros(chosen.shape)
        point, sample = np.nonzero(chosen)
        if len(point):
            starts = self.visibility.lifted_unit(points, normals)
            seen[point, sample] = self._unblocked(starts[point], offsets[point, sample][:, None], 1.0,
                                                  jittered=True)[:, 0]
        return seen

    def _open_sky(self, starts, normals, rotation,
                  sky_rays: int = SKY_RAYS_PER_RAY) -> tuple[np.ndarray, np.ndarray]:
        """Directions (m, K, 3) over the cosine-weighted hemisphere of each point facing ``normals``
        (m, 3) whose rays leave from ``starts`` (``Visibility.lifted_unit``), and which of them
        (m, K) see no surface: K = ``rays`` x ``sky_rays`` stratified directions by Malley's
        method (``_cosine_directions``), each point's strata turned by its ``rotation`` (m, 2) of
        the unit square (random: Cranley-Patterson)."""
        grid = _strata(self.rays * sky_rays)
        # the angle 2 pi (stratum + rotation): its cosine and sine from those of its two parts
        stratum, turn = 2 * math.pi * grid[:, 1], 2 * math.pi * rotation[:, 1:]
        directions = _cosine_directions((grid[:, 0] + rotation[:, :1]) % 1.0,
                                        np.cos(stratum) * np.cos(turn) - np.sin(stratum) * np.sin(turn),
                                        np.sin(stratum) * np.cos(turn) + np.cos(stratum) * np.sin(turn),
                                        _frames(normals))
        return directions, self._unblocked(starts, directions, None, jittered=True)

    def _rotation(self, key: tuple[int, ...], count: int) -> np.ndarray:
        """(count, 2) the rotations of the sky's strata (``_open_sky``) at the points of the block
        of ``key``."""
        return self._generator(key, 0).random((count, 2))

    def _generator(self, key: tuple[int, ...], look: int) -> np.random.Generator:
        """The random numbers of the sky's directions at the points of the block of ``key``, for
        their ``look`` (0: the first directions)."""
        return streams.generator(self.seed, streams.SKY_DIRECTIONS, *key, look)

    def _unblocked(self, starts, offsets, reach, *, jittered: bool) -> np.ndarray:
        """(m, s) what gets through along each of the s rays from each of ``starts`` (m, 3), where
        a point's rays leave its surface in unit space (``Visibility.lifted_unit``), along
        ``offsets`` (m, s, 3) from the point: whether no surface blocks it, or the share of its
        light no surface stops where some let light through (``Visibility.blocked_unit``);
        ``reach`` 1.0 up to the offsets' ends, None to infinity (the offsets then unit directions);
        ``jittered``: the offsets are drawn at random over the hemisphere (the sky's), not the same
        at every point (a sun's, nearly so for a sun of a tiny angle) or aimed at one point (a
        point light's, nearly so for a small radius)."""
        visibility = self.visibility
        shape = offsets.shape[:2]
        if offsets.size == 0:
            return np.ones(shape)
        if reach is None:  # beyond the scene: every surface is within 1 of the unit space's centre
            directions = np.asarray(offsets, np.float32)
            ray_reach = np.linalg.norm(starts, axis=1)[:, None] + 2.0
        else:  # stop RAY_EPSILON short of the end, along the ray
            directions = np.asarray(offsets, np.float32) * np.float32(visibility.scale)
            lengths = np.linalg.norm(directions, axis=2)
            ray_reach = reach - RAY_EPSILON / np.maximum(lengths, np.finfo(np.float32).tiny)
        ray_starts, ray_reaches = np.empty((*shape, 3), np.float32), np.empty(shape, np.float32)
        ray_starts[:], ray_reaches[:] = starts[:, None], ray_reach
        blocked = visibility.blocked_unit(ray_starts.reshape(-1, 3), directions.reshape(-1, 3), ray_reaches.reshape(-1),
                                          jittered=jittered)
        return _seen(blocked).reshape(shape)


def _seen(blocked: np.ndarray) -> np.ndarray:
    """What gets through, from what ``Visibility.blocked_unit`` stops (bool, or shares)."""
    return ~blocked if blocked.dtype == bool else 1.0 - blocked


def _frames(normals: np.ndarray) -> np.ndarray:
    """(m, 3, 3) float32 frames about unit ``normals`` (m, 3): rows tangent, bitangent, normal."""
    return orthonormal_frames(normals).astype(np.float32)


def _cosine_directions(u: np.ndarray, cosine: np.ndarray, sine: np.ndarray, frames: np.ndarray) -> np.ndarray:
    """(m, k, 3) float32 cosine-distributed directions in ``frames`` (m, 3, 3, ``_frames``) from
    points (m, k) of the unit square by Malley's method: radius sqrt(u) on the disc, at the angle
    whose ``cosine`` and ``sine`` are given, lifted to the hemisphere."""
    radius = np.sqrt(u)
    local = np.empty((*np.shape(u), 3), np.float32)  # (m, k, 3), float32 as the rays are traced
    local[..., 0], local[..., 1], local[..., 2] = radius * cosine, radius * sine, np.sqrt(1 - u)
    return local @ frames


def _outline(through: np.ndarray) -> np.ndarray:
    """(m, K) bool: the strata of K = n x n directions (``_strata``' order) on the outline of what
    gets ``through`` (m, K) along them: those that differ from a neighbour (the angle wraps around,
    and so does the radius, as the rotation does), and the ring of strata around those."""
    side = int(round(math.sqrt(through.shape[1])))
    grid = through.reshape(-1, side, side)
    differs = np.zeros(grid.shape, bool)
    for axis in (1, 2):
        for step in (1, -1):
            differs |= grid != np.roll(grid, step, axis=axis)
    ring = np.zeros_like(differs)
    for across in (-1, 0, 1):
        for along in (-1, 0, 1):
            ring |= np.roll(differs, (across, along), axis=(1, 2))
    return ring.reshape(through.shape)


def _joined(columns: list[np.ndarray]) -> np.ndarray:
    """(m, E, 3) the sky's (m,) and the environment's (m, 3) light (``_each_direction``'s, reduced)."""
    return np.stack([np.broadcast_to(column[:, None], (len(column), 3)) if column.ndim == 1 else column
                     for column in columns], axis=1)


def _on_triangles(points: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """(..., ) whether each of ``points`` (..., 3), on the triangles' common plane, lies on one of
    ``triangles`` (K, 3, 3): barycentric coordinates, triangle by triangle."""
    inside = np.zeros(points.shape[:-1], dtype=bool)
    for a, b, c in triangles:
        e1, e2, w = b - a, c - a, points - a
        d11, d12, d22 = e1 @ e1, e1 @ e2, e2 @ e2
        w1, w2 = w @ e1, w @ e2
        denominator = d11 * d22 - d12 * d12
        u = (d22 * w1 - d12 * w2) / denominator
        v = (d11 * w2 - d12 * w1) / denominator
        inside |= (u >= 0) & (v >= 0) & (u + v <= 1)
    return inside


def _strata(count: int) -> np.ndarray:
    """(n^2, 2) centres of the n x n cells of the unit square, n = round(sqrt(count))."""
    side = int(round(math.sqrt(count)))
    return (np.stack(np.meshgrid(np.arange(side), np.arange(side)), axis=-1).reshape(-1, 2) + 0.5) / side

