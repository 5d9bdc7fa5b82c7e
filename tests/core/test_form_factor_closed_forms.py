"""Form factors against closed forms from J. R. Howell, "A Catalog of Radiation Heat Transfer
Configuration Factors" (3rd edition, www.thermalradiation.net), by catalog number:

    B-3   differential element to a parallel rectangle, its normal through a corner
    B-12  differential element to a parallel coaxial disk
    C-11  identical, parallel, directly opposed rectangles
    C-14  perpendicular rectangles with a common edge
    C-41  parallel coaxial disks of unequal radius

and the interior of a sphere (every patch sees every other with F_ij = A_j / A), reciprocity and
closure in a box, and how the error shrinks with each method's knobs.

A surface of several triangles sends F(S -> T) = sum_{i in S} (A_i / A_S) sum_{j in T} F[i, j].
"Measured" in a comment is this module's own case, as computed when the bound was set.
"""

import numpy as np
import pytest

from core import form_factor_matrix
from core.transport.analytic import point_to_triangle
from core.util.geometry import GOLDEN, INSIDE, barycentric, solid_angle_directions
from tests.core.scenes import box, merge, quad

METHODS = ("hemicube", "raycast")
RESOLUTION = 64  # form_factor_matrix's default hemicube resolution


# Closed forms, coded from the catalog.

def b3(a, b, c):
    """B-3: element to a parallel a x b rectangle at distance c, the element's normal through a
    corner. Odd in a and in b, so signed sides give the signed quadrant terms of superposition."""
    x, y = a / c, b / c
    sx, sy = np.sqrt(1 + x * x), np.sqrt(1 + y * y)
    return (x / sx * np.arctan(y / sx) + y / sy * np.arctan(x / sy)) / (2 * np.pi)


def b3_anywhere(x, y, x1, x2, y1, y2, c):
    """B-3 by superposition: element at (x, y, 0) facing +z, rectangle [x1, x2] x [y1, y2] at z = c."""
    return b3(x2 - x, y2 - y, c) - b3(x1 - x, y2 - y, c) - b3(x2 - x, y1 - y, c) + b3(x1 - x, y1 - y, c)


def b12(r, h):
    """B-12: element to a parallel coaxial disk of radius r at distance h."""
    return r * r / (h * h + r * r)


def c11(a, b, c):
    """C-11: between identical, parallel, directly opposed a x b rectangles at distance c."""
    x, y = a / c, b / c
    return 2 / (np.pi * x * y) * (
        np.log(np.sqrt((1 + x * x) * (1 + y * y) / (1 + x * x + y * y)))
        + x * np.sqrt(1 + y * y) * np.arctan(x / np.sqrt(1 + y * y))
        + y * np.sqrt(1 + x * x) * np.arctan(y / np.sqrt(1 + x * x))
        - x * np.arctan(x) - y * np.arctan(y)
    )


def c14(w, h, length):
    """C-14: from a w x length rectangle to a perpendicular h x length one sharing the edge of
    that length."""
    w, h = w / length, h / length
    w2, h2, s2 = w * w, h * h, w * w + h * h
    logarithm = (
        np.log((1 + w2) * (1 + h2) / (1 + s2))
        + w2 * np.log(w2 * (1 + s2) / ((1 + w2) * s2))
        + h2 * np.log(h2 * (1 + s2) / ((1 + h2) * s2))
    )
    return (w * np.arctan(1 / w) + h * np.arctan(1 / h) - np.sqrt(s2) * np.arctan(1 / np.sqrt(s2))
            + logarithm / 4) / (np.pi * w)


def c41(r1, r2, h):
    """C-41: from a disk of radius r1 to a parallel coaxial disk of radius r2 at distance h."""
    big_r1, big_r2 = r1 / h, r2 / h
    x = 1 + (1 + big_r2**2) / big_r1**2
    return (x - np.sqrt(x * x - 4 * (big_r2 / big_r1) ** 2)) / 2


# Geometry.

def frame(normal):
    """Unit tangents t, b with t x b = the unit normal."""
    n = np.asarray(normal, dtype=float) / np.linalg.norm(normal)
    helper = [1.0, 0.0, 0.0] if abs(n[0]) < 0.9 else [0.0, 1.0, 0.0]
    t = np.cross(helper, n)
    t /= np.linalg.norm(t)
    return t, np.cross(n, t)


