"""Contact lines (core/contacts.py): a triangle is cut where another surface meets its inside,
the pieces tile it exactly, and none straddles the line. Truths: the geometry itself (areas,
which side of a known line each corner lies on)."""

import numpy as np
import pytest

from core.mesh.contacts import pieces
from core.util import overlaps
from core.util.overlaps import coplanar_overlaps
from core.mesh.discretize import discretize
from core.util.geometry import areas_and_normals
from tests.core.scenes import box, merge, quad, uniform

FLOOR = quad([0, 0, 0], [1, 0, 0], [0, 1, 0])  # z = 0, faces +z, two triangles


def _cut(*parts):
    vertices, triangles = merge(*parts)
    corners = vertices[triangles]
    return corners, pieces(corners, np.zeros(len(corners), dtype=bool))


def _assert_tiles(corners, parts, owner):
    """The pieces of each triangle cover its area exactly and keep its normal."""
    areas, normals = areas_and_normals(corners)
    piece_areas, piece_normals = areas_and_normals(parts)
    np.testing.assert_allclose(np.bincount(owner, piece_areas, len(corners)), areas, rtol=1e-12)
    np.testing.assert_allclose(piece_normals, normals[owner], atol=1e-9)


def test_a_wall_standing_on_the_floor_cuts_it_along_its_bottom_edge():
    """The wall, meshed as two quads side by side, meets the floor along one line, which cuts
    both floor triangles."""
    wall = merge(quad([0.5, 0.0, 0], [0, 0.5, 0], [0, 0, 0.4]), quad([0.5, 0.5, 0], [0, 0.5, 0], [0, 0, 0.4]))
    corners, (parts, owner) = _cut(FLOOR, wall)
    _assert_tiles(corners, parts, owner)
    on_floor = owner < 2
    assert on_floor.sum() == 6  # each floor triangle: a triangle and a quadrilateral (two)
    side = parts[on_floor][..., 0] - 0.5  # signed distance to the line x = 0.5
    assert np.all((side >= -1e-12).all(axis=1) | (side <= 1e-12).all(axis=1)), "a piece straddles the contact"
    assert np.array_equal(parts[~on_floor], corners[2:])  # the wall itself meets the floor only at its edge


def test_a_wall_through_the_floor_cuts_it_where_they_cross():
    wall = quad([0.5, 0.0, -0.2], [0, 1.0, 0], [0, 0, 0.5])  # x = 0.5, reaching below z = 0
    corners, (parts, owner) = _cut(FLOOR, wall)
    _assert_tiles(corners, parts, owner)
    side = parts[owner < 2][..., 0] - 0.5
    assert np.all((side >= -1e-12).all(axis=1) | (side <= 1e-12).all(axis=1))
    # and the floor cuts the wall along z = 0
    height = parts[owner >= 2][..., 2]
    assert (owner >= 2).sum() > 2
    assert np.all((height >= -1e-12).all(axis=1) | (height <= 1e-12).all(axis=1))


@pytest.mark.parametrize("lift", [1e-3, 0.1])
def test_a_wall_above_the_floor_is_no_contact(lift):
    wall = quad([0.3, 0.2, lift], [0, 0.5, 0], [0, 0, 0.4])
    corners, (parts, owner) = _cut(FLOOR, wall)
    assert np.array_equal(parts, corners) and np.array_equal(owner, np.arange(len(corners)))


def test_faces_meeting_at_their_shared_edges_do_not_cut_each_other():
    vertices, triangles = box()
    corners = vertices[triangles]
    parts, owner = pieces(corners, np.zeros(len(corners), dtype=bool))
    assert np.array_equal(parts, corners) and np.array_equal(owner, np.arange(len(corners)))


