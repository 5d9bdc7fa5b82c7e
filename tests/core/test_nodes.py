"""Receiver nodes: one per (vertex, material, smooth normal), so colour may jump at creases and
material borders and is shared elsewhere."""

import numpy as np
import pytest

from core import Scene, bake
from core.mesh.discretize import discretize
from tests.core.scenes import box, merge, quad, uniform


def test_a_box_corner_has_one_node_per_face_below_the_crease_angle():
    """A cube's faces meet at 90 degrees: with a 30 degree crease angle each corner vertex
    has three nodes (one per face); with 100 degrees the faces share one node per corner."""
    scene = uniform(*box(), 0.5, 1.0)
    assert discretize(scene, None, np.radians(30)).node_count == 24
    assert discretize(scene, None, np.radians(100)).node_count == 8


def test_a_material_border_splits_nodes_and_colour_jumps_there():
    """A floor of two halves, black and white, lit from above: the vertices on the border get
    one node per side, white-side colour > 0 and black-side colour 0."""
    left = quad([0, 0, 0], [0.5, 0, 0], [0, 1, 0])
    right = quad([0.5, 0, 0], [0.5, 0, 0], [0, 1, 0])
    light = quad([0, 0, 1], [0, 1, 0], [1, 0, 0])
    vertices, triangles = merge(left, right, light)
    reflectance = np.array([[0.0] * 3] * 2 + [[0.8] * 3] * 2 + [[0.0] * 3] * 2)
    emission = np.zeros((6, 3))
    emission[4:] = 1.0
    scene = Scene(vertices, triangles, reflectance, emission)
    mesh = discretize(scene, None)
    border = np.isclose(vertices[triangles][..., 0], 0.5)  # (T, 3) corners on x = 0.5
    left_nodes = set(mesh.corner_node[:2][border[:2]])
    right_nodes = set(mesh.corner_node[2:4][border[2:4]])
    assert len(left_nodes) == 2 and len(right_nodes) == 2 and not left_nodes & right_nodes
    result = bake(scene)
    assert (result.corner_colors[:2][border[:2]] == 0).all()
    assert (result.corner_colors[2:4][border[2:4]] > 0.1).all()


def test_the_same_vertex_in_two_coplanar_triangles_shares_one_colour():
    """Welded positions: two quads with separate but coincident vertices share nodes."""
    vertices, triangles = merge(quad([0, 0, 0], [1, 0, 0], [0, 1, 0]), quad([1, 0, 0], [1, 0, 0], [0, 1, 0]))
    scene = uniform(vertices, triangles, 0.5, 0.0)
    mesh = discretize(scene, None)
    assert mesh.node_count == 6


def test_smooth_nodes_take_the_mean_normal():
    """Two faces at 20 degrees with a 30 degree crease angle share nodes along their edge,
    facing the area-weighted mean normal (10 degrees from each)."""
    angle = np.radians(20)
    flat = quad([0, 0, 0], [1, 0, 0], [0, 1, 0])
    tilted = quad([0, 0, 0], [0, 1, 0], [-np.cos(angle), 0, np.sin(angle)])  # faces (sin, 0, cos): up
    scene = uniform(*merge(flat, tilted), 0.5, 0.0)
    mesh = discretize(scene, None, np.radians(30))
    assert mesh.node_count == 6
    edge_nodes = mesh.corner_node[0][np.isclose(scene.vertices[scene.triangles[0], 0], 0)]
    tilt = np.degrees(np.arccos(mesh.node_normals[edge_nodes] @ [0, 0, 1]))
    np.testing.assert_allclose(tilt, 10.0, rtol=1e-9)


