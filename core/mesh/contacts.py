"""Contact lines: triangles cut where another surface meets them, so that no patch straddles one.

A block standing on a floor meets it along the bottom edges of its sides. A floor patch across
that line is half in the open and half under the block: its one radiosity is neither side's, and
the block's bottom corners, which see the floor there at point-blank range, take it for the
floor's value at the line, too dark (docs/notes/experiments.md). Cutting the
floor's triangles along the line (discontinuity meshing of the contact, Heckbert 1992, "Discontinuity
meshing for radiosity"; Lischinski, Tampieri and Greenberg 1992) puts patch edges on it.

A triangle U meets triangle T's plane along a segment where U's corners lie on both sides of the
plane, or along an edge of U lying in it (within CONTACT_TOLERANCE of T's size). Each segment
that runs inside T cuts, along its line, the pieces of T it runs through: T becomes convex
pieces, split in fans. Triangles parallel to T within PARALLEL are its neighbours, not contacts;
triangles smaller than a given size are not cut, but cut the larger ones (``pieces``).
"""

from __future__ import annotations

import numpy as np

from ..util.geometry import areas_and_normals, longest_edges
from ..util.overlaps import CONTACT_TOLERANCE, PARALLEL, padded_boxes
from ..util.spatial import overlapping_boxes, ranks
from ..util.progress import heartbeat


