"""The two ray backends of ``core.rays.visibility``: Embree (embreex) and the NumPy tracer answer the
same queries alike, on random and adversarial rays and through the form-factor code, and core
works (and bakes) where embreex cannot be imported.

Embree and the NumPy tracer both test triangles in float32, with different formulas, so a ray
passing within float32 rounding (about 1e-7 of the scene) of a triangle's edge or of its own end
may be decided either way by each; random rays almost never do (measured: 0 of 200,000). Where
two triangles are hit at exactly the same distance (a shared edge, coincident triangles), either
is the nearest, and each backend may pick another one: INTERSECT results are compared by the
distance of the hit.
"""

import json
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest

from core import Scene, bake
from core.transport import hemicube
from core.mesh.discretize import discretize
from core.rays.numpy_tracer import NumpyTracer
from core.transport.raycast import RayCaster
from core.rays.visibility import BACKENDS, RAY_EPSILON, Visibility, default_backend
from tests.core.scenes import lit_room, merge, quad
from tests.core.test_occlusion import BLOCKER, HEIGHT, PLATE, centred_square_factor
from tests.core.test_occlusion import scene as occlusion_scene

ROOT = Path(__file__).resolve().parents[2]
HAVE_EMBREE = default_backend() == "embree"
AVAILABLE = [backend for backend in BACKENDS if backend == "numpy" or HAVE_EMBREE]
needs_embree = pytest.mark.skipif(not HAVE_EMBREE, reason="embreex cannot be imported here")


def run(visibility: Visibility, origins, directions, reach, query, jittered=False):
    """The backend's raw answer for rays in unit space (what occluded_unit and nearest call)."""
    return visibility._run(origins, directions, reach, query, jittered=jittered)


def hit_distance(unit_corners, origins, directions, index):
    """(n,) float64 t where each ray meets the plane of triangle ``index`` (NaN for -1)."""
    t = np.full(len(index), np.nan)
    hit = index >= 0
    corners = unit_corners[index[hit]].astype(np.float64)
    normal = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    offset = np.einsum("nx,nx->n", corners[:, 0] - origins[hit], normal)
    t[hit] = offset / np.einsum("nx,nx->n", directions[hit].astype(np.float64), normal)
    return t


def random_soup(rng, count=400):
    """Small triangles scattered in a cube of side 2: every ray meets a few boxes."""
    centres = rng.uniform(-1, 1, (count, 1, 3))
    return centres + rng.normal(scale=0.1, size=(count, 3, 3))


def closed_mesh(divisions: int, rng) -> np.ndarray:
    """(T, 3, 3) corners of a closed mesh: the cube [0, 1]^3, each face a grid of quads split in
    two along alternating diagonals, then rotated, stretched and its vertices jittered; every
    vertex is shared bitwise by the triangles around it."""
    ticks = np.linspace(0.0, 1.0, divisions + 1)
    corners = []
    for axis in range(3):
        u, v = [a for a in range(3) if a != axis]
        for side in (0.0, 1.0):
            for i in range(divisions):
                for j in range(divisions):
                    quad_corners = []
                    for di, dj in ((0, 0), (1, 0), (1, 1), (0, 1)):
                        point = np.zeros(3)
                        point[axis], point[u], point[v] = side, ticks[i + di], ticks[j + dj]
                        quad_corners.append(point)
                    a, b, c, d = quad_corners
                    corners += [[a, b, c], [a, c, d]] if (i + j) % 2 else [[a, b, d], [b, c, d]]
    vertices, corner_vertex = np.unique(np.array(corners).reshape(-1, 3), axis=0, return_inverse=True)
    rotation = np.linalg.qr(rng.normal(size=(3, 3)))[0]
    vertices = (vertices - 0.5) @ rotation.T * [1.0, 2.0, 0.7] + rng.normal(scale=0.2 / divisions, size=vertices.shape)
    return vertices[corner_vertex.ravel()].reshape(-1, 3, 3)


