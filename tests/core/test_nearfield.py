"""The near field (core/nearfield.py): where a node looks on a patch next to it, against a fine
uniform quadrature of exact form factors; through whole bakes, a wall's colour at its contact
with a lit floor against the constant-patch answer extrapolated to zero patch size, and corners
enclosed under a block on a floor stay black (no light reaches them)."""

import numpy as np
import pytest

from core import Scene, bake
from core.transport.analytic import point_to_triangle
from core.util.geometry import barycentric_grid
from core.mesh.discretize import discretize
from core.reconstruct import nearfield
from core.reconstruct.nearfield import _near_pairs, _node_sizes, _where_seen
from core.transport.formfactors import FormFactorEngine
from tests.core.scenes import box, grid, merge, quad

WALL = np.array([[0.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])  # x = 0, faces +x


def _fine_centroid(point, normal, triangle, divisions=128):
    """The form-factor-weighted barycentric centroid by a uniform split into divisions**2
    pieces (its error is below a piece's size, 1/128 of the edge)."""
    grid, cells = barycentric_grid(divisions)
    pieces = np.einsum("scb,bx->scx", grid[cells], triangle)
    factors = point_to_triangle(np.repeat(point[None], len(cells), 0), np.repeat(normal[None], len(cells), 0), pieces)
    return factors @ grid[cells].mean(axis=1) / factors.sum()


@pytest.mark.parametrize("point", [
    [1e-3, 0.3, 1e-3],  # on the floor at point-blank range from the wall's bottom edge
    [0.2, 0.3, 0.05],  # a little way off
    [0.8, 0.5, 0.3],  # far: the centroid is nearly the triangle's
])
def test_where_a_point_looks_matches_a_fine_quadrature(point):
    """Graded quadrature (4 x 4, the two largest pieces split 4 x 4 again) against 128 x 128:
    within half a refined piece, 1/32 of the edge, in barycentric terms (measured 0.026 at
    point-blank range, where the weight sits in the pieces touching the edge, 0.003 and 0.012
    further off). Against the 4 x 4 split alone the point-blank case is off by 0.1."""
    point, normal = np.array(point), np.array([0.0, 0.0, 1.0])
    graded = _where_seen(point[None], normal[None], WALL[None])[0]
    assert (graded >= 0).all() and (graded <= 1).all()
    np.testing.assert_allclose(graded, _fine_centroid(point, normal, WALL), atol=1 / 32)


@pytest.mark.parametrize("solver", ["progressive", "jacobi"])
def test_corners_enclosed_under_a_block_stay_black(solver):
    """A closed two-sided box standing on a lit floor: the floor's corners under it see only the
    box's inside, where no light arrives: black (within the ambient term's 1e-3 of the light).
    The near field reads the box's inner faces and the floor's pieces inside the footprint from
    their corner colours: none of them may carry the lit floor's colour across the contact line
    (exact truth: 0; the bound is the ambient term's share)."""
    floor = merge(*(quad([x, y, 0], [0.5, 0, 0], [0, 0.5, 0]) for x in (-1, -0.5, 0, 0.5) for y in (-1, -0.5, 0, 0.5)))
    vertices, triangles = box(0.5)
    block = (vertices + [-0.1, -0.1, 0.0], triangles[:, ::-1])  # [-0.1, 0.4]^2, facing out
    light = quad([-0.5, -0.5, 2.0], [0, 1, 0], [1, 0, 0])  # faces -z
    vertices, triangles = merge(floor, block, light)
    count = len(triangles)
    emission = np.zeros((count, 3))
    emission[-2:] = 5.0
    reflectance = np.full((count, 3), 0.6)
    reflectance[-2:] = 0.0
    scene = Scene(vertices, triangles, reflectance, emission, two_sided=np.ones(count, dtype=bool))
    result = bake(scene, solver=solver, patch_size=0.3)
    on_floor = np.arange(32)
    corners = vertices[triangles[on_floor]]
    under = (np.abs(corners) < 1e-12).all(axis=2)  # the floor's vertex (0, 0, 0), inside the footprint
    colours = result.corner_colors[on_floor]
    floor_mean = colours[~under].mean()
    assert under.sum() == 6 and floor_mean > 0.1
    assert np.abs(colours[under]).max() <= 1e-3 * floor_mean, colours[under].max() / floor_mean


def test_a_wall_on_a_lit_floor_reads_the_floor_at_the_contact():
    """The colour of a wall's vertex in the middle of its contact line with a floor lit from above:
    against the constant-patch bakes at 0.1 and 0.05 m extrapolated to zero patch size
    (Richardson, their error being linear in the patch size there: 2 B(h/2) - B(h), an answer
    the near field takes no part in), the near field at 0.25 m patches is at least 3 times closer
    than the constant reading (measured 0.10 % against 1.5 %), and at 0.1 m within 0.1 %
    (measured 0.03 %, while the extrapolation's two bakes differ by 0.3 %)."""
    floor = quad([-0.2, -0.5, 0], [1, 0, 0], [0, 1, 0])  # z = 0, faces +z
    wall = merge(quad([0, -0.5, 0], [0, 0.5, 0], [0, 0, 1]), quad([0, 0, 0], [0, 0.5, 0], [0, 0, 1]))  # x = 0, faces +x
    light = quad([0.3, -0.2, 1.2], [0, 0.4, 0], [0.4, 0, 0])  # faces -z
    vertices, triangles = merge(floor, wall, light)
    count = len(triangles)
    reflectance = np.full((count, 3), 0.8)
    reflectance[-2:] = 0.0
    emission = np.zeros((count, 3))
    emission[-2:] = 10.0
    scene = Scene(vertices, triangles, reflectance, emission)
    wall_corners = vertices[triangles[2:6]]
    middle = (np.abs(wall_corners[..., 1]) < 1e-12) & (np.abs(wall_corners[..., 2]) < 1e-12)

    def contact_colour(patch_size, near_field):
        result = bake(scene, patch_size=patch_size, near_field=near_field, tolerance=1e-5)
        return result.corner_colors[2:6][middle][:, 0].mean()

    truth = 2 * contact_colour(0.05, False) - contact_colour(0.1, False)
    assert abs(contact_colour(0.25, True) - truth) * 3 < abs(contact_colour(0.25, False) - truth)
    assert abs(contact_colour(0.1, True) - truth) < 1e-3 * truth


@pytest.mark.parametrize("gap, pressed", [(0.005, True), (0.3, False)])
def test_a_patch_pressed_under_a_surface_is_not_read_by_its_interpolant(gap, pressed):
    """A 0.2 m plate facing down over a 2 m floor patch: 5 mm above it, the floor where the plate's
    nodes look lies in the plate's own shadow, so the floor's interpolant (from its lit corners
    outside) is not read there (PRESSED_ANGLE; on the breakfast room's plates and cups, 6 to 10 mm
    over the table, it was the largest error: docs/notes/experiments.md); 0.3 m above it, farther
    than the plate's faces are long, the floor is read as before. A wall standing on the floor
    keeps its pairs either way."""
    floor = quad([-1, -1, 0], [2, 0, 0], [0, 2, 0])
    plate = quad([-0.1, -0.1, gap], [0, 0.2, 0], [0.2, 0, 0])  # faces down
    wall = quad([0.5, -0.5, 0], [0, 0.4, 0], [0, 0, 0.4])  # x = 0.5, faces +x
    vertices, triangles = merge(floor, plate, wall)
    scene = Scene(vertices, triangles, np.full((6, 3), 0.5), np.zeros((6, 3)))
    mesh = discretize(scene, 4.0)
    points, normals = mesh.node_points, mesh.node_normals
    receivers, patches = _near_pairs(points, normals, _node_sizes(scene, mesh), mesh,
                                     np.ones(mesh.patch_count, dtype=bool))
    assert (normals[:, 2] < -0.9).sum() == 4  # the plate's corners
    on_floor = mesh.patch_triangle[patches] < 2
    under_plate = normals[receivers, 2] < -0.9
    on_wall = np.abs(normals[receivers, 0]) > 0.9
    assert (on_floor & under_plate).any() != pressed
    assert (on_floor & on_wall).any()


def test_the_corrected_colours_are_the_fixed_point_of_the_near_field():
    """``corrected_lighting`` on a room's corner of 4 x 4 grids (reflectance 0.95, patches of
    uneven radiosity): its G' satisfies G' = G + sum_q F (sum_i lambda_i V_i - B_q), V = E + rho G'
    at the corners' nodes, written out pair by pair, to the fixed point's tolerance; the coupling
    is strong enough that one pass of the map misses it by far more."""
    vertices, triangles = merge(grid([0, 0, 0], [2, 0, 0], [0, 2, 0], 4), grid([0, 0, 0], [0, 0, 1], [2, 0, 0], 4),
                                grid([0, 0, 0], [0, 2, 0], [0, 0, 1], 4))
    scene = Scene(vertices, triangles, np.full((len(triangles), 3), 0.95), np.zeros((len(triangles), 3)))
    mesh = discretize(scene)
    rng = np.random.default_rng(2)
    radiosity = rng.uniform(0.5, 1.5, (mesh.patch_count, 3))
    gathered = rng.uniform(0.5, 1.5, (mesh.node_count, 3))
    near = nearfield.near_field(scene, mesh, radiosity, FormFactorEngine(mesh).point_form_factors,
                                np.ones(mesh.patch_count, dtype=bool), interpolate=False)
    lighting, iterations = nearfield.corrected_lighting(near, mesh, radiosity, gathered, np.zeros((0, 3)))

    def mapped(lighting):
        colours = mesh.node_emission + mesh.node_reflectance * lighting
        read = np.einsum("kc,kcx->kx", near.weights, colours[near.corner_receiver]) - radiosity[near.patch]
        result = gathered.copy()
        np.add.at(result, near.receiver, near.form_factor[:, None] * read)
        return np.maximum(result, 0.0)

    scale = np.abs(lighting).max()
    assert np.abs(mapped(lighting) - lighting).max() <= 1e-6 * scale
    assert np.abs(mapped(gathered) - mapped(mapped(gathered))).max() > 1e-2 * scale
    assert 5 < iterations < nearfield.MAX_ITERATIONS
