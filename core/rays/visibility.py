"""Every ray of the project goes through here: segment occlusion and nearest hits, traced by
Embree (``embreex``) or, where that cannot be imported, by the slower ``numpy_tracer``; both
answer the same queries (``EmbreeScene.run``) on the same float32 triangles.

Every query is watertight unless its caller says its rays are ``jittered``: drawn at random
(origins or directions), as the gathers', the particles', the sky's and the shots' are, and lifted
off the surface they leave. Those go to a second Embree scene, built when first needed, that is
faster but may let a ray through an edge two triangles share (``embree_build``): a ray must pass
within float32 rounding of the edge, which a random ray almost never does (Sponza: 8 of 80 million
rays, the breakfast room 79 of 218 million; 14 of 400,000 from a node beside a room's corner),
and a ray along a grid (a hemicube's, a sun's, from one vertex to another) may.

The triangles are re-centred and scaled to unit size before they become float32 for Embree, and ray
offsets are a fixed fraction of that unit size, so results do not depend on the scene's scale.
embreex releases the GIL while it traces, so callers run batches from several threads (the NumPy
tracer is safe there too, but gains little: see ``numpy_tracer``); Embree's scenes are filled and
built with the GIL released too (``embree_build``), so other threads run meanwhile.
"""

from __future__ import annotations

import threading

import numpy as np

from ..util.geometry import ENCLOSING_TOLERANCE, areas_and_normals, enclosing
from ..util.overlaps import coplanar_overlap_pairs
from . import embree_build
from .numpy_tracer import NumpyTracer

# Rays start and stop this far (in unit space, where the scene's extent is 1) from their end points, so a
# ray does not hit the surface it leaves or the one it aims at (float32 resolves about 6e-8 there).
RAY_EPSILON = 1e-5
# Where another surface lies nearer than RAY_EPSILON along a point's normal (a face within a hair of
# another solid, laid on it or through it), its rays start half-way to that surface instead, but no
# nearer their own than LEAST_LIFT, from which the probe along the normal starts: a surface nearer
# still is not seen, and the rays start RAY_EPSILON off as before (``Visibility.lifted_unit``).
LEAST_LIFT = RAY_EPSILON / 32
BACKENDS = ("embree", "numpy")
# See-through triangles a ray is followed through (``Visibility.blocked_unit``): beyond, the
# light left is taken to go on unstopped.
MAX_LAYERS = 8
# What a built Embree scene holds (its BVH, its vertices, its device): upper bounds of the resident
# memory measured as scenes of 20,000 to 720,000 triangles were built, 90 to 150 bytes per triangle
# beyond about 5 MiB (69 to 118 on Sponza and the breakfast room).
EMBREE_BYTES_PER_TRIANGLE = 160
EMBREE_BYTES_PER_SCENE = 8 << 20


def _import_embree():
    """embreex's (EmbreeScene, TriangleMesh), imported only when asked for: ``core`` works
    without it."""
    from embreex import rtcore_scene
    from embreex.mesh_construction import TriangleMesh

    return rtcore_scene.EmbreeScene, TriangleMesh


def default_backend() -> str:
    """"embree" if embreex can be imported here, else "numpy"."""
    try:
        _import_embree()
    except (ImportError, OSError):  # OSError: the wheel is there but its library does not load
        return "numpy"
    return "embree"