@needs_embree
@pytest.mark.parametrize("query", ["OCCLUDED", "INTERSECT"])
@pytest.mark.parametrize("bounded", [True, False])
@pytest.mark.parametrize("jittered", [False, True])
def test_backends_agree_on_random_rays(query, bounded, jittered):
    """Random origins, directions of random length (not unit) and random reach; a mismatch
    needs a ray within float32 rounding of an edge or of its end: at most 1 in 10,000, on
    Embree's watertight scene and on its faster one (``jittered``) alike."""
    rng = np.random.default_rng(1)
    soup = random_soup(rng)
    embree, numpy = Visibility(soup, "embree"), Visibility(soup, "numpy")
    count = 20_000
    origins = embree.to_unit(rng.uniform(-1.2, 1.2, (count, 3)))
    directions = (rng.normal(size=(count, 3)) * rng.uniform(0.1, 10, (count, 1))).astype(np.float32)
    reach = rng.uniform(0, 2, count).astype(np.float32) if bounded else None
    expected = run(embree, origins, directions, reach, query, jittered)
    found = run(numpy, origins, directions, reach, query)
    assert 0.1 * count < np.count_nonzero(expected != -1) < 0.9 * count  # the rays are a test
    assert np.count_nonzero((expected == -1) != (found == -1)) <= count // 10_000
    if query == "INTERSECT":
        both = (expected != -1) & (found != -1)
        unit = embree.to_unit(soup.reshape(-1, 3)).reshape(-1, 3, 3)
        np.testing.assert_allclose(hit_distance(unit, origins, directions, found)[both],
                                   hit_distance(unit, origins, directions, expected)[both], rtol=1e-5)


