"""Form factors between receiving points and patches, by hemicube or by ray casting, computed in
blocks sized to a ray budget so that memory stays bounded and progress is reported often."""

from __future__ import annotations

import copy
from functools import cached_property

import numpy as np

from ..mesh.discretize import Discretization, discretize
from ..rays.visibility import Visibility
from ..scene import Scene
from ..settings import METHODS
from ..util import parallel, spatial, streams
from ..util.geometry import longest_edges
from ..util.progress import Report, quiet
from . import hemicube, raycast, reach, receivers

# Rays and point-patch pairs per block: about 0.03 s of work on one core, so that progress is
# reported well within its 0.2 s promise while the pool stays busy.
RAYS_PER_BLOCK = 1 << 18
PAIRS_PER_BLOCK = 1 << 14
# From this many receivers (patches and nodes) on, a ray-cast shot evaluates only those in the box
# its source's own rays reach (``reach``), and a row from a point skips the patches whose boxes do
# not hold it: below it a box's rays cost more than they save (64 shots in one Cornell box: 0.15 s
# with boxes, 0.06 s without). In one room most boxes hold the room, and their rays cost about what
# the few others spare: once REACH_TRIALS boxes have been made (for shots or rows), it goes on
# making boxes while they spare on average at least REACH_GAIN of the receivers each
# (docs/notes/experiments.md, "Shots and rows searched where the light reaches").
REACH_RECEIVERS = 2_000
REACH_TRIALS = 64
REACH_GAIN = 0.25
# A box that holds more than this share of the receivers is not worth the search: the shot
# evaluates them all by matrix products instead. (At a half, a room of two in a row was never
# searched: its box reaches past the wall between them; two Cornell boxes 3.3 -> 2.9 s at 0.75.)
REACH_SHARE = 0.75
# Sources whose reach boxes are found at once (about 90 kB each while their rays are traced).
REACH_BLOCK = 1024
# Pixels across the hemicube that measures how much of a shooter's light lands on patches.
CAPTURE_RESOLUTION = 8
# With ``light_means`` (a bake whose lights shoot and Monte Carlo carries the rest), a patch whose
# longest edge is over MEAN_REACH times its distance to a light made of surfaces (an emitting
# patch that reflects nothing; a lower bound of the distance: from the patch's centroid to the
# light's plane or bounding sphere, the farther) receives the light's shot as the mean over
# MEAN_POINTS stratified points of it, each read by MEAN_RAYS directions in the light's solid
# angle (``raycast.RayCaster.solid_angle_form_factors``; all of a patch's directions one
# lattice), not at its centroid: so close, the light across it is far from linear, and the
# patch's light feeds every bounce. On Sponza the walls' tops under the sky quad are lit most
# halfway down: their centroids took in 3.0 % more than the quad sends, which the bounces carried
# into every corner's indirect light (1.2 % too bright): docs/notes/experiments.md, "The
# emitters' light at the nodes". The classic solvers keep the centroids, where a closed room's
# form factors sum to 1 and a regular one's are exact (16 points read a face beside the light
# 2 % off).
MEAN_REACH = 0.25
MEAN_POINTS = 16
MEAN_RAYS = 4