def test_discretisation_keeps_the_pieces_apart():
    """Patches of the cut floor are numbered by piece (-1 where nothing cuts), the floor's
    patches still cover its area, and the output nodes are the input vertices' as before."""
    wall = quad([0.5, 0.0, 0], [0, 1.0, 0], [0, 0, 0.4])
    vertices, triangles = merge(FLOOR, wall)
    scene = uniform(vertices, triangles, 0.5, 0.0)
    mesh = discretize(scene, 0.25)
    floor = mesh.patch_triangle < 2
    np.testing.assert_allclose(mesh.patch_areas[floor].sum(), 1.0, rtol=1e-12)
    assert (mesh.patch_piece[floor] >= 0).all() and (mesh.patch_piece[~floor] == -1).all()
    assert len(np.unique(mesh.patch_piece[floor])) > 2
    assert mesh.node_count == len(discretize(uniform(*FLOOR, 0.5, 0.0), 0.25).node_points) + 4


def test_coplanar_overlaps_flag_faces_over_each_other_not_neighbours():
    """Two squares of a floor side by side share an edge: not overlapping. A third square laid
    half over one of them (z-fighting), or the other face of a card (opposite normal): overlapping,
    both ways. Owners group triangles: a quad's own two triangles never count."""
    left, right = quad([0, 0, 0], [1, 0, 0], [0, 1, 0]), quad([1, 0, 0], [1, 0, 0], [0, 1, 0])
    over = quad([0.5, 0, 0], [1, 0, 0], [0, 1, 0])
    card_back = quad([0, 0, 0], [0, 1, 0], [1, 0, 0])  # the left square's back face
    for parts, expected in [((left, right), [False] * 4),
                            ((left, right, over), [True] * 6),
                            ((left, card_back), [True] * 4)]:
        vertices, triangles = merge(*parts)
        owners = np.arange(len(triangles)) // 2
        np.testing.assert_array_equal(coplanar_overlaps(vertices[triangles], owners), expected)


def posts(count: int, size: float = 0.02):
    """``count`` x ``count`` small open boxes (four walls, no top or bottom) standing on FLOOR."""
    parts, step = [], 1.0 / count
    for i in range(count):
        for j in range(count):
            x, y = (i + 0.5) * step, (j + 0.5) * step
            parts += [quad([x, y, 0], [size, 0, 0], [0, 0, size]), quad([x + size, y, 0], [0, size, 0], [0, 0, size]),
                      quad([x + size, y + size, 0], [-size, 0, 0], [0, 0, size]),
                      quad([x, y + size, 0], [0, -size, 0], [0, 0, size])]
    return parts


def test_each_contact_segment_cuts_only_the_pieces_it_runs_through():
    """Posts standing on a floor cut it along their footprints' edges, each line only through
    the pieces its segment crosses: the pieces grow with the posts (linearly: measured 39, 137 and
    531 for 2 x 2, 4 x 4 and 8 x 8 posts), not with their square, as lines across the whole floor
    would make them (8 x 8 posts: 32 lines each way, over 2,000 pieces). The pieces still tile the
    floor, and none straddles a footprint edge (x and y of the edges swapped: the same)."""
    for count in (2, 8):
        corners, (parts, owner) = _cut(FLOOR, *posts(count))
        _assert_tiles(corners, parts, owner)
        floor = parts[owner < 2]
        assert len(floor) <= 2 + 10 * count**2, (count, len(floor))
        size, step = 0.02, 1.0 / count
        starts = (np.arange(count) + 0.5) * step
        for along, across in ((0, 1), (1, 0)):  # edges x = const over a footprint's y range, and y = const
            for edge in np.concatenate([starts, starts + size]):
                for first in starts:
                    cross = (floor[..., along].min(axis=1) < edge - 1e-9) & \
                        (floor[..., along].max(axis=1) > edge + 1e-9)
                    over = (floor[..., across].min(axis=1) < first + size - 1e-9) & \
                        (floor[..., across].max(axis=1) > first + 1e-9)
                    assert not (cross & over).any(), "a piece straddles a footprint edge"