def test_the_two_sides_of_a_card_never_share_a_node():
    """Even with a 180 degree crease angle, faces folded back onto each other keep their own
    nodes (their mean normal would be zero): a two-sided emitter card lights a floor, and the
    floor's lit vertex colours come out the same as with the default crease angle."""
    card = quad([0, 0, 1], [0, 1, 0], [1, 0, 0])  # faces -z
    back = (card[0], card[1][:, ::-1])  # the same card as separate triangles facing +z
    floor = quad([-1, -1, 0], [3, 0, 0], [0, 3, 0])
    vertices, triangles = merge(card, back, floor)
    reflectance = np.array([[0.0] * 3] * 4 + [[0.5] * 3] * 2)
    emission = np.zeros((6, 3))
    emission[:4] = 1.0
    scene = Scene(vertices, triangles, reflectance, emission, material=np.zeros(6, dtype=int))
    folded = bake(scene, crease_angle=179.0)
    default = bake(scene)
    np.testing.assert_allclose(folded.corner_colors, default.corner_colors, rtol=1e-9)
    assert folded.corner_colors[4:].min() > 0  # every floor vertex sees the card's lit side


def tent(angle_degrees: float) -> Scene:
    """Two unit squares meeting along the y axis, each tilted by half the angle between their
    normals (a shallow roof), grey, no light."""
    half = np.radians(angle_degrees) / 2
    down = [np.cos(half), 0, -np.sin(half)]
    left = quad([0, 0, 0], [0, 1, 0], [-down[0], 0, down[2]])  # x < 0, faces up
    right = quad([0, 0, 0], down, [0, 1, 0])  # x > 0, faces up
    return uniform(*merge(left, right), 0.5, 0.0)


def with_corner_normals(scene: Scene, normals: np.ndarray) -> Scene:
    return Scene(scene.vertices, scene.triangles, scene.reflectance, scene.emission, corner_normals=normals)


def face_normals(scene: Scene) -> np.ndarray:
    corners = scene.vertices[scene.triangles]
    normals = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    return np.repeat((normals / np.linalg.norm(normals, axis=1, keepdims=True))[:, None], 3, axis=1)


def test_flat_corner_normals_split_the_nodes_that_the_crease_angle_joins():
    """A 20 degree roof (6 vertices): below the 30 degree crease angle each vertex has one node;
    with each face's own normal at its corners (Blender's Shade Flat, as Cycles shades them) the
    two ridge vertices get a node per face (8 in all), each facing its face."""
    scene = tent(20.0)
    assert discretize(scene, None, np.radians(30)).node_count == 6
    flat = with_corner_normals(scene, face_normals(scene))
    mesh = discretize(flat, None, np.radians(30))
    assert mesh.node_count == 8
    node_normals = mesh.node_normals[mesh.corner_node]  # (T, 3, 3)
    np.testing.assert_allclose(node_normals, face_normals(scene), atol=1e-12)


def test_smooth_corner_normals_join_faces_beyond_the_crease_angle_and_set_the_node_normal():
    """A 60 degree roof with the same (vertical) normal given at both faces' ridge corners, as
    Shade Smooth would: the ridge vertices share one node each though the crease angle is 30
    degrees, and the node faces the given normal."""
    scene = tent(60.0)
    normals = face_normals(scene)
    ridge = np.isclose(scene.vertices[scene.triangles][..., 0], 0.0)  # (T, 3) corners on the ridge
    normals[ridge] = [0.0, 0.0, 1.0]
    mesh = discretize(with_corner_normals(scene, normals), None, np.radians(30))
    assert mesh.node_count == 6
    np.testing.assert_allclose(mesh.node_normals[mesh.corner_node[ridge]], [[0.0, 0.0, 1.0]] * ridge.sum(), atol=1e-12)


@pytest.mark.parametrize("bad", [np.zeros((4, 3, 3)), np.full((4, 3, 3), np.nan), np.ones((4, 3))])
def test_corner_normals_must_be_finite_non_zero_and_one_per_corner(bad):
    with pytest.raises(ValueError, match="corner_normals"):
        with_corner_normals(tent(20.0), bad)