class Visibility:
    """Ray queries against a fixed set of triangles.

    corners : (P, 3, 3) float, the occluding triangles (index p is what ``nearest`` returns).
    backend : "embree", "numpy" (``numpy_tracer``), or None for ``default_backend()``; the name
        used is ``self.backend``.
    triangle_normals : (P, 3) their unit normals (zero for a zero-area triangle).
    two_sided : (P,) bool, which of them have two faces (none unless given): ``receivers`` only.
    owners : (P,) int, the surface each belongs to (by default each its own): a ray aimed at a
        surface is not blocked by the surface itself (``raycast``).
    coplanar_pairs : (a, b), each b a triangle of another owner lying over a in its plane, each
        pair both ways (``overlaps.coplanar_overlap_pairs``).
    coplanar_overlaps : (P,) bool, whether a triangle has any.
    enclosing : (P,) bool, the triangles with every corner on or in front of their plane
        (``geometry.enclosing``, to ENCLOSING_TOLERANCE), as a room's walls:
        ``occluded_between_unit`` leaves them out.
    casting : (P,) bool, the triangles that block light (``Scene.casts_shadows``; None: all):
        the ``occluded`` and ``blocked`` queries see only those, ``first_hit_unit`` and
        ``nearest`` every one.
    opacity : (P,) float in [0, 1], the share of the light each triangle stops (``Scene.opacity``;
        None: all): the ``occluded`` queries see the opaque ones, ``blocked`` all that cast.
    opaque : (P,) bool, the triangles that cast and stop all the light.
    """

    def __init__(self, corners: np.ndarray, backend: str | None = None, two_sided: np.ndarray | None = None,
                 owners: np.ndarray | None = None, casting: np.ndarray | None = None,
                 opacity: np.ndarray | None = None) -> None:
        if backend is None:
            backend = default_backend()
        if backend not in BACKENDS:
            raise ValueError(f"backend must be one of {BACKENDS} or None, got {backend!r}")
        if backend == "embree":
            try:
                _import_embree()
            except (ImportError, OSError) as error:
                raise ImportError(
                    f"backend 'embree' needs the embreex package, which cannot be imported here ({error}); "
                    "use backend='numpy', or None to take what is available"
                ) from error
        self.backend = backend
        self.corners = corners
        points = corners.reshape(-1, 3)
        low, high = points.min(axis=0), points.max(axis=0)
        self.center = (low + high) / 2
        # unit extent: a scaled copy of a scene traces the same float32 rays (up to rounding)
        self.scale = 1.0 / max(float(np.linalg.norm(high - low)), np.finfo(float).tiny)
        unit_corners = self.to_unit(corners.reshape(-1, 3)).reshape(-1, 3, 3)
        self.triangle_normals = areas_and_normals(np.asarray(corners, dtype=np.float64))[1]
        self.two_sided = np.zeros(len(unit_corners), dtype=bool) if two_sided is None else np.asarray(two_sided, bool)
        self.owners = np.arange(len(unit_corners)) if owners is None else np.asarray(owners)
        self.coplanar_pairs = coplanar_overlap_pairs(np.asarray(corners, dtype=np.float64), self.owners)
        self.coplanar_overlaps = np.zeros(len(unit_corners), dtype=bool)
        self.coplanar_overlaps[self.coplanar_pairs[0]] = True
        # n . x of each triangle's plane in unit space, float64 (``raycast`` tells coplanar faces apart)
        self.unit_plane_offsets = (self.triangle_normals * unit_corners[:, 0].astype(np.float64)).sum(axis=1)
        self.enclosing = enclosing(np.asarray(corners, dtype=np.float64), ENCLOSING_TOLERANCE / self.scale)
        casting = np.ones(len(unit_corners), dtype=bool) if casting is None else np.asarray(casting, bool)
        self.opacity = np.ones(len(unit_corners)) if opacity is None else np.asarray(opacity, np.float64)
        opaque = casting & (self.opacity >= 1)
        self.opaque = opaque
        self._partial = np.flatnonzero(casting & (self.opacity > 0) & (self.opacity < 1))  # light goes through
        self._scene = _Traced(backend, unit_corners)
        self._occluders = self._subset(unit_corners, opaque)
        self._inner = self._subset(unit_corners, opaque & ~self.enclosing)
        self._see_through = self._subset(unit_corners, np.isin(np.arange(len(unit_corners)), self._partial))
        self.rays_cast = 0
        self._count_lock = threading.Lock()

    def _subset(self, unit_corners: np.ndarray, chosen: np.ndarray):
        """A traced scene of the ``chosen`` triangles of ``unit_corners`` (the whole scene's when
        it is all of them), or None when none is chosen."""
        if not chosen.any():
            return None
        return self._scene if chosen.all() else _Traced(self.backend, unit_corners[chosen])

    @property
    def bytes(self) -> int:
        """About the memory held: its traced scenes (each faster one once its first query built
        it) and the per-triangle arrays."""
        traced = {id(part): part for part in (self._scene, self._occluders, self._inner, self._see_through) if part}
        arrays = (self.triangle_normals, self.two_sided, self.owners, self.unit_plane_offsets, self.enclosing,
                  self.opacity, self.opaque, self.coplanar_overlaps, *self.coplanar_pairs)
        return sum(part.bytes for part in traced.values()) + sum(array.nbytes for array in arrays)

    def to_unit(self, points: np.ndarray) -> np.ndarray:
        """(n, 3) float32: world-space points in the unit space rays are traced in."""
        return np.ascontiguousarray((points - self.center) * self.scale, dtype=np.float32)

    def lifted_unit(self, points: np.ndarray, normals: np.ndarray) -> np.ndarray:
        """(n, 3) float32: where rays leaving ``points`` (n, 3) of surfaces facing unit ``normals``
        (n, 3) start, in unit space: RAY_EPSILON off the surface, or half-way (at least LEAST_LIFT)
        to another surface that a ray along the normal from LEAST_LIFT off meets within RAY_EPSILON.
        Lifted the whole RAY_EPSILON, the rays of a point a hair from a solid that leans over it
        started inside the solid and saw nothing (docs/notes/experiments.md, "Nodes that read no
        sky"); a surface within LEAST_LIFT of the point is not seen, so that band remains."""
        at = self.to_unit(points).astype(np.float64)
        lift = np.full(len(at), RAY_EPSILON)
        met = self._run(at + LEAST_LIFT * normals, normals, np.full(len(at), RAY_EPSILON - LEAST_LIFT), "INTERSECT")
        near = np.flatnonzero(met >= 0)
        if len(near):
            planes = self.triangle_normals[met[near]]
            slope = np.einsum("ij,ij->i", normals[near], planes)
            height = self.unit_plane_offsets[met[near]] - np.einsum("ij,ij->i", at[near], planes)
            distance = height / np.where(np.abs(slope) > 1e-12, slope, 1e-12)
            lift[near] = np.maximum(np.clip(distance, 0.0, RAY_EPSILON) / 2, LEAST_LIFT)
        return np.ascontiguousarray(at + lift[:, None] * normals, dtype=np.float32)

    @staticmethod
    def to_unit_directions(normals: np.ndarray) -> np.ndarray:
        """(n, 3) float32: unit vectors in unit space (which only shifts and scales)."""
        return np.ascontiguousarray(normals, dtype=np.float32)

    def occluded_unit(self, starts: np.ndarray, directions: np.ndarray, reach: np.ndarray,
                      jittered: bool = False) -> np.ndarray:
        """(n,) bool: whether a casting triangle lies on each ray start + t direction,
        0 <= t < reach, from starts (n, 3) along directions (n, 3, any length), in unit space (see
        ``to_unit``); a ray with reach <= 0 is not blocked. ``jittered``: the rays are drawn at
        random (the module's docstring)."""
        return self._occluded(starts, directions, reach, self._occluders, jittered)

    def occluded_between_unit(self, starts: np.ndarray, directions: np.ndarray, reach: np.ndarray) -> np.ndarray:
        """``occluded_unit`` for rays from points on or in front of the triangles' surfaces
        (lifted off them to their front) to points of those surfaces: no ``enclosing`` triangle
        can block them, so none is traced (the same answers, fewer triangles: in a room, its
        walls)."""
        return self._occluded(starts, directions, reach, self._inner, jittered=False)

    @property
    def see_through(self) -> bool:
        """Whether some casting triangles let part of the light through (``opacity``)."""
        return len(self._partial) > 0

    def blocked_unit(self, starts: np.ndarray, directions: np.ndarray, reach: np.ndarray,
                     between: bool = False, jittered: bool = False) -> np.ndarray:
        """(n,) the share of the light along each ray (as ``occluded_unit``; ``between``: as
        ``occluded_between_unit``) that the casting triangles stop: bool where every one is
        opaque, else float, 1 - prod (1 - opacity) over the triangles crossed (the first
        MAX_LAYERS of those that let light through)."""
        blocked = self._occluded(starts, directions, reach, self._inner if between else self._occluders, jittered)
        if not self.see_through:
            return blocked
        share = blocked.astype(np.float64)
        open_rays = np.flatnonzero(~blocked & (np.asarray(reach) > 0))
        share[open_rays] = 1.0 - self._transmitted(starts[open_rays], directions[open_rays],
                                                   np.asarray(reach, np.float64)[open_rays], jittered)
        return share

    def _transmitted(self, starts, directions, reach, jittered) -> np.ndarray:
        """(n,) prod (1 - opacity) over the see-through triangles on each ray, layer by layer:
        the nearest one's plane gives where the ray goes on from."""
        starts = np.asarray(starts, np.float64).copy()
        directions = np.asarray(directions, np.float64)
        reach = np.asarray(reach, np.float64).copy()
        transmitted = np.ones(len(starts))
        going = np.arange(len(starts))
        for _ in range(MAX_LAYERS):
            if len(going) == 0:
                break
            hit = self._run(starts[going], directions[going], reach[going], "INTERSECT", self._see_through, jittered)
            going, hit = going[hit >= 0], hit[hit >= 0]
            triangle = self._partial[hit]
            transmitted[going] *= 1.0 - self.opacity[triangle]
            normals = self.triangle_normals[triangle]
            slope = (directions[going] * normals).sum(axis=1)
            slope = np.where(np.abs(slope) > 1e-12, slope, 1e-12)
            along = (self.unit_plane_offsets[triangle] - (starts[going] * normals).sum(axis=1)) / slope
            along = np.maximum(along, 0.0) + RAY_EPSILON / np.linalg.norm(directions[going], axis=1)
            starts[going] += along[:, None] * directions[going]
            reach[going] -= along
            going = going[reach[going] > 0]
        return transmitted

    def _occluded(self, starts, directions, reach, traced, jittered) -> np.ndarray:
        if traced is None:
            return np.zeros(len(starts), dtype=bool)
        test = np.flatnonzero(reach > 0)
        if len(test) == len(starts):
            return self._run(starts, directions, reach, "OCCLUDED", traced, jittered) != -1
        blocked = np.zeros(len(starts), dtype=bool)
        if len(test):
            blocked[test] = self._run(starts[test], directions[test], reach[test], "OCCLUDED", traced, jittered) != -1
        return blocked

    def first_hit_unit(self, starts: np.ndarray, directions: np.ndarray, reach: np.ndarray,
                       jittered: bool = False) -> np.ndarray:
        """(n,) int: the nearest triangle on each ray start + t direction, 0 <= t < reach, or -1,
        in unit space (as ``occluded_unit``)."""
        return self._run(starts, directions, reach, "INTERSECT", jittered=jittered)

    def nearest(self, origins: np.ndarray, directions: np.ndarray, lift: np.ndarray,
                jittered: bool = False) -> np.ndarray:
        """(n,) int: index of the first triangle along each ray (unit ``directions``), -1 for a
        miss. Rays start RAY_EPSILON off the surface they leave (along its unit normals
        ``lift``, (n, 3)) and RAY_EPSILON along their direction, so a ray nearly parallel to
        that surface does not hit it through float32 rounding."""
        start = (origins - self.center) * self.scale + RAY_EPSILON * (directions + lift)
        return self._run(start, directions, None, "INTERSECT", jittered=jittered)

    def _run(self, origins, directions, reach, query, traced=None, jittered=False) -> np.ndarray:
        """The scene's answer (``EmbreeScene.run``) for rays in unit space, on ``traced`` (None:
        every triangle)."""
        traced = self._scene if traced is None else traced
        origins = np.ascontiguousarray(origins, dtype=np.float32)
        directions = np.ascontiguousarray(directions, dtype=np.float32)
        if reach is not None:
            reach = np.ascontiguousarray(reach, dtype=np.float32)
        with self._count_lock:
            self.rays_cast += len(origins)
        return traced.scene(jittered).run(origins, directions, dists=reach, query=query)