def test_triangles_below_the_smallest_size_cut_larger_ones_but_are_not_cut():
    """With ``smallest`` above the posts' size, the floor is cut along their footprints as with
    no ``smallest`` (an arch's small faces meeting a wall: docs/notes/experiments.md), but no
    small triangle is cut: neither a small tile the posts pierce, nor the posts where it meets
    them, which with no ``smallest`` cut each other."""
    tile = quad([0.24, 0.24, 0.01], [0.07, 0, 0], [0, 0.07, 0])  # around the first post, halfway up
    vertices, triangles = merge(FLOOR, tile, *posts(2))
    corners = vertices[triangles]
    unsized = np.zeros(len(corners), dtype=bool)
    every, every_owner = pieces(corners, unsized)
    parts, owner = pieces(corners, unsized, smallest=0.1)
    _assert_tiles(corners, parts, owner)
    assert (np.bincount(every_owner)[2:4] > 1).all() and (np.bincount(every_owner)[4:12] > 1).any()
    np.testing.assert_array_equal(parts[owner < 2], every[every_owner < 2])
    assert (owner < 2).sum() > 2
    np.testing.assert_array_equal(parts[owner >= 2], corners[2:])


def _share_a_group(listed: np.ndarray, group: np.ndarray, first: np.ndarray, second: np.ndarray) -> np.ndarray:
    """Whether each pair of faces is listed in a common group of ``overlaps._plane_groups``."""
    groups = {}
    for face, number in zip(listed.tolist(), group.tolist()):
        groups.setdefault(face, set()).add(number)
    return np.array([bool(groups.get(a, set()) & groups.get(b, set())) for a, b in zip(first, second)])


def test_the_plane_groups_hold_every_coplanar_pair_and_few_lone_faces(monkeypatch):
    """``overlaps._plane_groups`` before the boxes: cards of two faces (the second turned over,
    or tilted by up to 5e-7 radians and lifted by 1e-7 of its size: still coplanar) anywhere in a
    200 m scene, some with normals across ``SIDE``, share a group, and the pairs found are those
    found with every face in one group; faces in planes of their own are dropped."""
    rng = np.random.default_rng(3)
    faces = []
    for k in range(300):
        normal = rng.normal(size=3)
        if k % 5 == 0:  # across SIDE: kept with both signs
            normal -= (normal @ overlaps.SIDE) * overlaps.SIDE
        normal /= np.linalg.norm(normal)
        along = np.cross(normal, rng.normal(size=3))
        along /= np.linalg.norm(along)
        across = np.cross(normal, along)
        size = rng.uniform(0.01, 2.0)
        face = rng.uniform(-100, 100, 3) + size * (rng.random((3, 1)) * along + rng.random((3, 1)) * across)
        faces.append(face)
        if k < 200:  # a card: its other face
            tilt = rng.uniform(-5e-7, 5e-7) * np.cross(along, face - face.mean(axis=0))
            other = face[::-1] if k % 2 else face + tilt + 1e-7 * size * normal
            faces.append(other)
    corners = np.array(faces)
    owners = np.arange(len(corners))
    areas, normals = areas_and_normals(corners)
    listed, group = overlaps._plane_groups(corners, normals, owners, np.arange(len(corners)))
    cards = np.arange(0, 400, 2)
    assert _share_a_group(listed, group, cards, cards + 1).all()
    # listed twice: the 80 faces across SIDE, and about 1 / 8 near a cell's border
    assert len(np.unique(listed)) < 400 + 10 and len(listed) < 400 + 80 + 400 / 4
    found = overlaps.coplanar_overlap_pairs(corners, owners)
    monkeypatch.setattr(overlaps, "_plane_groups",
                        lambda corners, normals, owners, chosen: (chosen, np.zeros(len(chosen), dtype=np.int64)))
    unfiltered = overlaps.coplanar_overlap_pairs(corners, owners)
    assert len(found[0]) == 400
    np.testing.assert_array_equal(np.array(found), np.array(unfiltered))