class FormFactorEngine:
    """Rows F(point -> every patch) and shooting columns F(every patch -> one patch) of a
    discretised scene. A patch receives at ``receiving_points`` (its centroid unless partly
    buried: see ``receivers``), facing its normal."""

    def __init__(
        self,
        mesh: Discretization,
        method: str = "raycast",
        hemicube_resolution: int = 64,
        rays_per_form_factor: int = 16,
        seed: int = 0,
        visibility: Visibility | None = None,
        probing: bool = False,
        light_means: bool = False,
    ) -> None:
        """``visibility`` may be shared with an engine of the same scene (its triangles are
        what occludes, whatever the patches); ``probing``: see ``raycast.RayCaster``;
        ``light_means``: the shots of lights reach the patches close to them as their means
        (MEAN_REACH, ``shooting_columns``)."""
        if method not in METHODS:
            raise ValueError(f"method must be one of {METHODS}, got {method!r}")
        self.mesh = mesh
        self.method = method
        self.resolution = hemicube_resolution
        self._ray_settings = (rays_per_form_factor, seed, probing)
        self.light_means = light_means
        self._reach_record = [0, 0.0]  # boxes made for shots and rows, the shares of receivers they spared
        # the box each patch's light reaches (``_reach_boxes``; unbounded until made), and whether made
        self._reached = (np.full((mesh.patch_count, 3), -np.inf), np.full((mesh.patch_count, 3), np.inf))
        self._box_made = np.zeros(mesh.patch_count, dtype=bool)
        if method == "hemicube":
            hemicube.pixels(hemicube_resolution)  # validates the resolution
        else:
            raycast.check_ray_count(rays_per_form_factor)
        front = mesh.front_patch_count
        if visibility is None:
            visibility = Visibility(mesh.patch_corners[:front], two_sided=mesh.back_of_front >= 0,
                                    owners=mesh.patch_triangle[:front], casting=mesh.front_casts,
                                    opacity=mesh.front_opacity)
        self.visibility = visibility
        self.receiving_points = receivers.receiving_points(mesh, self.visibility)
        self.raycaster = None if method == "hemicube" else raycast.RayCaster(
            mesh.patch_corners, mesh.patch_normals, mesh.patch_areas, self.visibility, rays_per_form_factor, seed,
            patch_owners=mesh.patch_triangle, probing=probing, emitting=mesh.patch_emission.any(axis=1))

    def refined(self, mesh: Discretization) -> FormFactorEngine:
        """An engine with this one's settings for ``mesh``, this one's patches refined: ray
        casting keeps this one's occluders (the same surfaces), the hemicube traces the new
        patches (its pixels show patch indices)."""
        rays, seed, probing = self._ray_settings
        return FormFactorEngine(mesh, self.method, self.resolution, rays, seed,
                                visibility=self.visibility if self.method == "raycast" else None, probing=probing,
                                light_means=self.light_means)

    def point_form_factors(self, points: np.ndarray, normals: np.ndarray, receivers: np.ndarray,
                           sources: np.ndarray, finely: np.ndarray | None = None) -> np.ndarray:
        """(n,) ray-cast form factors from points[receivers] (facing normals[receivers]) to
        patches ``sources``, pairwise, whatever the method (the hemicube's are per pixel, not per
        pair); ``finely``: see ``raycast.RayCaster.form_factors``."""
        return self._point_raycaster.form_factors(points, normals, receivers, sources, finely)

    def with_surfaces(self, mesh: Discretization) -> FormFactorEngine:
        """This engine for ``mesh``, this one's patches with other reflectance and emission
        (``mesh.surfaces.resurfaced``): its rays, samples and receiving points are shared."""
        engine = copy.copy(self)
        engine.mesh = mesh
        return engine

    def emitted_light(self, points: np.ndarray, normals: np.ndarray) -> np.ndarray:
        """(m, 3) sum_e F(point -> e) E_e over the emitting patches e: the light of the first
        shot of each emitter at points (m, 3) facing normals (m, 3)."""
        emitters, factors = self.emitter_form_factors(points, normals)
        return factors @ self.mesh.patch_emission[emitters]

    def emitter_form_factors(self, points: np.ndarray, normals: np.ndarray,
                             finely: bool = True) -> tuple[np.ndarray, np.ndarray]:
        """The emitting patches (e,) and the form factors (m, e) from points (m, 3) facing normals
        (m, 3) to them, read ``finely`` (two sets of ``raycast.EMITTER_RAYS``, and
        ``EMITTER_MIXED_RAYS`` or ``CLOSE_MIXED_RAYS``, each or the rays if more, where those
        disagree: for points where colours are shown, as the nodes) or as a patch reads them."""
        mesh = self.mesh
        emitters = np.flatnonzero(mesh.patch_emission.any(axis=1))
        factors = np.zeros((len(points), len(emitters)))
        if len(emitters) == 0 or len(points) == 0:
            return emitters, factors
        bounded = np.zeros(len(emitters), dtype=bool)
        if self._reaching():  # as a shot would: in their boxes (``reach``)
            low, high = self._reach_of(emitters)
            bounded = self._few_inside(low, high)
        unbounded = np.flatnonzero(~bounded)
        receivers = np.repeat(np.arange(len(points)), len(unbounded))
        chosen = np.tile(unbounded, len(points))
        if bounded.any():
            inside = np.flatnonzero(bounded)
            found, which = self._facing_in_boxes(points, normals, emitters[inside], low[inside], high[inside])
            receivers, chosen = np.concatenate([receivers, found]), np.concatenate([chosen, inside[which]])
        size, fine = PAIRS_PER_BLOCK, np.full(len(points), finely)
        factors[receivers, chosen] = np.concatenate([np.zeros(0), *parallel.map_ordered(
            lambda start: self.point_form_factors(points, normals, receivers[start:start + size],
                                                  emitters[chosen[start:start + size]], fine),
            range(0, len(receivers), size))])
        return emitters, factors

    def _facing_in_boxes(self, points: np.ndarray, normals: np.ndarray, sources: np.ndarray, low: np.ndarray,
                         high: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Index pairs (i, j) of the points (m, 3) facing normals (m, 3) that lie in the box of
        patch ``sources[j]`` (corners ``low``, ``high`` (k, 3)) and face it (``RayCaster.faces``)."""
        return spatial.points_in_boxes(points, low, high, lambda receivers, chosen: self._point_raycaster.faces(
            points[receivers], normals[receivers], sources[chosen]))

    def _reaching(self) -> bool:
        """Whether shots and rows make and search the boxes their sources' rays reach (``reach``):
        from REACH_RECEIVERS receivers on, while the boxes made spare REACH_GAIN of the receivers
        each on average, or fewer than REACH_TRIALS were made."""
        made, spared = self._reach_record
        return len(self._shot_receivers[0]) >= REACH_RECEIVERS and (made < REACH_TRIALS or spared >= REACH_GAIN * made)

    def _searched(self, patches: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The reach boxes of ``patches`` (k,) (``_reach_boxes``) and (k,) bool, whether each is
        worth searching (``_few_inside``), counted for ``_reaching``."""
        low, high = self._reach_boxes(patches)
        share = self._shares_inside(low, high)
        bounded = share <= REACH_SHARE
        self._reach_record[0] += len(patches)
        self._reach_record[1] += float((1.0 - share[bounded]).sum())
        return low, high, bounded

    def _reach_of(self, patches: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``reach.reach_boxes`` of ``patches`` (k,), each made once (``_reach_boxes``; an engine
        ``with_surfaces`` shares them, the geometry being the same)."""
        missing = patches[~self._box_made[patches]]
        if len(missing):
            self._reach_boxes(missing)
        return self._reached[0][patches], self._reached[1][patches]

    def _reach_boxes(self, patches: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``reach.reach_boxes`` of ``patches`` (k,), in blocks of at most REACH_BLOCK on the pool's
        threads (a patch's box follows from its own rays alone), kept for the rows (``_block``)."""
        mesh = self.mesh
        pieces = max(parallel.THREADS, -(-len(patches) // REACH_BLOCK))
        blocks = np.array_split(patches, max(1, min(len(patches), pieces)))
        boxes = list(parallel.map_ordered(lambda chosen: reach.reach_boxes(
            mesh.patch_corners[chosen], mesh.patch_normals[chosen], chosen, self.visibility, self._ray_settings[1]),
            blocks))
        low, high = (np.concatenate(corners) for corners in zip(*boxes))
        self._box_made[patches] = True
        self._reached[0][patches], self._reached[1][patches] = low, high
        return low, high

    @cached_property
    def _point_raycaster(self) -> raycast.RayCaster:
        if self.raycaster is not None:
            return self.raycaster
        mesh = self.mesh
        rays, seed, probing = self._ray_settings
        return raycast.RayCaster(mesh.patch_corners, mesh.patch_normals, mesh.patch_areas, self.visibility,
                                 rays, seed, patch_owners=mesh.patch_triangle, probing=probing,
                                 emitting=mesh.patch_emission.any(axis=1))

    @cached_property
    def _mean_rotations(self) -> np.ndarray:
        """(P, 1, 2) the Cranley-Patterson rotation of each patch's points where it receives a
        shot as a mean (``_near_patch_means``): its own, whichever patches are so read."""
        return streams.generator(self._ray_settings[1], streams.MEAN_POINTS).random((self.mesh.patch_count, 1, 2))

    @cached_property
    def _shot_receivers(self) -> tuple[np.ndarray, np.ndarray]:
        """Points and normals (P + N, 3) of everything a ray-cast shot reaches: patches, nodes."""
        mesh = self.mesh
        return (np.concatenate([self.receiving_points, mesh.node_points]),
                np.concatenate([mesh.patch_normals, mesh.node_normals]))

    @cached_property
    def _shot_receivers_by_axis(self) -> tuple[np.ndarray, np.ndarray]:
        """(3, P + N) each: the receivers in their order along each axis, and their coordinates
        in that order."""
        coordinates = self._shot_receivers[0].T
        order = np.argsort(coordinates, axis=1, kind="stable")
        return order, np.take_along_axis(coordinates, order, axis=1)

    def _slabs(self, low: np.ndarray, high: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(3, k) each: where the receivers within each box's sides (corners (k, 3)) along each
        axis start and end in that axis's order (``_shot_receivers_by_axis``)."""
        by_axis = self._shot_receivers_by_axis[1]
        return (np.stack([np.searchsorted(by_axis[axis], low[:, axis]) for axis in range(3)]),
                np.stack([np.searchsorted(by_axis[axis], high[:, axis], side="right") for axis in range(3)]))

    def _few_inside(self, low: np.ndarray, high: np.ndarray) -> np.ndarray:
        """(k,) bool: whether at most REACH_SHARE of the receivers lie in each box (corners (k, 3)),
        which a shot then searches (``_shares_inside``)."""
        return self._shares_inside(low, high) <= REACH_SHARE

    def _shares_inside(self, low: np.ndarray, high: np.ndarray) -> np.ndarray:
        """(k,) the share of the receivers in each box (corners (k, 3)), taken as the product of
        the shares within its sides along each axis (exact for rooms in a row or in a grid, where
        any one axis' slab holds a row of rooms); 1 for an unbounded box. It only chooses how a
        shot finds its receivers."""
        first, last = self._slabs(low, high)
        share = np.prod((last - first) / len(self._shot_receivers[0]), axis=0)
        return np.where(np.isfinite(low).all(axis=1), share, 1.0)

    def _receivers_within(self, low: np.ndarray, high: np.ndarray) -> np.ndarray:
        """(m,) sorted: the receivers whose coordinate along one axis, the one where the fewest
        do, lies within ``low``..``high`` (3,): a superset of those in that box, so that a batch
        of shots searches its room's slab, not the whole scene."""
        first, last = (ends[:, 0] for ends in self._slabs(low[None], high[None]))
        axis = int(np.argmin(last - first))
        return np.sort(self._shot_receivers_by_axis[0][axis, first[axis]:last[axis]])

    @property
    def rays_cast(self) -> int:
        return self.visibility.rays_cast

    def working_bytes(self) -> int:
        """Estimated peak of the ray-cast sample points and reach boxes and of the temporary
        arrays of the blocks in flight (one per thread, and one waiting): per ray-cast pair about
        200 bytes plus 32 per ray, and a block of rows' RAYS_PER_BLOCK pairs tested 40 bytes each;
        per hemicube ray about 100 bytes plus the block's dense rows (upper bounds, from
        tracemalloc)."""
        in_flight = parallel.THREADS + 1
        if self.method == "hemicube":
            rows = self._rows_per_block(0)
            return in_flight * (rows * len(hemicube.pixels(self.resolution)[1]) * 100
                                + rows * self.mesh.patch_count * 16)
        kept = self.raycaster.sample_bytes + sum(part.nbytes for part in (*self._reached, self._box_made))  # whole bake
        return kept + in_flight * (self._pairs_per_block() * (200 + 32 * self.raycaster.rays) + 40 * RAYS_PER_BLOCK)

    def _pairs_per_block(self) -> int:
        return max(1, min(PAIRS_PER_BLOCK, RAYS_PER_BLOCK // self.raycaster.rays))

    def rows(self, points: np.ndarray, normals: np.ndarray, report: Report = quiet) -> np.ndarray:
        """(m, P) form factors from points (m, 3) facing normals (m, 3) to every patch."""
        sources = np.arange(self.mesh.patch_count)
        result = np.empty((len(points), len(sources)))  # filled in place: the matrix exists once
        start = 0
        for block in self._blocks(points, normals, sources, lambda block: block, report):
            result[start : start + len(block)] = block
            start += len(block)
        return result

    def gather(self, points: np.ndarray, normals: np.ndarray, radiosity: np.ndarray,
               report: Report = quiet) -> np.ndarray:
        """(m, C) sum_q F(point -> q) B_q at each point, without storing F."""
        if len(points) == 0:
            return np.zeros((0, radiosity.shape[1]))
        sources = np.flatnonzero(radiosity.any(axis=1))
        parts = self._blocks(points, normals, sources, lambda block: block @ radiosity[sources], report)
        return np.concatenate(list(parts)).reshape(len(points), radiosity.shape[1])

    def gather_rows(self, points: np.ndarray, normals: np.ndarray, sources: np.ndarray,
                    report: Report = quiet) -> np.ndarray:
        """(m, k) F(point -> q) for the patches ``sources`` (k,), to ``gather_with`` again."""
        if len(points) == 0:
            return np.zeros((0, len(sources)))
        return np.concatenate(list(self._blocks(points, normals, sources, lambda block: block, report)))

    def gather_with(self, rows: np.ndarray, sources: np.ndarray, radiosity: np.ndarray) -> np.ndarray:
        """(m, C) ``gather`` from ``gather_rows``' rows (m, k) of the patches ``sources``, which
        hold every patch of ``radiosity`` (P, C) that shines (the same sums, block by block)."""
        size = self._rows_per_block(len(sources))
        return np.concatenate([rows[start:start + size] @ radiosity[sources]
                               for start in range(0, len(rows), size)] or [np.zeros((0, radiosity.shape[1]))])

    def _blocks(self, points, normals, sources, finish, report):
        """finish(F block) for consecutive blocks of points, computed in parallel, in order (at
        least four a thread, so that they end together); by ray casting, the reach boxes of the
        ``sources`` that have none made first while they pay (``_reaching``), so that a row skips
        the patches whose light cannot reach it, as a shot would (Jacobi's and Gauss-Seidel's
        matrix, the gathers at the nodes, in a scene of many rooms)."""
        if self.raycaster is not None:
            unknown = sources[~self._box_made[sources]]
            for start in range(0, len(unknown), REACH_TRIALS):
                if not self._reaching():
                    break
                self._searched(unknown[start:start + REACH_TRIALS])
        size = max(1, min(self._rows_per_block(len(sources)), -(-len(points) // (4 * parallel.THREADS))))
        starts = range(0, len(points), size)

        def one(start):
            stop = min(start + size, len(points))
            return finish(self._block(points[start:stop], normals[start:stop], sources))

        for done, part in enumerate(parallel.map_ordered(one, starts), 1):
            report(min(1.0, done * size / max(1, len(points))))
            yield part

    def patch_rows(self, patches: np.ndarray, report: Report = quiet) -> np.ndarray:
        """(m, P) F[p, q] for the receiving patches ``patches``."""
        mesh = self.mesh
        return self.rows(self.receiving_points[patches], mesh.patch_normals[patches], report)

    def shooting_columns(self, sources: np.ndarray, report: Report = quiet) -> tuple[list, np.ndarray]:
        """F[r, q] for every receiver r and each patch q in ``sources`` (k,): what q shoots, one
        column per source, either (P + N,) values or, for a source whose reach is bounded, the
        receivers (int32) and values of its nonzero ones; and the share of each q's light that
        lands on a patch (k,): 1 in a closed scene.

        Ray casting evaluates the columns directly at every patch centroid and every node (from
        REACH_RECEIVERS on, only at those in the box the source's own rays reach, ``reach``: the
        others are 0, and the work of a shot grows with its room, not with the scene), and
        measures the share with a small hemicube (CAPTURE_RESOLUTION) at the source; the
        hemicube sees from each source and uses reciprocity, F[p, q] = A_q F[q, p] / A_p (Cohen
        et al. 1988), for the patches only ((P,) values), and its row sum is the share.
        """
        mesh = self.mesh
        if self.method == "hemicube":
            rows = self.rows(self.receiving_points[sources], mesh.patch_normals[sources], report)
            columns = np.divide(rows.T * mesh.patch_areas[sources], mesh.patch_areas[:, None],
                                out=np.zeros((mesh.patch_count, len(sources))), where=mesh.patch_areas[:, None] > 0)
            return list(columns.T), rows.sum(axis=1)
        capture = parallel.submit(hemicube.visible_patches, self.receiving_points[sources], mesh.patch_normals[sources],
                                  CAPTURE_RESOLUTION, self.visibility, mesh)
        points, normals = self._shot_receivers
        finely = np.arange(len(points)) >= mesh.patch_count  # the nodes read the emitters finely
        columns: list = [None] * len(sources)
        bounded = np.zeros(len(sources), dtype=bool)
        if self._reaching():
            low, high, bounded = self._searched(sources)  # (at most a batch of shots)
        unbounded = np.flatnonzero(~bounded)
        if len(unbounded):
            dense = np.zeros((len(points), len(unbounded)))
            pieces = max(parallel.THREADS, -(-len(points) * len(unbounded) // self._pairs_per_block()))
            chunks = np.array_split(np.arange(len(points)), min(pieces, len(points)))
            for done, (chunk, part) in enumerate(zip(chunks, parallel.map_ordered(
                    lambda rows: self.raycaster.grid_form_factors(points[rows], normals[rows], sources[unbounded],
                                                                  finely[rows]),
                    chunks)), 1):
                dense[chunk] = part
                report(done / len(chunks) * len(unbounded) / len(sources))
            for j, column in zip(unbounded, dense.T):
                columns[j] = column
        if bounded.any():
            inside = np.flatnonzero(bounded)
            nearby = self._receivers_within(low[inside].min(axis=0), high[inside].max(axis=0))
            receivers, chosen = self._facing_in_boxes(points[nearby], normals[nearby], sources[inside], low[inside],
                                                      high[inside])
            receivers = nearby[receivers]
            values = np.zeros(len(receivers))
            size = max(1, min(self._pairs_per_block(), -(-len(receivers) // parallel.THREADS)))  # every thread busy
            starts = range(0, len(receivers), size)
            for done, (start, part) in enumerate(zip(starts, parallel.map_ordered(
                    lambda start: self.raycaster.form_factors(points, normals, receivers[start:start + size],
                                                              sources[inside[chosen[start:start + size]]], finely),
                    starts)), 1):
                values[start:start + size] = part
                report((len(unbounded) + done / len(starts) * len(inside)) / len(sources))
            kept = values != 0
            receivers, chosen, values = receivers[kept], chosen[kept], values[kept]
            order = np.argsort(chosen, kind="stable")
            bounds = np.searchsorted(chosen[order], np.arange(len(inside) + 1))
            for j, first, last in zip(inside, bounds[:-1], bounds[1:]):
                columns[j] = (receivers[order[first:last]].astype(np.int32), values[order[first:last]])
        if self.light_means:
            self._near_patch_means(sources, columns)
        seen, factors = capture.result()
        return columns, (factors * (seen >= 0)).sum(axis=1)

    def _near_patch_means(self, sources: np.ndarray, columns: list) -> None:
        """Set in ``columns`` (as ``shooting_columns`` makes them) the form factors from the
        patches lit at their centroid by a source of ``sources`` to it as their mean where they
        are close to a light (``_means_near_lights``)."""
        mesh = self.mesh
        lights = np.flatnonzero(mesh.patch_emission[sources].any(axis=1) & ~mesh.patch_reflectance[sources].any(axis=1))
        lit = []  # (patches, places in the column) per light
        for j in lights:
            column = columns[j]
            if isinstance(column, np.ndarray):
                places = np.flatnonzero(column[: mesh.patch_count])
                lit.append((places, places))
            else:
                places = np.flatnonzero(column[0] < mesh.patch_count)
                lit.append((column[0][places], places))
        if not lit:
            return
        patches = np.concatenate([patches for patches, _ in lit]).astype(np.int64)
        chosen = np.repeat(lights, [len(patches) for patches, _ in lit])
        places = np.concatenate([places for _, places in lit])
        near, means = self._means_near_lights(patches, sources[chosen])
        for j in np.unique(chosen[near]):
            mine = chosen[near] == j
            values = columns[j] if isinstance(columns[j], np.ndarray) else columns[j][1]
            values[places[near][mine]] = means[mine]

    def _means_near_lights(self, patches: np.ndarray, sources: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Of the pairs of ``patches`` and lights ``sources`` (n,) each, those (k,) where the patch
        is close to its light (MEAN_REACH) and receives at its centroid (not partly buried), and
        the mean over MEAN_POINTS stratified points of each such patch of its form factor to its
        light, each from MEAN_RAYS directions (k,)."""
        mesh = self.mesh
        centroids = mesh.patch_centroids[patches]
        source_centres = mesh.patch_centroids[sources]
        radii = np.linalg.norm(mesh.patch_corners[sources] - source_centres[:, None], axis=2).max(axis=1)
        apart = np.maximum(np.linalg.norm(centroids - source_centres, axis=1) - radii,
                           np.abs(np.einsum("kx,kx->k", centroids - source_centres, mesh.patch_normals[sources])))
        near = np.flatnonzero((apart * MEAN_REACH < longest_edges(mesh.patch_corners[patches]))
                              & (self.receiving_points[patches] == centroids).all(axis=1))
        rotation = self._mean_rotations[patches[near]]
        points = raycast.stratified_samples(mesh.patch_corners[patches[near]], MEAN_POINTS, rotation).reshape(-1, 3)
        normals = np.repeat(mesh.patch_normals[patches[near]], MEAN_POINTS, axis=0)
        to = np.repeat(sources[near], MEAN_POINTS)
        # point k of a patch takes the directions k, k + MEAN_POINTS, ... of one rank-1 lattice
        directions = raycast.lattice(MEAN_POINTS * MEAN_RAYS).reshape(MEAN_RAYS, MEAN_POINTS, 2).transpose(1, 0, 2)
        uv = ((directions[None] + rotation[:, :, None, ::-1]) % 1.0).reshape(-1, MEAN_RAYS, 2)
        size = max(1, self._pairs_per_block() // MEAN_RAYS)
        means = np.concatenate([np.zeros(0), *parallel.map_ordered(
            lambda start: self.raycaster.solid_angle_form_factors(
                points[start:start + size], normals[start:start + size], np.arange(len(to[start:start + size])),
                to[start:start + size], uv[start:start + size]),
            range(0, len(to), size))]).reshape(-1, MEAN_POINTS).mean(axis=1)
        return near, means

    def _rows_per_block(self, source_count: int) -> int:
        """Points a block of rows takes: RAYS_PER_BLOCK hemicube rays, or RAYS_PER_BLOCK pairs
        tested by ray casting (most of a room's face away: ``RayCaster.facing_pairs``)."""
        if self.method == "hemicube":
            return max(1, RAYS_PER_BLOCK // len(hemicube.pixels(self.resolution)[1]))
        return max(1, RAYS_PER_BLOCK // max(1, source_count))

    def _block(self, points: np.ndarray, normals: np.ndarray, sources: np.ndarray) -> np.ndarray:
        """(m, k) form factors from points (m, 3) facing normals (m, 3) to the patches ``sources``
        (k,); by ray casting, a point outside the box a source's light reaches (``_reach_boxes``,
        where it was made) is taken as unseen by it, as a shot takes it, and the pairs left are
        measured PAIRS_PER_BLOCK at a time."""
        mesh = self.mesh
        if self.method == "hemicube":
            full = hemicube.form_factor_rows(points, normals, self.resolution, self.visibility, mesh)
            return full[:, sources]
        low, high = self._reached[0][sources], self._reached[1][sources]
        receivers, chosen = self.raycaster.facing_pairs(points, normals, sources,
                                                        (low, high) if np.isfinite(low).any() else None)
        result = np.zeros((len(points), len(sources)))
        size = self._pairs_per_block()
        for start in range(0, len(receivers), size):
            pairs = slice(start, start + size)
            result[receivers[pairs], chosen[pairs]] = self.raycaster.form_factors(
                points, normals, receivers[pairs], sources[chosen[pairs]])
        return result


def form_factor_matrix(
    vertices: np.ndarray,
    triangles: np.ndarray,
    method: str = "hemicube",
    *,
    patch_size: float | None = None,
    hemicube_resolution: int = 64,
    rays_per_form_factor: int = 16,
    seed: int = 0,
    probe_rays: bool = False,
) -> np.ndarray:
    """(T, T) float64 form factors F[i, j] from input triangle i to input triangle j (front
    sides), occlusion by the other triangles included; ``probe_rays`` as in BakeSettings (off:
    every ray is cast).

    Each triangle is one patch receiving at its centroid; with ``patch_size`` it is split into
    patches no longer than that, and F[i, j] = sum_{p in i} A_p/A_i sum_{q in j} F[p, q]
    (the receiver's area average, better as patches shrink).
    """
    vertices = np.asarray(vertices, dtype=np.float64)
    triangles = np.asarray(triangles)
    count = len(triangles)
    scene = Scene(vertices, triangles, np.zeros((count, 3)), np.zeros((count, 3)))
    mesh = discretize(scene, patch_size)
    engine = FormFactorEngine(mesh, method, hemicube_resolution, rays_per_form_factor, seed, probing=probe_rays)
    patch_matrix = engine.patch_rows(np.arange(mesh.patch_count))
    owner = mesh.patch_triangle  # sorted: a triangle's patches are consecutive
    present, starts = np.unique(owner, return_index=True)
    by_source = np.add.reduceat(patch_matrix, starts, axis=1)  # (P, triangles with patches)
    weights = mesh.patch_areas / np.bincount(owner, weights=mesh.patch_areas, minlength=count)[owner]
    result = np.zeros((count, count))
    result[np.ix_(present, present)] = np.add.reduceat(by_source * weights[:, None], starts, axis=0)
    return result
