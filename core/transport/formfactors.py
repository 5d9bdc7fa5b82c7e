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
from ..util import parallel
from ..util.progress import Report, quiet
from . import hemicube, raycast, receivers

# Rays and point-patch pairs per block: about 0.03 s of work on one core, so that progress is
# reported well within its 0.2 s promise while the pool stays busy.
RAYS_PER_BLOCK = 1 << 18
PAIRS_PER_BLOCK = 1 << 14
# Pixels across the hemicube that measures how much of a shooter's light lands on patches.
CAPTURE_RESOLUTION = 8


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
    ) -> None:
        """``visibility`` may be shared with an engine of the same scene (its triangles are
        what occludes, whatever the patches); ``probing``: see ``raycast.RayCaster``."""
        if method not in METHODS:
            raise ValueError(f"method must be one of {METHODS}, got {method!r}")
        self.mesh = mesh
        self.method = method
        self.resolution = hemicube_resolution
        self._ray_settings = (rays_per_form_factor, seed, probing)
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
                                visibility=self.visibility if self.method == "raycast" else None, probing=probing)

    def point_form_factors(self, points: np.ndarray, normals: np.ndarray, receivers: np.ndarray,
                           sources: np.ndarray) -> np.ndarray:
        """(n,) ray-cast form factors from points[receivers] (facing normals[receivers]) to
        patches ``sources``, pairwise, whatever the method (the hemicube's are per pixel, not per
        pair)."""
        return self._point_raycaster.form_factors(points, normals, receivers, sources)

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

    def emitter_form_factors(self, points: np.ndarray, normals: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The emitting patches (e,) and the form factors (m, e) from points (m, 3) facing normals
        (m, 3) to them."""
        mesh = self.mesh
        emitters = np.flatnonzero(mesh.patch_emission.any(axis=1))
        if len(emitters) == 0 or len(points) == 0:
            return emitters, np.zeros((len(points), len(emitters)))
        receivers = np.repeat(np.arange(len(points)), len(emitters))
        sources = np.tile(emitters, len(points))
        size = PAIRS_PER_BLOCK
        factors = np.concatenate(list(parallel.map_ordered(
            lambda start: self.point_form_factors(points, normals, receivers[start:start + size],
                                                  sources[start:start + size]),
            range(0, len(receivers), size))))
        return emitters, factors.reshape(len(points), len(emitters))

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
    def _shot_receivers(self) -> tuple[np.ndarray, np.ndarray]:
        """Points and normals (P + N, 3) of everything a ray-cast shot reaches: patches, nodes."""
        mesh = self.mesh
        return (np.concatenate([self.receiving_points, mesh.node_points]),
                np.concatenate([mesh.patch_normals, mesh.node_normals]))

    @property
    def rays_cast(self) -> int:
        return self.visibility.rays_cast

    def working_bytes(self) -> int:
        """Estimated peak of the ray-cast sample points and of the temporary arrays of the blocks
        in flight (one per thread, and one waiting): per ray-cast pair about 200 bytes plus 32
        per ray, per hemicube ray about 100 bytes plus the block's dense rows (upper bounds,
        from tracemalloc)."""
        in_flight = parallel.THREADS + 1
        if self.method == "hemicube":
            rows = self._rows_per_block(0)
            return in_flight * (rows * len(hemicube.pixels(self.resolution)[1]) * 100 + rows * self.mesh.patch_count * 16)
        samples = self.raycaster.sample_bytes  # kept for the whole bake
        return samples + in_flight * self._pairs_per_block() * (200 + 32 * self.raycaster.rays)

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
        """finish(F block) for consecutive blocks of points, computed in parallel, in order."""
        size = self._rows_per_block(len(sources))
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

    def shooting_columns(self, sources: np.ndarray, report: Report = quiet) -> tuple[np.ndarray, np.ndarray]:
        """F[r, q] for every receiver r and each patch q in ``sources`` (k,): what q shoots; and
        the share of each q's light that lands on a patch (k,): 1 in a closed scene.

        Ray casting evaluates the columns directly at every patch centroid and every node
        ((P + N, k) values), and measures the share with a small hemicube (CAPTURE_RESOLUTION)
        at the source; the hemicube sees from each source and uses reciprocity,
        F[p, q] = A_q F[q, p] / A_p (Cohen et al. 1988), for the patches only ((P, k) values),
        and its row sum is the share.
        """
        mesh = self.mesh
        if self.method == "hemicube":
            rows = self.rows(self.receiving_points[sources], mesh.patch_normals[sources], report)
            columns = np.divide(rows.T * mesh.patch_areas[sources], mesh.patch_areas[:, None],
                                out=np.zeros((mesh.patch_count, len(sources))), where=mesh.patch_areas[:, None] > 0)
            return columns, rows.sum(axis=1)
        capture = parallel.submit(hemicube.visible_patches, self.receiving_points[sources], mesh.patch_normals[sources],
                                  CAPTURE_RESOLUTION, self.visibility, mesh)
        points, normals = self._shot_receivers
        pieces = max(parallel.THREADS, -(-len(points) * len(sources) // self._pairs_per_block()))
        chunks = np.array_split(np.arange(len(points)), min(pieces, len(points)))

        def one(receivers):
            return self.raycaster.grid_form_factors(points[receivers], normals[receivers], sources)

        parts = []
        for part in parallel.map_ordered(one, chunks):
            parts.append(part)
            report(len(parts) / len(chunks))
        seen, factors = capture.result()
        return np.concatenate(parts), (factors * (seen >= 0)).sum(axis=1)

    def _rows_per_block(self, source_count: int) -> int:
        if self.method == "hemicube":
            return max(1, RAYS_PER_BLOCK // len(hemicube.pixels(self.resolution)[1]))
        return max(1, self._pairs_per_block() // max(1, source_count))

    def _block(self, points: np.ndarray, normals: np.ndarray, sources: np.ndarray) -> np.ndarray:
        mesh = self.mesh
        if self.method == "hemicube":
            full = hemicube.form_factor_rows(points, normals, self.resolution, self.visibility, mesh)
            return full[:, sources]
        return self.raycaster.grid_form_factors(points, normals, sources)


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