def pieces(corners: np.ndarray, degenerate: np.ndarray, smallest: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """Triangles (T, 3, 3) cut along their contact lines: (K, 3, 3) pieces with the winding of
    their triangle, and (K,) the triangle of each, in triangle order. A triangle without contact
    or ``degenerate`` ((T,) bool) is its own single piece. Triangles whose longest edge is below
    ``smallest`` are not cut: a patch that small straddling a contact line shows little, and a
    detailed object's thousands of small triangles, all touching each other, would each be cut by
    all the others. They cut the larger ones: where an arch of small faces meets a wall, a wall
    patch across the line is half inside the arch, and the arch's corners there read it."""
    target, start, end = _contact_lines(corners, degenerate, smallest)
    if len(target) == 0:
        return corners, np.arange(len(corners))
    uncut = np.ones(len(corners), dtype=bool)
    uncut[target] = False
    cut, cut_owner = _cut(corners, target, start, end)
    owner = np.concatenate([np.flatnonzero(uncut), cut_owner])
    order = np.argsort(owner, kind="stable")
    return np.concatenate([corners[uncut], cut])[order], owner[order]


def _contact_lines(corners: np.ndarray, degenerate: np.ndarray,
                   smallest: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The lines that cut triangles with an edge of length ``smallest`` or more where another
    meets their inside: (L,) the triangle each cuts, sorted, and (L, 3) start and end of each."""
    size = longest_edges(corners)
    cutters = np.flatnonzero(~degenerate)
    targets = cutters[size[cutters] >= smallest]
    low, high = padded_boxes(corners)
    _, normals = areas_and_normals(corners)

    def heights(target: np.ndarray, other: np.ndarray) -> np.ndarray:
        """(k, 3) the other triangle's corners over the target's plane, zero within its tolerance."""
        over = np.einsum("kcx,kx->kc", corners[other] - corners[target][:, :1], normals[target])
        over[np.abs(over) <= CONTACT_TOLERANCE * size[target][:, None]] = 0
        return over

    def section(target: np.ndarray, other: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Where the other triangle meets the target's plane (``_plane_sections``): (k, 3) start and
        end, and (k,) bool, whether that segment runs inside the target."""
        start, end, found = _plane_sections(corners[other], heights(target, other))
        inside = np.flatnonzero(found)
        found[inside] = _length_inside(corners[target[inside]], normals[target[inside]], start[inside], end[inside],
                                       CONTACT_TOLERANCE * size[target[inside]]) > 0
        return start, end, found

    def cuts(first: np.ndarray, second: np.ndarray) -> np.ndarray:
        """Whether the other triangle, not parallel to the target, meets the target's plane inside it
        (run on the threads: most pairs fail the cheaper tests first)."""
        target, other = targets[first], cutters[second]
        result = np.abs((normals[target] * normals[other]).sum(axis=1)) < 1 - PARALLEL
        crossing = np.flatnonzero(result)
        over = heights(target[crossing], other[crossing])
        result[crossing] = (over.min(axis=1) <= 0) & (over.max(axis=1) >= 0)
        meeting = np.flatnonzero(result)
        result[meeting] = section(target[meeting], other[meeting])[2]
        return result

    first, second = overlapping_boxes(low[targets], high[targets], low[cutters], high[cutters], cuts)
    target, other = targets[first], cutters[second]  # sorted by target, as the pairs are
    start, end, _ = section(target, other)
    return target, start, end


def _plane_sections(triangles: np.ndarray, heights: np.ndarray):
    """Where triangles (k, 3, 3) with corner ``heights`` (k, 3) over a plane (exact zeros on it)
    meet the plane: segments (start, end) (k, 3) each, and (k,) bool, False where they meet it
    at a point at most."""
    following = [1, 2, 0]
    h, g = heights, heights[:, following]
    crosses = h * g < 0
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.where(crosses, h / (h - g), 0.0)
    crossings = triangles + t[..., None] * (triangles[:, following] - triangles)
    points = np.concatenate([triangles, crossings], axis=1)  # (k, 6, 3)
    valid = np.concatenate([h == 0, crosses], axis=1)
    first = valid.argmax(axis=1)
    start = points[np.arange(len(points)), first]
    offset = points - start[:, None]
    spread = np.where(valid, np.einsum("kpx,kpx->kp", offset, offset), -1.0)  # squared: its order and sign
    far = spread.argmax(axis=1)
    found = valid.any(axis=1) & (spread.max(axis=1) > 0)
    return start, points[np.arange(len(points)), far], found


def _length_inside(triangles: np.ndarray, normals: np.ndarray, start: np.ndarray, end: np.ndarray,
                   tolerance: np.ndarray) -> np.ndarray:
    """(k,) how long each segment runs inside its triangle, or 0 where its line does not separate
    the triangle's corners by more than ``tolerance`` or it runs inside for no more than that."""
    across = np.cross(normals, end - start)
    across /= np.maximum(np.linalg.norm(across, axis=1, keepdims=True), np.finfo(float).tiny)
    side = np.einsum("kcx,kx->kc", triangles - start[:, None], across)
    separates = (side.min(axis=1) < -tolerance) & (side.max(axis=1) > tolerance)
    length = _run_inside(triangles, np.full(len(triangles), 3), normals, start, end, tolerance)
    return np.where(separates & (length > tolerance), length, 0.0)


def _run_inside(polygons: np.ndarray, sizes: np.ndarray, normals: np.ndarray, start: np.ndarray, end: np.ndarray,
                tolerance: np.ndarray) -> np.ndarray:
    """(k,) how long each segment from ``start`` to ``end`` (k, 3) runs inside its convex polygon
    (k, V, 3) of ``sizes`` (k,) corners, counter-clockwise about ``normals`` (k, 3), grown by
    ``tolerance`` (k,): its parameter range clipped to the polygon's inner half-planes."""
    direction = end - start
    corner = np.arange(polygons.shape[1])
    used = corner < sizes[:, None]
    following = np.take_along_axis(polygons, np.where(corner + 1 < sizes[:, None], corner + 1, 0)[..., None], axis=1)
    inward = np.cross(normals[:, None], following - polygons)
    inward /= np.maximum(np.linalg.norm(inward, axis=2, keepdims=True), np.finfo(float).tiny)
    at_start = np.einsum("kvx,kvx->kv", start[:, None] - polygons, inward) + tolerance[:, None]
    rate = np.einsum("kx,kvx->kv", direction, inward)
    parallel = np.abs(rate) < 1e-300
    with np.errstate(divide="ignore", invalid="ignore"):
        bound = np.where(parallel, 0.0, -at_start / np.where(parallel, 1.0, rate))
    low = np.where(used & ~parallel & (rate > 0), bound, 0.0).max(axis=1, initial=0.0)
    high = np.where(used & ~parallel & (rate < 0), bound, 1.0).min(axis=1, initial=1.0)
    high = np.where((used & parallel & (at_start < 0)).any(axis=1), -np.inf, high)
    return np.maximum(high - low, 0.0) * np.linalg.norm(direction, axis=1)


def _cut(corners: np.ndarray, target: np.ndarray, start: np.ndarray, end: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Fan triangles (K, 3, 3) of the convex pieces of the triangles ``target`` (L,), sorted,
    cut along the lines of the segments from ``start`` to ``end`` (L, 3), and the triangle of
    each: each segment's line cuts the pieces the segment runs through. The pieces of all
    triangles are split at once, one line of each triangle per round: polygons of up to V
    corners padded to V. The triangles with most lines come first, so those still being cut are
    a leading run of the polygons, and the others are set aside once their last line is done (a
    table top that 400 cups' rims cut does not make every other piece wait 400 rounds). A round
    measures a segment only across the pieces whose ``_reach`` holds its box."""
    _, normals = areas_and_normals(corners)
    tolerance = CONTACT_TOLERANCE * longest_edges(corners)
    triangles, first_line, line_count = np.unique(target, return_index=True, return_counts=True)
    across = np.cross(normals[target], end - start)
    across /= np.linalg.norm(across, axis=1, keepdims=True)
    slot = np.argsort(-line_count, kind="stable")  # the triangle (index into ``triangles``) of each polygon
    polygons, sizes = corners[triangles[slot]], np.full(len(triangles), 3)
    low, high = _reach(polygons, sizes, normals[triangles[slot]], tolerance[triangles[slot]])
    finished = []
    for number in range(int(line_count.max())):
        heartbeat()
        cutting = int(np.searchsorted(-line_count[slot], -number, side="left"))  # line_count > number
        finished.append((polygons[cutting:], sizes[cutting:], slot[cutting:]))
        polygons, sizes, slot, low, high = (part[:cutting] for part in (polygons, sizes, slot, low, high))
        line = first_line[slot] + number
        # only the pieces the contact segment itself runs through: a line across the whole
        # triangle would cut every piece, L lines into O(L^2) pieces; and of those, only the
        # pieces whose reach holds the segment's box are measured
        near = np.flatnonzero((low <= np.maximum(start[line], end[line])).all(axis=1)
                              & (high >= np.minimum(start[line], end[line])).all(axis=1))
        line = line[near]
        runs = _run_inside(polygons[near], sizes[near], normals[target[line]], start[line], end[line],
                           tolerance[target[line]]) > tolerance[target[line]]
        crossed, line = near[runs], line[runs]
        positive, negative, cuts = _split(polygons[crossed], sizes[crossed], start[line], across[line],
                                          tolerance[target[line]])
        split = np.zeros(len(polygons), dtype=bool)
        split[crossed] = cuts
        width = max(polygons.shape[1], positive[0].shape[1], negative[0].shape[1])
        copies = np.where(split, 2, 1)
        at = np.cumsum(copies) - copies  # each polygon's first place in the new list
        new_polygons = np.zeros((copies.sum(), width, 3))
        new_polygons[at, : polygons.shape[1]] = polygons
        new_sizes = np.repeat(sizes, copies)
        for place, (points, count) in ((at[split], positive), (at[split] + 1, negative)):
            new_polygons[place] = 0.0
            new_polygons[place, : points.shape[1]] = points[cuts]
            new_sizes[place] = count[cuts]
        low, high = np.repeat(low, copies, axis=0), np.repeat(high, copies, axis=0)
        halves, owner = np.concatenate([at[split], at[split] + 1]), np.tile(target[line[cuts]], 2)
        low[halves], high[halves] = _reach(new_polygons[halves], new_sizes[halves], normals[owner], tolerance[owner])
        polygons, sizes, slot = new_polygons, new_sizes, np.repeat(slot, copies)
    finished.append((polygons, sizes, slot))
    sizes = np.concatenate([part[1] for part in finished])
    slot = np.concatenate([part[2] for part in finished])
    width = max(part[0].shape[1] for part in finished)
    polygons = np.concatenate([np.pad(part[0], ((0, 0), (0, width - part[0].shape[1]), (0, 0))) for part in finished])
    fans = sizes - 2
    polygon = np.repeat(np.arange(len(sizes)), fans)
    second = ranks(fans) + 1
    return np.stack([polygons[polygon, 0], polygons[polygon, second], polygons[polygon, second + 1]], axis=1), \
        triangles[slot[polygon]]


def _reach(polygons: np.ndarray, sizes: np.ndarray, normals: np.ndarray,
           tolerance: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(k, 3) lowest and highest corners of boxes that hold each convex polygon (k, V, 3) of
    ``sizes`` (k,) corners, counter-clockwise about ``normals`` (k, 3), grown by ``tolerance``
    (k,) as ``_run_inside`` grows it: each edge moved out by t moves a corner of interior angle a
    by t / sin(a / 2), which is 1 / cos of half the turn between the edges' outward normals o and
    o' (|o + o'| / (1 + o . o')); one tolerance more keeps rounding from dropping a piece a
    segment runs through. A polygon with a corner sharper than about 0.1 degree, or an edge of no
    length, reaches everywhere."""
    corner = np.arange(polygons.shape[1])
    used = corner < sizes[:, None]
    following = np.take_along_axis(polygons, np.where(corner + 1 < sizes[:, None], corner + 1, 0)[..., None], axis=1)
    outward = np.cross(following - polygons, normals[:, None])
    length = np.linalg.norm(outward, axis=2)
    outward /= np.maximum(length, np.finfo(float).tiny)[..., None]
    before = np.take_along_axis(outward, np.where(corner > 0, corner - 1, sizes[:, None] - 1)[..., None], axis=1)
    turn = 1.0 + np.einsum("kvx,kvx->kv", before, outward)  # 1 + o . o' = 2 cos^2 of half the turn
    stretch = np.where(used, np.linalg.norm(before + outward, axis=2) / np.maximum(turn, 1e-300), 0.0).max(axis=1)
    spread = ((used & ((turn < 1e-6) | (length <= 0))).any(axis=1))
    margin = np.where(spread, np.inf, (stretch + 1.0) * tolerance)[:, None]
    low = np.where(used[..., None], polygons, np.inf).min(axis=1) - margin
    high = np.where(used[..., None], polygons, -np.inf).max(axis=1) + margin
    return low, high


def _split(polygons: np.ndarray, sizes: np.ndarray, start: np.ndarray, across: np.ndarray,
           tolerance: np.ndarray) -> tuple[tuple[np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray], np.ndarray]:
    """Convex polygons (k, V, 3) of ``sizes`` (k,) corners split by the lines through ``start``
    (k, 3) normal to unit ``across`` (k, 3): the sides across >= 0 and <= 0 (corners within
    ``tolerance`` (k,) of the line on both), each as (polygons (k, W, 3), sizes (k,)), and (k,)
    whether the line crosses the polygon's inside (elsewhere the sides are not meaningful)."""
    count, width = polygons.shape[:2]
    corner = np.arange(width)
    valid = corner < sizes[:, None]
    side = np.einsum("kvx,kx->kv", polygons - start[:, None], across)
    side[np.abs(side) <= tolerance[:, None]] = 0
    split = (np.where(valid, side, np.inf).min(axis=1) < 0) & (np.where(valid, side, -np.inf).max(axis=1) > 0)
    following = np.where(corner + 1 < sizes[:, None], corner + 1, 0)
    next_side = np.take_along_axis(side, following, axis=1)
    next_corner = np.take_along_axis(polygons, following[..., None], axis=1)
    crosses = valid & (side * next_side < 0)
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.where(crosses, side / (side - next_side), 0.0)
    crossing = polygons + t[..., None] * (next_corner - polygons)
    slots = np.stack([polygons, crossing], axis=2).reshape(count, 2 * width, 3)  # each corner, then its edge's crossing
    sides = []
    for keep in (side >= 0, side <= 0):
        used = np.stack([valid & keep, crosses], axis=2).reshape(count, 2 * width)
        place = np.cumsum(used, axis=1) - 1
        result = np.zeros((count, max(1, int(used.sum(axis=1).max())), 3))
        row, column = np.nonzero(used)
        result[row, place[row, column]] = slots[row, column]
        sides.append((result, used.sum(axis=1)))
    return sides[0], sides[1], split