def disk(center, normal, radius, n):
    """A regular n-gon inscribed in the circle, fanned from its centre, facing ``normal``."""
    t, b = frame(normal)
    angle = 2 * np.pi * np.arange(n) / n
    rim = np.asarray(center, dtype=float) + radius * (np.cos(angle)[:, None] * t + np.sin(angle)[:, None] * b)
    k = np.arange(n)
    return np.vstack([center, rim]), np.stack([np.zeros(n, dtype=int), 1 + k, 1 + (k + 1) % n], axis=1)


def tiny_receiver(point, normal, size=1e-4):
    """An equilateral triangle of circumradius ``size`` centred on ``point``, facing ``normal``:
    one patch that receives at its centroid, i.e. at the point."""
    t, b = frame(normal)
    angle = 2 * np.pi * np.arange(3) / 3
    corners = np.asarray(point, dtype=float) + size * (np.cos(angle)[:, None] * t + np.sin(angle)[:, None] * b)
    return corners, np.array([[0, 1, 2]])


def icosphere(levels):
    """Unit sphere: an icosahedron with each face split in 4, ``levels`` times; faces outwards."""
    p = (1 + np.sqrt(5)) / 2
    vertices = [(-1, p, 0), (1, p, 0), (-1, -p, 0), (1, -p, 0), (0, -1, p), (0, 1, p),
                (0, -1, -p), (0, 1, -p), (p, 0, -1), (p, 0, 1), (-p, 0, -1), (-p, 0, 1)]
    faces = [(0, 11, 5), (0, 5, 1), (0, 1, 7), (0, 7, 10), (0, 10, 11), (1, 5, 9), (5, 11, 4),
             (11, 10, 2), (10, 7, 6), (7, 1, 8), (3, 9, 4), (3, 4, 2), (3, 2, 6), (3, 6, 8),
             (3, 8, 9), (4, 9, 5), (2, 4, 11), (6, 2, 10), (8, 6, 7), (9, 8, 1)]
    middles = {}

    def middle(i, j):
        key = (min(i, j), max(i, j))
        if key not in middles:
            middles[key] = len(vertices)
            vertices.append(tuple(np.add(vertices[i], vertices[j]) / 2))
        return middles[key]

    for _ in range(levels):
        split = []
        for a, b, c in faces:
            ab, bc, ca = middle(a, b), middle(b, c), middle(c, a)
            split += [(a, ab, ca), (b, bc, ab), (c, ca, bc), (ab, bc, ca)]
        faces = split
    vertices = np.array(vertices, dtype=float)
    return vertices / np.linalg.norm(vertices, axis=1, keepdims=True), np.array(faces)


def surfaces(*parts):
    """Merged vertices, triangles and, per part, the indices of its triangles."""
    vertices, triangles = merge(*parts)
    ends = np.cumsum([len(part[1]) for part in parts])
    return vertices, triangles, [np.arange(end - len(part[1]), end) for end, part in zip(ends, parts)]


def areas(vertices, triangles):
    """(T,) triangle areas."""
    corners = vertices[triangles]
    return np.linalg.norm(np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]), axis=1) / 2


def exchange(F, vertices, triangles, source, target):
    """A_S F(S -> T): the area-weighted sum of the rows of S over the columns of T."""
    return areas(vertices, triangles)[source] @ F[np.ix_(source, target)].sum(axis=1)


def surface_factor(F, vertices, triangles, source, target):
    """F(S -> T) of two surfaces of triangles."""
    return exchange(F, vertices, triangles, source, target) / areas(vertices, triangles)[source].sum()


# A rigid motion, so that the exact point-to-triangle checks do not rely on axis-aligned input.
_AXIS = np.array([1.0, 2.0, 3.0]) / np.sqrt(14.0)
_K = np.cross(np.eye(3), _AXIS)
ROTATION = np.eye(3) + np.sin(0.7) * _K + (1 - np.cos(0.7)) * _K @ _K
SHIFT = np.array([0.3, -1.2, 2.5])