@pytest.mark.parametrize("backend", AVAILABLE)
def test_rays_through_shared_edges_and_vertices_of_a_closed_mesh_do_not_leak(backend):
    """From points inside a closed mesh, rays aimed at its vertices and at points on its edges
    (in unit space, as the corners, so within float32 rounding of them) always hit it. The
    NumPy tracer's test is watertight: no leak (none in 900,000 such rays). Embree's default
    (non-robust) triangle test is not: 12 of these 41,472 rays leak, so allow 1 in 1,000."""
    rng = np.random.default_rng(2)
    corners = closed_mesh(6, rng)
    visibility = Visibility(corners, backend)
    unit = visibility.to_unit(corners.reshape(-1, 3)).reshape(-1, 3, 3)
    weights = rng.random((len(unit), 3, 1)).astype(np.float32)
    on_edges = (unit * weights + unit[:, [1, 2, 0]] * (1 - weights)).reshape(-1, 3)
    targets = np.concatenate([unit.reshape(-1, 3), on_edges])
    inside = visibility.to_unit(corners.reshape(-1, 3).mean(axis=0) + rng.normal(scale=0.05, size=(8, 3)))
    leaks = rays = 0
    for origin in inside:
        directions = ((targets - origin) * rng.uniform(0.5, 3)).astype(np.float32)  # any length
        origins = np.broadcast_to(origin, directions.shape)
        blocked = run(visibility, origins, directions, np.full(len(targets), 3.0, np.float32), "OCCLUDED")
        nearest = run(visibility, origins, directions, None, "INTERSECT")
        leaks += np.count_nonzero(blocked == -1) + np.count_nonzero(nearest == -1)
        rays += 2 * len(targets)
    assert leaks <= (0 if backend == "numpy" else rays // 1000), (leaks, rays)



def floor_scene():
    """The unit floor square at z = 0 (two triangles) and, far off below it, a block that makes
    the unit space differ from the world; rays from above the floor never reach the block."""
    floor = quad([0, 0, 0], [1, 0, 0], [0, 1, 0])
    block = quad([3, 3, -2], [0.5, 0, 0], [0, 0.5, 0])
    vertices, triangles = merge(floor, block)
    return vertices[triangles]


@pytest.mark.parametrize("backend", AVAILABLE)
def test_grazing_rays_hit_exactly_where_they_cross_the_floor(backend):
    """Rays at 1e-3 and 1e-5 rad over the floor cross its plane inside it (hit) or outside it
    (miss), 0.02 or more from its edges; rays parallel to it just above or below it, or in its
    plane, miss."""
    visibility = Visibility(floor_scene(), backend)
    cases = []  # (start, direction, hits)
    for slope in (1e-3, 1e-5):
        for cross_x, hits in ((-0.3, False), (-0.02, False), (0.02, True), (0.5, True), (0.98, True), (1.02, False)):
            for y in (0.05, 0.5, 0.95, 1.05):
                start = np.array([-0.5, y, slope * (cross_x + 0.5)])
                cases.append((start, np.array([1.0, 0.0, -slope]), hits and y < 1))
    for height in (1e-4, -1e-4, 0.0):
        cases.append((np.array([-0.5, 0.5, height]), np.array([1.0, 0.0, 0.0]), False))
    starts = visibility.to_unit(np.array([case[0] for case in cases]))
    directions = visibility.to_unit_directions(np.array([case[1] for case in cases]))
    expected = np.array([case[2] for case in cases])
    reach = np.full(len(cases), 10 * visibility.scale * 2, np.float32)  # far past the floor
    np.testing.assert_array_equal(visibility.occluded_unit(starts, directions, reach), expected)
    nearest = run(visibility, starts, directions, None, "INTERSECT")
    np.testing.assert_array_equal(nearest >= 0, expected)
    assert set(nearest[expected]) <= {0, 1}


@pytest.mark.parametrize("backend", AVAILABLE)
def test_rays_leaving_a_surface_never_hit_it(backend):
    """As Visibility traces them: from random points on the floor, RAY_EPSILON off it, in every
    direction of the upper hemisphere down to 1e-4 rad from grazing, segments and nearest hits
    never find the floor; the same rays aimed down always do (those steeper than 0.01 rad, which
    cross the floor's plane within 1e-3 of where they start)."""
    rng = np.random.default_rng(3)
    visibility = Visibility(floor_scene(), backend)
    count = 4000
    points = np.column_stack([rng.uniform(0.01, 0.99, (count, 2)), np.zeros(count)])
    elevation = np.concatenate([np.geomspace(1e-4, 1.5, count // 2), rng.uniform(0, np.pi / 2, count - count // 2)])
    azimuth = rng.uniform(0, 2 * np.pi, count)
    directions = np.column_stack([np.cos(elevation) * np.cos(azimuth), np.cos(elevation) * np.sin(azimuth),
                                  np.sin(elevation)])
    normals = np.tile([0.0, 0.0, 1.0], (count, 1))
    starts = visibility.to_unit(points) + RAY_EPSILON * visibility.to_unit_directions(normals)
    unit_directions = visibility.to_unit_directions(directions)
    reach = np.full(count, 2.0, np.float32)
    assert not visibility.occluded_unit(starts, unit_directions, reach).any()
    nearest = visibility.nearest(points, directions, normals)
    assert not np.isin(nearest, [0, 1]).any()
    steep = elevation > 0.01
    down = directions[steep] * [1, 1, -1]
    assert visibility.occluded_unit(starts[steep], visibility.to_unit_directions(down), reach[steep]).all()


@pytest.mark.parametrize("backend", AVAILABLE)
def test_reach_stops_a_segment_short_of_a_wall_or_lets_it_through(backend):
    """Segments towards the floor from 1 above: with reach 1 - 1e-4 (of the distance) they stop
    short, with 1 + 1e-4 they are blocked, whatever the length of their direction; reach 0 or
    below is never blocked, nor is a direction of zero length."""
    rng = np.random.default_rng(4)
    visibility = Visibility(floor_scene(), backend)
    count = 500
    points = np.column_stack([rng.uniform(0.05, 0.95, (count, 2)), np.ones(count)])
    starts = visibility.to_unit(points)
    length = rng.uniform(0.01, 100, (count, 1))
    directions = (np.array([0.0, 0.0, -1.0]) * visibility.scale / length).astype(np.float32)
    distance = length[:, 0].astype(np.float32)  # t at which each ray reaches the floor
    assert not visibility.occluded_unit(starts, directions, distance * (1 - 1e-4)).any()
    assert visibility.occluded_unit(starts, directions, distance * (1 + 1e-4)).all()
    for reach in (0.0, -1.0):
        assert not visibility.occluded_unit(starts, directions, np.full(count, reach, np.float32)).any()
    zero = np.zeros_like(directions)
    assert not visibility.occluded_unit(starts, zero, np.full(count, 1.0, np.float32)).any()
    np.testing.assert_array_equal(run(visibility, starts, zero, None, "INTERSECT"), -1)


def occlusion_mesh():
    """test_occlusion's receiver, plate and blocker, split into patches of 1/8."""
    vertices, triangles = occlusion_scene(with_blocker=True)
    count = len(triangles)
    return discretize(Scene(vertices, triangles, np.zeros((count, 3)), np.zeros((count, 3))), 0.125)


def ray_cast_factors(mesh, backend):
    """(P, P) ray-cast form factors between all patches, their occlusion traced by ``backend``."""
    visibility = Visibility(mesh.patch_corners[: mesh.front_patch_count], backend)
    caster = RayCaster(mesh.patch_corners, mesh.patch_normals, mesh.patch_areas, visibility, 16, 0)
    count = mesh.patch_count
    receivers, sources = np.repeat(np.arange(count), count), np.tile(np.arange(count), count)
    return caster.form_factors(mesh.patch_centroids, mesh.patch_normals, receivers, sources).reshape(count, count)


def test_the_numpy_backend_removes_exactly_what_a_blocker_hides():
    """test_occlusion's closed form, with rays traced by NumPy (wherever embreex is missing):
    F(point -> plate) is B-3 over the plate minus B-3 over the hidden square; 16 stratified rays
    per patch of side 1/8 resolve the shadow's edge to 1e-3 (as there)."""
    mesh = occlusion_mesh()
    factors = ray_cast_factors(mesh, "numpy")
    receiver = np.flatnonzero(mesh.patch_triangle == 0)
    assert len(receiver) == 1  # the tiny receiver is one patch: its centroid is the point
    plate = np.isin(mesh.patch_triangle, [1, 2])
    whole, hidden = centred_square_factor(PLATE, HEIGHT), centred_square_factor(2 * BLOCKER, HEIGHT)
    np.testing.assert_allclose(factors[receiver[0], plate].sum(), whole - hidden, rtol=1e-3)
    np.testing.assert_allclose(factors[receiver[0], mesh.patch_triangle >= 3].sum(), hidden, rtol=1e-3)


@needs_embree
def test_ray_cast_form_factors_are_the_same_with_both_backends():
    """Every pair of 1,109 patches, 3.4 million occlusion rays: identical blocked rays give
    identical factors (measured: identical). One ray flipped by float32 rounding near an edge
    would change one factor by its sample's share, at most 1/16 of it; 1e-6 allows none."""
    mesh = occlusion_mesh()
    np.testing.assert_allclose(ray_cast_factors(mesh, "numpy"), ray_cast_factors(mesh, "embree"), rtol=1e-6, atol=0)


@needs_embree
def test_hemicube_rows_are_the_same_with_both_backends():
    """Hemicubes (N = 32) at every patch centroid: the same patch in every pixel (measured:
    identical), so the same rows. A pixel whose ray crosses a shared edge may show either
    patch: each entry may move by one pixel's factor, the rows' sums not at all."""
    mesh = occlusion_mesh()
    points, normals = mesh.patch_centroids, mesh.patch_normals
    rows = {}
    for backend in ("embree", "numpy"):
        visibility = Visibility(mesh.patch_corners[: mesh.front_patch_count], backend)
        rows[backend] = hemicube.form_factor_rows(points, normals, 32, visibility, mesh)
    pixel = hemicube.pixels(32)[1].max()
    np.testing.assert_allclose(rows["numpy"], rows["embree"], rtol=0, atol=pixel)
    np.testing.assert_allclose(rows["numpy"].sum(axis=1), rows["embree"].sum(axis=1), rtol=1e-12)


@pytest.mark.parametrize("backend", AVAILABLE)
def test_threads_trace_side_by_side_and_every_ray_is_counted(backend):
    """Visibility is shared by the bake's threads: results as traced alone, rays all counted."""
    rng = np.random.default_rng(5)
    visibility = Visibility(random_soup(rng), backend)
    batches = [(visibility.to_unit(rng.uniform(-1, 1, (3000, 3))), rng.normal(size=(3000, 3)).astype(np.float32),
                rng.uniform(0, 1, 3000).astype(np.float32)) for _ in range(6)]
    alone = [visibility.occluded_unit(*batch) for batch in batches]
    before = visibility.rays_cast
    results = [None] * len(batches)

    def trace(index):
        results[index] = visibility.occluded_unit(*batches[index])

    threads = [threading.Thread(target=trace, args=(index,)) for index in range(len(batches))]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    for together, single in zip(results, alone):
        np.testing.assert_array_equal(together, single)
    assert visibility.rays_cast - before == sum(len(batch[0]) for batch in batches)


@needs_embree
def test_embree_scenes_made_and_dropped_free_their_devices():
    """embreex gives each scene an Embree device of its own, and a process holding about a
    thousand cannot make another; ``embree_build`` took a reference to each scene's device and
    never released it, so its 1,016th scene, the others long dropped, failed (and the fallback
    then crashed the process). 1,200 scenes made one after the other, each dropped, all build."""
    from core.rays import embree_build

    triangle = np.array([[[0, 0, 0], [1, 0, 0], [0, 1, 0]]], np.float32)
    assert all(embree_build.triangle_scene(triangle, robust=bool(i % 2)) is not None for i in range(1200))


def resident_bytes() -> int:
    """The process's resident memory now (Linux)."""
    return int(Path("/proc/self/statm").read_text().split()[1]) * 4096


@needs_embree
def test_the_memory_a_visibility_reports_covers_what_its_embree_scenes_take():
    """``Visibility.bytes``, counted in a bake's ``peak_memory_estimate``, reports its Embree scenes
    by their triangles (Embree's memory is no Python object's): at least the resident memory the
    process gains as the two scenes of 180,000 triangles (a wavy sheet) are built, the first with
    its device."""
    from core.rays.visibility import _Traced

    side = 300
    u, v = np.meshgrid(np.linspace(0, 1, side + 1), np.linspace(0, 1, side + 1), indexing="ij")
    grid = np.stack([u, v, 0.05 * np.sin(20 * u) * np.cos(15 * v)], axis=-1)
    a, b, c, d = grid[:-1, :-1], grid[1:, :-1], grid[1:, 1:], grid[:-1, 1:]
    corners = np.concatenate([np.stack([a, b, c], axis=2), np.stack([a, c, d], axis=2)]).reshape(-1, 3, 3)
    corners = np.ascontiguousarray(corners, dtype=np.float32)
    before = resident_bytes()
    traced = _Traced("embree", corners)
    traced.scene(jittered=True)  # the faster scene too
    taken = resident_bytes() - before
    assert 0 < taken <= traced.bytes, (taken, traced.bytes)


@needs_embree
def test_a_scene_embree_refuses_is_none_not_a_crash(monkeypatch):
    """An Embree error inside ``embree_build``'s calls (here a geometry type Embree does not know)
    gives None, for the caller to build the scene with embreex alone: embreex's own error
    function, Python called without the GIL, would crash the process, so the device reports
    errors only when asked."""
    from core.rays import embree_build

    triangle = np.array([[[0, 0, 0], [1, 0, 0], [0, 1, 0]]], np.float32)
    monkeypatch.setattr(embree_build, "_TRIANGLE", 12345)
    assert embree_build.triangle_scene(triangle) is None
    monkeypatch.undo()
    assert embree_build.triangle_scene(triangle) is not None


@needs_embree
def test_embree_scenes_are_built_while_other_threads_run_and_trace_as_embreex_builds_them():
    """``embree_build.triangle_scene`` fills an embreex scene and builds its BVH with the GIL
    released: a thread woken as it starts on 600,000 triangles runs well before it ends (with
    the GIL held, as embreex's ``TriangleMesh`` and first query build it, the thread runs only
    once the build is over: its wait is then the whole build), and the scene answers as one
    embreex built, to the bit, on both queries."""
    from embreex.mesh_construction import TriangleMesh
    from embreex.rtcore_scene import EmbreeScene

    from core.rays import embree_build

    rng = np.random.default_rng(8)
    triangles = (rng.random((600_000, 1, 3)) + 0.01 * rng.random((600_000, 3, 3))).astype(np.float32)
    starts, directions = rng.random((20_000, 3)).astype(np.float32), rng.normal(size=(20_000, 3)).astype(np.float32)
    reach = rng.random(20_000).astype(np.float32)
    as_embreex = EmbreeScene()
    TriangleMesh(as_embreex, triangles)
    go, woke = threading.Event(), []
    waiter = threading.Thread(target=lambda: (go.wait(), woke.append(time.perf_counter())))
    waiter.start()
    start = time.perf_counter()
    go.set()
    scene = embree_build.triangle_scene(triangles)
    end = time.perf_counter()
    waiter.join()
    assert scene is not None and scene.is_committed
    assert woke[0] - start < 0.5 * (end - start), (woke[0] - start, end - start)
    for query, distances in (("INTERSECT", None), ("OCCLUDED", reach)):
        np.testing.assert_array_equal(scene.run(starts, directions, dists=distances, query=query),
                                      as_embreex.run(starts, directions, dists=distances, query=query))


def test_the_backend_is_chosen_named_and_checked():
    corners = floor_scene()
    assert BACKENDS == ("embree", "numpy")
    assert default_backend() in BACKENDS
    assert Visibility(corners).backend == default_backend()
    assert Visibility(corners, "numpy").backend == "numpy"
    with pytest.raises(ValueError, match=r"backend must be one of \('embree', 'numpy'\) or None, got 'optix'"):
        Visibility(corners, "optix")


def test_asking_for_embree_without_embreex_is_a_clear_error(monkeypatch):
    monkeypatch.setitem(sys.modules, "embreex", None)  # "import embreex" now fails
    assert default_backend() == "numpy"
    assert Visibility(floor_scene()).backend == "numpy"
    with pytest.raises(ImportError, match="backend 'embree' needs the embreex package"):
        Visibility(floor_scene(), "embree")


def test_core_imports_and_bakes_without_embreex():
    """In a fresh interpreter where embreex cannot be imported, core imports, picks the NumPy
    backend and bakes; the colours are the in-process bake's. Occlusion rays agree exactly; the
    small hemicube that measures each shot's share may see either of the floating plate's two
    coincident faces in a pixel (a tie of distances), which moved colours up to 10 by 3e-6."""
    code = (
        "import json, sys\n"
        "sys.modules['embreex'] = None\n"
        "import core\n"
        "from core.rays.visibility import default_backend\n"
        "from tests.core.scenes import lit_room\n"
        "result = core.bake(lit_room())\n"
        "print(json.dumps({'backend': default_backend(), 'colors': result.corner_colors.tolist()}))\n"
    )
    done = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, timeout=120,
                          check=False)
    assert done.returncode == 0, done.stderr
    output = json.loads(done.stdout.splitlines()[-1])
    assert output["backend"] == "numpy"
    np.testing.assert_allclose(np.array(output["colors"]), bake(lit_room()).corner_colors, rtol=0, atol=1e-4)


def test_the_numpy_tracer_refuses_bad_input():
    tracer = NumpyTracer(floor_scene())
    rays = np.zeros((4, 3), np.float32)
    with pytest.raises(ValueError, match="query must be one of"):
        tracer.run(rays, rays, None, "DISTANCE")
    with pytest.raises(ValueError, match=r"origins and directions must both have shape \(n, 3\)"):
        tracer.run(rays, rays[:3], None, "OCCLUDED")
    with pytest.raises(ValueError, match=r"dists must have shape \(4,\)"):
        tracer.run(rays, rays, np.ones(3), "OCCLUDED")
    with pytest.raises(ValueError, match=r"triangles must have shape \(P, 3, 3\)"):
        NumpyTracer(np.zeros((4, 3)))
    with pytest.raises(ValueError, match="leaf_size must be at least 1"):
        NumpyTracer(floor_scene(), leaf_size=0)


def test_the_numpy_tracer_handles_empty_degenerate_and_coincident_triangles():
    """No triangles: nothing is hit. Zero-area triangles are never hit. Two hundred copies of one
    triangle (which the SAH cannot split) build a tree of bounded depth and are hit."""
    down = np.array([[0.2, 0.2, 1.0]], np.float32), np.array([[0.0, 0.0, -1.0]], np.float32)
    np.testing.assert_array_equal(NumpyTracer(np.zeros((0, 3, 3))).run(*down, None, "INTERSECT"), [-1])
    assert NumpyTracer(floor_scene()).run(np.zeros((0, 3)), np.zeros((0, 3)), None, "OCCLUDED").shape == (0,)
    flat = np.array([[[0, 0, 0], [1, 0, 0], [2, 0, 0]], [[0, 0, 0], [0, 0, 0], [0, 0, 0]]], float)
    above_the_line = np.array([[0.5, 0, 1]], np.float32)
    np.testing.assert_array_equal(NumpyTracer(flat).run(above_the_line, down[1], None, "INTERSECT"), [-1])
    copies = np.repeat(floor_scene()[:1], 200, axis=0)
    tracer = NumpyTracer(copies)
    assert tracer.depth <= 64 + 10
    assert 0 <= tracer.run(*down, None, "INTERSECT")[0] < 200
    assert tracer.run(*down, None, "OCCLUDED")[0] != -1