def test_the_plane_groups_hold_faces_as_far_apart_as_parallel_allows():
    """Faces turned by 0.95e-3 radians (PARALLEL allows 1e-3) about an axis in their plane through a
    corner, 100 m from the middle: their planes differ by nearly the groups' tolerances, so they
    often fall in different cells of the grid; each pair shares a group."""
    rng = np.random.default_rng(5)
    faces = []
    for _ in range(200):
        normal = rng.normal(size=3)
        normal /= np.linalg.norm(normal)
        along = np.cross(normal, rng.normal(size=3))
        along /= np.linalg.norm(along)
        face = rng.uniform(-100, 100, 3) + rng.normal(size=(3, 3))
        face -= np.outer((face - face[0]) @ normal, normal)  # flat, through its first corner
        angle = 0.95e-3 * rng.choice([-1, 1])
        turn = np.cos(angle) * np.eye(3) + np.sin(angle) * np.cross(np.eye(3), along) \
            + (1 - np.cos(angle)) * np.outer(along, along)
        faces += [face, face[0] + (face - face[0]) @ turn.T]
    corners = np.array(faces)
    _, normals = areas_and_normals(corners)
    listed, group = overlaps._plane_groups(corners, normals, np.arange(len(corners)), np.arange(len(corners)))
    pairs = np.arange(0, len(corners), 2)
    assert _share_a_group(listed, group, pairs, pairs + 1).all()


def test_a_pieces_reach_holds_every_segment_that_runs_inside_it():
    """``contacts._reach``, the box each piece is tested against before a segment is measured
    across it: every segment that ``_run_inside`` (the truth) finds running more than the
    tolerance inside a convex piece grown by it lies in that box. The pieces are triangles in
    random planes, slivers with corners of 0.5 to 5 degrees among them, cut by random lines
    (``_split``), with a tolerance of 5 % of their size so that growing a sharp corner reaches far;
    the segments pass close to the pieces' corners. Without the sharp corners' stretch it fails."""
    from core.mesh.contacts import _reach, _run_inside, _split

    rng = np.random.default_rng(7)
    count = 4000
    normals = rng.normal(size=(count, 3))
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    u = np.cross(normals, rng.normal(size=(count, 3)))
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    v = np.cross(normals, u)
    tip = np.radians(np.where(np.arange(count) % 2 == 0, rng.uniform(0.5, 5.0, count), rng.uniform(20, 150, count)))
    flat = np.stack([np.zeros((count, 2)), np.tile([1.0, 0.0], (count, 1)),
                     rng.uniform(0.5, 1.5, count)[:, None] * np.stack([np.cos(tip), np.sin(tip)], axis=1)], axis=1)
    triangles = flat[..., :1] * u[:, None] + flat[..., 1:] * v[:, None] + rng.normal(size=(count, 1, 3))
    start = triangles.mean(axis=1)
    across = np.cross(normals, rng.normal(size=(count, 3)))
    across /= np.linalg.norm(across, axis=1, keepdims=True)
    tolerance = np.full(count, 0.05)
    positive, _, cuts = _split(triangles, np.full(count, 3), start, across, np.zeros(count))
    polygons = np.where(cuts[:, None, None], positive[0], np.pad(triangles, ((0, 0), (0, positive[0].shape[1] - 3),
                                                                            (0, 0))))
    sizes = np.where(cuts, positive[1], 3)
    low, high = _reach(polygons, sizes, normals, tolerance)
    assert np.isfinite(low).all()  # no piece here is sharp enough to reach everywhere
    for _ in range(20):  # segments from near a corner, past it, in random directions in the plane
        corner = polygons[np.arange(count), rng.integers(0, sizes)]
        heading = rng.normal(size=(count, 2))
        offset = (heading[:, :1] * u + heading[:, 1:] * v) * rng.uniform(0.01, 0.5, (count, 1))
        first = corner + offset * rng.uniform(-1.0, 0.2, (count, 1))
        last = first + offset
        runs = _run_inside(polygons, sizes, normals, first, last, tolerance) > tolerance
        held = (low <= np.maximum(first, last)).all(axis=1) & (high >= np.minimum(first, last)).all(axis=1)
        assert runs.any() and not runs.all()
        assert held[runs].all(), np.flatnonzero(runs & ~held)