def point_factor(point, normal, corners):
    """Exact unoccluded form factor from a point to the union of triangles ``corners`` (k, 3, 3),
    all moved by the same rigid motion."""
    k = len(corners)
    points = np.tile(np.asarray(point, dtype=float) @ ROTATION.T + SHIFT, (k, 1))
    normals = np.tile(np.asarray(normal, dtype=float) @ ROTATION.T, (k, 1))
    return point_to_triangle(points, normals, corners @ ROTATION.T + SHIFT).sum()


# Exact point-to-triangle factors: both sides are exact formulas, so only rounding separates them
# (measured at most 3.3e-14, for the far 0.01 x 0.02 rectangle whose contour terms cancel to 7e-6).
EXACT = 1e-12


@pytest.mark.parametrize("a, b, c", [(1.0, 2.0, 1.5), (0.3, 5.0, 1.0), (10.0, 10.0, 0.1), (0.01, 0.02, 3.0)])
def test_b3_point_under_corner_of_parallel_rectangle(a, b, c):
    """B-3: element at the origin facing +z; the a x b rectangle at height c faces it."""
    vertices, triangles = quad([0, 0, c], [0, b, 0], [a, 0, 0])
    assert point_factor([0, 0, 0], [0, 0, 1], vertices[triangles]) == pytest.approx(b3(a, b, c), rel=EXACT, abs=0)


@pytest.mark.parametrize("x, y", [(0.3, 0.7), (0.5, 1.0), (-0.4, 0.5), (1.6, -0.8), (0.0, 2.0)])
def test_b3_superposition_point_anywhere_below_rectangle(x, y):
    """B-3 by superposition of four corner rectangles, for elements below, beside and diagonally
    off the rectangle [0, 1] x [0, 2] at height 1.5."""
    vertices, triangles = quad([0, 0, 1.5], [0, 2, 0], [1, 0, 0])
    expected = b3_anywhere(x, y, 0, 1, 0, 2, 1.5)
    assert point_factor([x, y, 0], [0, 0, 1], vertices[triangles]) == pytest.approx(expected, rel=EXACT, abs=0)


@pytest.mark.parametrize("n", [8, 64, 512])
@pytest.mark.parametrize("r, h", [(1.0, 1.0), (0.2, 3.0), (5.0, 0.5)])
def test_b12_point_to_coaxial_polygon_is_bracketed_by_disks(r, h, n):
    """B-12 for an n-gon inscribed in the disk: it holds the circle of radius r cos(pi/n) and lies
    in the circle of radius r, and the kernel is positive, so B-12 at these radii brackets it."""
    vertices, triangles = disk([0, 0, h], [0, 0, -1], r, n)
    f = point_factor([0, 0, 0], [0, 0, 1], vertices[triangles])
    # The bracket is (pi/n)^2 wide relative (the n-gon's area deficit is (2 pi/n)^2/6), e.g.
    # 2e-5 at n = 512; its ends are exact, so only rounding (EXACT) is added.
    assert b12(r * np.cos(np.pi / n), h) * (1 - EXACT) <= f <= b12(r, h) * (1 + EXACT)


# A tiny receiver through form_factor_matrix. Ray casting multiplies the exact unoccluded factor by
# the visible fraction, which is exactly 1 with no occluder: rounding only. The hemicube misassigns
# the pixels its outline crosses, ~1/N with the outline along pixel rows as here (measured up to
# 1.33/N = 2.1 % in these cases, and up to 3.0/N at the receiving patches of C-11 for N = 32 to
# 256); bound 3/N = 4.7 %.
TINY = {"raycast": 1e-9, "hemicube": 3 / RESOLUTION}


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("x, y", [(0.0, 0.0), (0.3, 0.7), (-0.4, 0.5)])
def test_tiny_receiver_sees_rectangle_as_b3(method, x, y):
    """B-3 (by superposition off the corner) through form_factor_matrix."""
    vertices, triangles, (rectangle, receiver) = surfaces(
        quad([0, 0, 1.5], [0, 2, 0], [1, 0, 0]), tiny_receiver([x, y, 0], [0, 0, 1])
    )
    F = form_factor_matrix(vertices, triangles, method)
    expected = b3_anywhere(x, y, 0, 1, 0, 2, 1.5)
    assert F[receiver[0], rectangle].sum() == pytest.approx(expected, rel=TINY[method], abs=0)


