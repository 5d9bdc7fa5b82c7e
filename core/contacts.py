"""Contact lines: triangles cut where another surface meets them, so that no patch straddles one.

A block standing on a floor meets it along the bottom edges of its sides. A floor patch across
that line is half in the open and half under the block: its one radiosity is neither side's, and
the block's bottom corners, which see the floor there at point-blank range, take it for the
floor's value at the line (docs/cycles.md measured those corners at 0.83 of Cycles'). Cutting the
floor's triangles along the line (discontinuity meshing of the contact, Heckbert 1992, "Discontinuity
meshing for radiosity"; Lischinski, Tampieri and Greenberg 1992) puts patch edges on it.

A triangle U meets triangle T's plane along a segment where U's corners lie on both sides of the
plane, or along an edge of U lying in it (within CONTACT_TOLERANCE of T's size). Each segment
that passes through T's inside cuts T along its whole line: T becomes convex pieces, split in
fans. Triangles of T's own plane are its neighbours, not contacts.
"""

from __future__ import annotations

import numpy as np

from . import spatial
from .geometry import areas_and_normals, longest_edges

CONTACT_TOLERANCE = 1e-6  # distance to a plane, as a fraction of the triangle's longest edge, that counts as on it
PARALLEL = 1e-9  # 1 - |cos| below which two triangles are coplanar (or parallel) and do not cut each other


def pieces(corners: np.ndarray, degenerate: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Triangles (T, 3, 3) cut along their contact lines: (K, 3, 3) pieces with the winding of
    their triangle, and (K,) the triangle of each, in triangle order. A triangle without contact
    (or ``degenerate``, (T,) bool) is its own single piece."""
    lines = _contact_lines(corners, degenerate)
    if not lines:
        return corners, np.arange(len(corners))
    uncut = np.ones(len(corners), dtype=bool)
    uncut[list(lines)] = False
    parts = [corners[uncut]] + [_cut(corners[t], lines[t]) for t in lines]
    owners = [np.flatnonzero(uncut)] + [np.full(len(part), t) for t, part in zip(lines, parts[1:])]
    owner = np.concatenate(owners)
    order = np.argsort(owner, kind="stable")
    return np.concatenate(parts)[order], owner[order]


def _contact_lines(corners: np.ndarray, degenerate: np.ndarray) -> dict[int, list[tuple[np.ndarray, np.ndarray]]]:
    """For each triangle met by another inside, the lines (point, direction) that cut it."""
    valid = np.flatnonzero(~degenerate)
    centres = corners[valid].mean(axis=1)
    radii = np.linalg.norm(corners[valid] - centres[:, None], axis=2).max(axis=1)
    first, second = spatial.overlapping(centres, radii, centres, radii)
    target, other = valid[first], valid[second]
    _, normals = areas_and_normals(corners)
    crossing = np.abs((normals[target] * normals[other]).sum(axis=1)) < 1 - PARALLEL
    target, other = target[crossing], other[crossing]
    size = longest_edges(corners)
    heights = np.einsum("kcx,kx->kc", corners[other] - corners[target][:, :1], normals[target])
    heights[np.abs(heights) <= CONTACT_TOLERANCE * size[target][:, None]] = 0
    meets = (heights.min(axis=1) <= 0) & (heights.max(axis=1) >= 0)
    lines: dict[int, list] = {}
    for k in np.flatnonzero(meets):
        segment = _plane_section(corners[other[k]], heights[k])
        if segment is None:
            continue
        t = target[k]
        if _crosses_inside(corners[t], normals[t], segment, CONTACT_TOLERANCE * size[t]):
            lines.setdefault(int(t), []).append(segment)
    return lines


def _plane_section(triangle: np.ndarray, heights: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
    """The segment (start, end) where a triangle with corner ``heights`` over a plane (exact
    zeros on it) meets the plane, or None if only at a point."""
    points = [triangle[i] for i in range(3) if heights[i] == 0]
    for i in range(3):
        j = (i + 1) % 3
        if heights[i] * heights[j] < 0:
            points.append(triangle[i] + heights[i] / (heights[i] - heights[j]) * (triangle[j] - triangle[i]))
    if len(points) < 2:
        return None
    points = np.array(points)
    spread = np.linalg.norm(points - points[0], axis=1)
    far = int(spread.argmax())
    if spread[far] == 0:
        return None
    return points[0], points[far]


def _crosses_inside(triangle: np.ndarray, normal: np.ndarray, segment, tolerance: float) -> bool:
    """Whether the segment's line separates the triangle's corners (by more than ``tolerance``)
    and the segment itself reaches inside the triangle."""
    start, end = segment
    direction = end - start
    across = np.cross(normal, direction)
    across /= np.linalg.norm(across)
    side = (triangle - start) @ across
    if side.min() >= -tolerance or side.max() <= tolerance:
        return False
    # clip the segment's parameter range to the triangle's three inner half-planes
    low, high = 0.0, 1.0
    for i in range(3):
        edge = triangle[(i + 1) % 3] - triangle[i]
        inward = np.cross(normal, edge)
        inward /= np.linalg.norm(inward)
        at_start = (start - triangle[i]) @ inward + tolerance
        rate = direction @ inward
        if abs(rate) < 1e-300:
            if at_start < 0:
                return False
            continue
        bound = -at_start / rate
        if rate > 0:
            low = max(low, bound)
        else:
            high = min(high, bound)
    return high - low > tolerance / np.linalg.norm(direction)


def _cut(triangle: np.ndarray, lines: list) -> np.ndarray:
    """(k, 3, 3) fan triangles of the convex pieces of ``triangle`` cut by ``lines``."""
    _, normal = areas_and_normals(triangle[None])
    normal = normal[0]
    tolerance = CONTACT_TOLERANCE * longest_edges(triangle[None])[0]
    polygons = [list(triangle)]
    for start, end in lines:
        across = np.cross(normal, end - start)
        across /= np.linalg.norm(across)
        split = []
        for polygon in polygons:
            split.extend(_split_polygon(polygon, start, across, tolerance))
        polygons = split
    return np.array([[polygon[0], polygon[i], polygon[i + 1]] for polygon in polygons
                     for i in range(1, len(polygon) - 1)])


def _split_polygon(polygon: list, start: np.ndarray, across: np.ndarray, tolerance: float) -> list:
    """A convex polygon (list of corners) split by the line through ``start`` normal to
    ``across`` into its two sides, or itself if the line misses its inside."""
    side = np.array([(corner - start) @ across for corner in polygon])
    side[np.abs(side) <= tolerance] = 0
    if side.min() >= 0 or side.max() <= 0:
        return [polygon]
    positive, negative = [], []
    for i, corner in enumerate(polygon):
        j = (i + 1) % len(polygon)
        if side[i] >= 0:
            positive.append(corner)
        if side[i] <= 0:
            negative.append(corner)
        if side[i] * side[j] < 0:
            crossing = corner + side[i] / (side[i] - side[j]) * (polygon[j] - corner)
            positive.append(crossing)
            negative.append(crossing)
    return [positive, negative]