class _Traced:
    """One set of float32 triangles (n, 3, 3) as scenes of ``backend`` ready to trace: watertight,
    and for rays ``jittered`` at random Embree's faster scene, built at their first query (the
    triangles are kept until then)."""

    def __init__(self, backend: str, triangles: np.ndarray) -> None:
        self._watertight = _traced(backend, triangles)
        self._count = len(triangles)
        self._triangles = triangles if backend == "embree" else None
        self._fast = None if backend == "embree" else self._watertight
        self._lock = threading.Lock()

    @property
    def bytes(self) -> int:
        """About the memory its scenes hold (Embree's, or the NumPy tracer's arrays)."""
        if isinstance(self._watertight, NumpyTracer):
            return self._watertight.bytes
        built = 1 if self._fast is None or self._fast is self._watertight else 2
        kept = 0 if self._triangles is None else self._triangles.nbytes
        return built * (self._count * EMBREE_BYTES_PER_TRIANGLE + EMBREE_BYTES_PER_SCENE) + kept

    def scene(self, jittered: bool):
        """The scene for rays in general position if ``jittered``, else the watertight one."""
        if not jittered:
            return self._watertight
        if self._fast is not None:
            return self._fast
        with self._lock:
            if self._fast is None:
                self._fast = embree_build.triangle_scene(self._triangles, robust=False) or self._watertight
                self._triangles = None
        return self._fast


def _traced(backend: str, triangles: np.ndarray):
    """A watertight scene of ``backend`` over float32 triangles (n, 3, 3), ready to trace."""
    if backend == "numpy":
        return NumpyTracer(triangles)
    built = embree_build.triangle_scene(triangles)
    if built is not None:
        return built
    embree_scene, triangle_mesh = _import_embree()
    scene = embree_scene()
    triangle_mesh(scene, triangles)
    # embreex builds the BVH on the first query, holding the GIL: do it now, while the bake says it
    # is preparing rays, rather than inside the first block of work
    scene.run(np.zeros((1, 3), np.float32), np.ones((1, 3), np.float32), query="OCCLUDED")
    return scene