@pytest.mark.parametrize("method", METHODS)
def test_tiny_receiver_sees_disk_as_b12(method):
    """B-12 through form_factor_matrix: a 64-gon of radius 1 at height 1.5; B-12 brackets the
    polygon's factor as in the exact test, widened by the method's tolerance."""
    n, r, h = 64, 1.0, 1.5
    vertices, triangles, (polygon, receiver) = surfaces(disk([0, 0, h], [0, 0, -1], r, n),
                                                        tiny_receiver([0, 0, 0], [0, 0, 1]))
    f = form_factor_matrix(vertices, triangles, method)[receiver[0], polygon].sum()
    assert b12(r * np.cos(np.pi / n), h) * (1 - TINY[method]) <= f <= b12(r, h) * (1 + TINY[method])


# Finite surfaces at patch_size 0.25 (0.5 for the disks, whose fan triangles are thin): each patch
# receives at its centroid, an O(h^2) quadrature error (measured at most 0.30 % for ray casting,
# in C-14 next to the common edge); bound 1 %. The hemicube adds its aliasing, which averages down
# over the receiving patches (measured at most 0.79 %); bound 2 %.
AREA = {"raycast": 0.01, "hemicube": 0.02}


@pytest.mark.parametrize("method", METHODS)
def test_c11_parallel_opposed_rectangles(method):
    """C-11: 1 x 2 rectangles facing each other 1.5 apart, in both directions."""
    a, b, c = 1.0, 2.0, 1.5
    vertices, triangles, (bottom, top) = surfaces(quad([0, 0, 0], [a, 0, 0], [0, b, 0]),
                                                  quad([0, 0, c], [0, b, 0], [a, 0, 0]))
    F = form_factor_matrix(vertices, triangles, method, patch_size=0.25)
    for source, target in ((bottom, top), (top, bottom)):
        assert surface_factor(F, vertices, triangles, source, target) == pytest.approx(c11(a, b, c), rel=AREA[method])


@pytest.mark.parametrize("method", METHODS)
def test_c14_perpendicular_rectangles_with_common_edge(method):
    """C-14: a 1 x 2 floor and a 0.7 x 2 wall on its edge of length 2, in both directions (C-14
    with the roles of w and h swapped)."""
    w, h, length = 1.0, 0.7, 2.0
    vertices, triangles, (floor, wall) = surfaces(quad([0, 0, 0], [w, 0, 0], [0, length, 0]),
                                                  quad([0, 0, 0], [0, length, 0], [0, 0, h]))
    F = form_factor_matrix(vertices, triangles, method, patch_size=0.25)
    assert surface_factor(F, vertices, triangles, floor, wall) == pytest.approx(c14(w, h, length), rel=AREA[method])
    assert surface_factor(F, vertices, triangles, wall, floor) == pytest.approx(c14(h, w, length), rel=AREA[method])


@pytest.mark.parametrize("method", METHODS)
def test_c41_coaxial_parallel_disks(method):
    """C-41 for 32-gons of radii 1 and 1.5, 1.2 apart. The exchange area A1 F12 = A2 F21 is a
    double integral of a positive kernel, so C-41 for the inscribed circles (radii r cos(pi/32))
    and for the circles brackets the polygons' exchange area in both directions."""
    n, r1, r2, h = 32, 1.0, 1.5, 1.2
    vertices, triangles, (lower, upper) = surfaces(disk([0, 0, 0], [0, 0, 1], r1, n),
                                                   disk([0, 0, h], [0, 0, -1], r2, n))
    F = form_factor_matrix(vertices, triangles, method, patch_size=0.5)
    inscribed = np.cos(np.pi / n)
    for (source, rs), (target, rt) in [((lower, r1), (upper, r2)), ((upper, r2), (lower, r1))]:
        low = np.pi * (rs * inscribed) ** 2 * c41(rs * inscribed, rt * inscribed, h)
        high = np.pi * rs**2 * c41(rs, rt, h)  # 1.4 % above low; both methods measured inside
        assert low * (1 - AREA[method]) <= exchange(F, vertices, triangles, source, target) <= high * (1 + AREA[method])


@pytest.mark.parametrize("method", METHODS)
def test_sphere_interior_patches_see_area_fractions(method):
    """Inside a sphere every element sees area element dA with F = dA / A. Here: 320 flat,
    inward-facing facets of a unit icosphere; near pairs see the facets' flatness, so the per-pair
    check is for pairs at least 90 degrees apart, whose error is O(alpha^2), alpha the facets'
    largest angular circumradius."""
    vertices, triangles = icosphere(2)
    triangles = triangles[:, ::-1]
    F = form_factor_matrix(vertices, triangles, method)
    area = areas(vertices, triangles)
    fraction = area / area.sum()
    corners = vertices[triangles]
    outward = -np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    outward /= np.linalg.norm(outward, axis=1, keepdims=True)
    alpha = np.arccos(np.einsum("tx,tkx->tk", outward, corners).min())  # 0.189 rad
    far = outward @ outward.T <= 0

    # Closed: every hemicube pixel meets a facet, and the exact unoccluded factors of a closed
    # polyhedron sum to 1; rounding only (one lost pixel would be >= 1.2e-6 at N = 64).
    np.testing.assert_allclose(F.sum(axis=1), 1.0, atol=1e-9)
    # Sagitta and tilt of flat facets, O(alpha^2) (measured 0.84 alpha^2 = 3.0 %); bound 1.5 alpha^2.
    # The hemicube adds aliasing: a far facet covers only ~10 pixels at N = 64, so each pixel of its
    # outline is ~10 % of F_ij (measured 32 % in all); bound 45 %.
    pair_bound = 1.5 * alpha**2 + (0.45 if method == "hemicube" else 0.0)
    assert np.abs(F / fraction[None, :] - 1)[far].max() <= pair_bound
    # Summed over the far half, pixels misassigned between facets cancel and the facets' errors
    # average (measured 1.08 % for both methods, 0.30 alpha^2); bound alpha^2 (3.6 %).
    far_half = (F * far).sum(axis=1) / (far * fraction[None, :]).sum(axis=1)
    assert np.abs(far_half - 1).max() <= alpha**2


@pytest.mark.parametrize("method", METHODS)
def test_closed_box_reciprocity_and_row_sums(method):
    """A cube of 12 inward triangles: rows sum to 1, and A_i F_ij = A_j F_ji."""
    vertices, triangles = box(1.0)
    F = form_factor_matrix(vertices, triangles, method, patch_size=0.25)
    # Closed: as in the sphere, rounding only.
    np.testing.assert_allclose(F.sum(axis=1), 1.0, atol=1e-9)
    exchange_areas = areas(vertices, triangles)[:, None] * F
    # Reciprocity holds for the exact integrals; centroid quadrature at patch_size 0.25 breaks it
    # by O(h^2) (measured 1.05 % (hemicube), 1.15 % (ray casting) of the largest exchange area);
    # bound 2 %.
    assert np.abs(exchange_areas - exchange_areas.T).max() <= 0.02 * exchange_areas.max()


# Convergence: the error at a coarse and a fine setting of each knob, each under its model bound.

def test_hemicube_error_shrinks_with_resolution():
    """Tiny receiver under a corner of the B-3 rectangle, hemicube at N = 32 and 256."""
    vertices, triangles, (rectangle, receiver) = surfaces(quad([0, 0, 1.5], [0, 2, 0], [1, 0, 0]),
                                                          tiny_receiver([0, 0, 0], [0, 0, 1]))
    error = {}
    for n in (32, 256):
        F = form_factor_matrix(vertices, triangles, "hemicube", hemicube_resolution=n)
        error[n] = abs(F[receiver[0], rectangle].sum() / b3(1.0, 2.0, 1.5) - 1)
        # Aliasing of an outline along pixel rows ~ 1/N (measured 0.56/N at 32, 0.60/N at 256).
        assert error[n] <= 1.0 / n
    assert error[256] < error[32]


@pytest.mark.parametrize("method, coarse, fine", [("raycast", 1.0, 0.25), ("hemicube", 2.0, 0.5)])
def test_error_shrinks_with_patch_size(method, coarse, fine):
    """C-11 (as above) at two patch sizes."""
    a, b, c = 1.0, 2.0, 1.5
    vertices, triangles, (bottom, top) = surfaces(quad([0, 0, 0], [a, 0, 0], [0, b, 0]),
                                                  quad([0, 0, c], [0, b, 0], [a, 0, 0]))
    error = {}
    for size in (coarse, fine):
        F = form_factor_matrix(vertices, triangles, method, patch_size=size)
        error[size] = abs(surface_factor(F, vertices, triangles, bottom, top) / c11(a, b, c) - 1)
        # Centroid quadrature O(h^2) (measured at most 0.019 h^2 with ray casting); bound 0.03 h^2,
        # plus the hemicube's aliasing, bound 1/N (hemicube minus ray casting: at most 0.44/N here).
        assert error[size] <= 0.03 * size**2 + (1 / RESOLUTION if method == "hemicube" else 0.0)
    assert error[fine] < error[coarse]


def test_directions_uniform_in_a_triangles_solid_angle_integrate_its_form_factor():
    """``solid_angle_directions`` (Arvo's sampling of spherical triangles): with directions
    uniform in the solid angle W a triangle subtends (W from Van Oosterom and Strackee's formula,
    independent of the sampler), W mean(max(0, n . d)) / pi is the form factor, which Lambert's
    contour formula gives exactly; a 4,096-point rank-1 lattice puts it within 5.4e-4 (measured,
    500 random triangles and points; bound 2e-3). The directions are unit (float32: 5e-6; bound
    1e-5) and the offsets meet the triangle where they aim (to 1e-5), but those that rounding or
    the edges' margin moved in, INSIDE of the way from an edge (under 1 % of them)."""
    rng = np.random.default_rng(1)
    count, samples = 500, 4096
    corners = rng.normal(size=(count, 3, 3))
    points = rng.normal(size=(count, 3)) * 0.3
    normals = rng.normal(size=(count, 3))
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    facing = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    behind = np.einsum("kx,kx->k", facing, points - corners[:, 0]) < 0
    corners[behind] = corners[behind][:, ::-1]  # each triangle faces its point
    index = np.arange(samples)
    lattice = np.stack([(index + 0.5) / samples, (index * GOLDEN) % 1], axis=1)
    uv = (lattice[None] + rng.random((count, 1, 2))) % 1
    directions, offsets = solid_angle_directions(points, corners, uv)
    relative = corners - points[:, None]
    length = np.linalg.norm(relative, axis=2)
    numerator = np.abs(np.einsum("kx,kx->k", relative[:, 0], np.cross(relative[:, 1], relative[:, 2])))
    denominator = (length.prod(axis=1) + np.einsum("kx,kx->k", relative[:, 0], relative[:, 1]) * length[:, 2]
                   + np.einsum("kx,kx->k", relative[:, 0], relative[:, 2]) * length[:, 1]
                   + np.einsum("kx,kx->k", relative[:, 1], relative[:, 2]) * length[:, 0])
    solid_angle = (2 * np.arctan2(numerator, denominator)) % (2 * np.pi)
    estimate = solid_angle * np.maximum(np.einsum("ksx,kx->ks", directions, normals), 0).mean(axis=1) / np.pi
    assert np.abs(estimate - point_to_triangle(points, normals, corners)).max() < 2e-3
    assert np.abs(np.linalg.norm(directions, axis=2) - 1).max() < 1e-5
    landed = points[:, None] + offsets
    weights = barycentric(landed.reshape(-1, 3), np.repeat(corners, samples, axis=0))
    assert weights.min() > INSIDE / 2
    aim = np.einsum("ksx,ksx->ks", offsets / np.linalg.norm(offsets, axis=2, keepdims=True), directions)
    moved = np.flatnonzero(aim.ravel() < 1 - 1e-5)
    assert len(moved) < 0.01 * aim.size
    assert (weights[moved].min(axis=1) < 1.01 * INSIDE).all()  # only those kept in from an edge
