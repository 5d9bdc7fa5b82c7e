"""A ray caster in NumPy alone, for where Embree (``embreex``) cannot be imported: the queries of
``embreex.rtcore_scene.EmbreeScene.run`` that ``visibility`` uses, with the same answers, 5 to 15
times slower than Embree on one core (the bake's coherent rays gain most from the packets).

Hierarchy: a binary bounding volume hierarchy (BVH) built top-down with the surface area
heuristic (SAH), one depth at a time for all nodes at once: per node and axis the triangles are
sorted by the centres of their boxes and every split position is costed from running bounds (a
full sweep, Wald, Boulos and Shirley 2007, "Ray tracing deformable scenes using dynamic BVHs",
ACM TOG 26(1)); nodes of at most ``leaf_size`` triangles are leaves.

Traversal is breadth first over packets of rays (Garanzha and Loop 2010, "Fast ray sorting and
breadth-first packet traversal for GPU ray tracing", Eurographics): consecutive rays that start
together and point the same way form a packet, bounded by intervals of origins and of inverse
directions. A frontier of (packet, node) pairs is tested against the boxes of both children of
each node at once, the interval slab test (Kay and Kajiya 1986, with interval arithmetic as in
Boulos et al. 2006, "Geometric and arithmetic culling methods for entire ray packets") passing
a child if any ray of the packet can cross it; a packet's rays run into one octant, and the
test works in a frame mirrored so that their directions are all positive. Packets reaching a
leaf split into their rays, each tested against the leaf's box, then its triangles. A blocked
ray (OCCLUDED) drops out; for INTERSECT, boxes beyond the nearest hit so far are culled. A step
is a few NumPy calls on every pair of the frontier, so Python's overhead grows with the depth
of the tree, not with the number of rays; memory is bounded (a few tens of MB) by tracing
CHUNK_RAYS rays at a time and splitting large frontiers and leaf batches.

The arrays are small for NumPy (thousands of elements), so threads tracing side by side mostly
wait for one another's GIL: the tracer is about as fast on one core as on several.

Triangles: the watertight test of Woop, Benthin and Wald (2013, "Watertight ray/triangle
intersection", JCGT 2(1)), in float32 as Embree. Its edge functions are computed per corner in a
frame sheared along the ray, so an edge shared by two triangles gets exactly opposite values in
both (the same two products, subtracted the other way round) and a ray through a shared edge or
vertex hits at least one of the triangles around it: a closed mesh has no cracks. Both sides
are hit (no culling), as by Embree's default.
"""

from __future__ import annotations

import numpy as np

QUERIES = ("OCCLUDED", "INTERSECT")
LEAF_SIZE = 2  # most triangles in a leaf (a leaf's per-ray box test costs about one triangle test)
CHUNK_RAYS = 1 << 15  # rays traced together
FRONTIER_PAIRS = 1 << 17  # larger frontiers are traced in halves
LEAF_PAIRS = 1 << 16  # (ray, leaf) pairs tested at once
PACKET_SIZE = 16  # most rays in a packet
# Rays whose origins differ by more than this fraction of the scene's extent are not packed together.
PACKET_ORIGIN = 1e-3
# A packet is halved until its unit directions span at most this many times the median extent of
# a leaf over the scene's extent (per axis): a wider bundle reaches many leaves its rays miss.
PACKET_SPREAD = 20.0
# Boxes are widened by this fraction of the scene's extent, which covers the rounding of their
# bounds, so the slab test never rejects a ray that hits a triangle inside a box.
BOX_PADDING = 1e-6
# The exit distance of the slab test is scaled by 1 + 2 gamma_3 (float32), which makes the test
# conservative whatever its rounding (Ize 2013, "Robust BVH ray traversal", JCGT 2(2)).
_ROBUST_EXIT = np.float32(1 + 2 * (3 * 2.0**-24) / (1 - 3 * 2.0**-24))
_TINY = np.float32(1e-30)  # a zero direction component becomes this, with its sign
_MEDIAN_DEPTH = 64  # deeper nodes split at their median (the SAH chains coincident triangles)


class NumpyTracer:
    """Occlusion and nearest-hit queries against fixed triangles, by a BVH traced in NumPy.

    triangles : (P, 3, 3) float, the corners of each triangle (index p is what INTERSECT
        returns); degenerate triangles are allowed and never hit.
    leaf_size : most triangles in a leaf of the hierarchy.

    ``run`` may be called from several threads at once.
    """

    def __init__(self, triangles: np.ndarray, leaf_size: int = LEAF_SIZE) -> None:
        triangles = np.asarray(triangles, dtype=np.float64)
        if triangles.ndim != 3 or triangles.shape[1:] != (3, 3):
            raise ValueError(f"triangles must have shape (P, 3, 3), got {triangles.shape}")
        if leaf_size < 1:
            raise ValueError(f"leaf_size must be at least 1, got {leaf_size}")
        self.triangle_count = len(triangles)
        if self.triangle_count:
            self._build(triangles, leaf_size)

    @property
    def bytes(self) -> int:
        """The memory its arrays hold (the hierarchy and the triangles)."""
        return sum(value.nbytes for value in vars(self).values() if isinstance(value, np.ndarray))

    def _build(self, triangles: np.ndarray, leaf_size: int) -> None:
        box_low, box_high = triangles.min(axis=1).T, triangles.max(axis=1).T  # (3, P)
        centre = (box_low + box_high) / 2
        scene_low, scene_high = box_low.min(axis=1), box_high.max(axis=1)
        extent = float(np.max(scene_high - scene_low))
        order = np.arange(self.triangle_count)
        # the nodes of the current depth: their triangles order[start : start + count], bounds
        starts, counts = np.zeros(1, dtype=np.int64), np.array([self.triangle_count])
        lows, highs = scene_low[:, None], scene_high[:, None]  # (3, nodes)
        node_low, node_high, node_child, node_start, node_count = [], [], [], [], []
        next_id, depth = 1, 0
        while len(starts):
            split = counts > leaf_size
            node_low.append(lows)
            node_high.append(highs)
            node_start.append(np.where(split, 0, starts))
            node_count.append(np.where(split, 0, counts))
            children = np.full(len(starts), -1, dtype=np.int64)
            children[split] = next_id + 2 * np.arange(np.count_nonzero(split))
            node_child.append(children)
            next_id += 2 * np.count_nonzero(split)
            if not split.any():
                break
            parent_starts, parent_counts = starts[split], counts[split]
            positions, members, left, bounds = _split(
                order, box_low, box_high, centre, parent_starts, parent_counts, extent, depth >= _MEDIAN_DEPTH
            )
            order[positions] = members
            starts = np.stack([parent_starts, parent_starts + left], axis=1).ravel()
            counts = np.stack([left, parent_counts - left], axis=1).ravel()
            lows = np.stack([bounds[0], bounds[2]], axis=2).reshape(3, -1)
            highs = np.stack([bounds[1], bounds[3]], axis=2).reshape(3, -1)
            depth += 1
        padding = BOX_PADDING * extent
        # rounded outwards onto float32, so that the padded boxes still hold their triangles
        low = np.nextafter((np.concatenate(node_low, axis=1) - padding).astype(np.float32), np.float32(-np.inf))
        high = np.nextafter((np.concatenate(node_high, axis=1) + padding).astype(np.float32), np.float32(np.inf))
        child = np.concatenate(node_child)
        internal = child >= 0
        self._child = child  # left child, the right one is next; -1 for a leaf
        self._is_leaf = ~internal
        self._start = np.concatenate(node_start)  # a leaf's triangles: slots start .. start + count
        self._count = np.concatenate(node_count)
        self._bounds = np.concatenate([low, high])  # (6, N) low x, y, z, high x, y, z of each node
        kids = np.where(internal, child, 0)
        # per axis, (4, 2 N): in column f N + i, the near planes of node i's two children, then
        # their far planes, for rays running up (f = 0: low, high) or down the axis (f = 1: -high,
        # -low: the mirrored frame of the packet test); junk for a leaf
        self._slab_tables = []
        for axis in range(3):
            low_planes = np.stack([low[axis, kids], low[axis, kids + internal]])  # (2, N)
            high_planes = np.stack([high[axis, kids], high[axis, kids + internal]])
            self._slab_tables.append(np.ascontiguousarray(np.concatenate(
                [np.concatenate([low_planes, -high_planes], axis=1),
                 np.concatenate([high_planes, -low_planes], axis=1)])))
        self._order = order.astype(np.int32)  # slot -> the caller's triangle index
        # (9, P) float32 corners by slot: x, y, z of corner 0, then of corner 1, then of corner 2
        self._corners = np.ascontiguousarray(triangles[order].reshape(-1, 9).T, dtype=np.float32)
        self.node_count = len(child)
        self.depth = depth
        scale = max(extent, float(np.finfo(np.float32).tiny))
        leaf_extent = np.median((high - low)[:, self._is_leaf].max(axis=0))
        self._packet_origin = np.float32(PACKET_ORIGIN * scale)
        self._packet_spread = np.float32(PACKET_SPREAD * leaf_extent / scale)

    def run(self, origins: np.ndarray, directions: np.ndarray, dists: np.ndarray | None = None,
            query: str = "INTERSECT") -> np.ndarray:
        """(n,) int32 for each ray origin + t direction, 0 <= t <= dists (both ends included,
        as by Embree; dists None: no limit): OCCLUDED gives -1 where no triangle lies on the ray
        and another value where one does; INTERSECT the index of the nearest triangle hit, or -1
        (of two at the same distance, either).

        origins, directions : (n, 3) float (directions of any non-zero length).
        dists : (n,) float or None.
        """
        if query not in QUERIES:
            raise ValueError(f"query must be one of {QUERIES}, got {query!r}")
        origins = np.asarray(origins, dtype=np.float32)
        directions = np.asarray(directions, dtype=np.float32)
        if origins.ndim != 2 or origins.shape[1] != 3 or directions.shape != origins.shape:
            raise ValueError(f"origins and directions must both have shape (n, 3), got {origins.shape} and "
                             f"{directions.shape}")
        count = len(origins)
        if dists is None:
            dists = np.full(count, np.inf, dtype=np.float32)
        else:
            dists = np.asarray(dists, dtype=np.float32)
            if dists.shape != (count,):
                raise ValueError(f"dists must have shape ({count},), got {dists.shape}")
        result = np.full(count, -1, dtype=np.int32)
        if self.triangle_count == 0 or count == 0:
            return result
        # the slab test divides by the direction: a zero component becomes tiny, keeping its sign
        safe = np.where(np.abs(directions) < _TINY, np.copysign(_TINY, directions), directions)
        for begin in range(0, count, CHUNK_RAYS):
            rays = slice(begin, begin + CHUNK_RAYS)
            chunk = _Chunk(self, origins[rays], directions[rays], safe[rays], dists[rays], query == "OCCLUDED")
            result[rays] = chunk.trace()
        return result


def _split(order, box_low, box_high, centre, starts, counts, extent, median):
    """The best SAH split of each node's triangles order[starts[s] : starts[s] + counts[s]]
    (counts > 1), or the median one if ``median``. Returns the positions of the nodes'
    triangles in ``order``, their new order (sorted along each node's split axis), the size of
    each left part, and the (3, s) low and high bounds of the left and right parts."""
    nodes, total = len(starts), int(counts.sum())
    node = np.repeat(np.arange(nodes), counts)
    first = np.cumsum(counts) - counts
    local = np.arange(total) - first[node]  # index within the node
    positions = starts[node] + local
    members = order[positions]
    stride = 2 * (extent + 1.0)  # more than any difference of coordinates
    best_cost = np.full(nodes, np.inf)
    best_split = np.zeros(nodes, dtype=np.int64)
    best_axis = np.zeros(nodes, dtype=np.int64)
    sorted_members, sweeps = [], []
    reverse_node = node[-1] - node[::-1]
    for axis in range(3):
        ordered = members[np.argsort(node * stride + centre[axis, members])]
        low, high = box_low[:, ordered], box_high[:, ordered]
        # running bounds from each node's start (prefix) and from its end (suffix)
        prefix_low = _running(low, node, stride, np.minimum)
        prefix_high = _running(high, node, stride, np.maximum)
        suffix_low = _running(low[:, ::-1], reverse_node, stride, np.minimum)[:, ::-1]
        suffix_high = _running(high[:, ::-1], reverse_node, stride, np.maximum)[:, ::-1]
        if median:
            cost = np.abs(local + 1 - counts[node] // 2).astype(float)
        else:  # split after element i: left = [first, i], right = [i + 1, last]
            right_area = np.zeros(total)
            right_area[:-1] = _half_area(suffix_high[:, 1:] - suffix_low[:, 1:])
            cost = _half_area(prefix_high - prefix_low) * (local + 1) + right_area * (counts[node] - local - 1)
        cost[first + counts - 1] = np.inf  # nothing right of the last element
        lowest = np.minimum.reduceat(cost, first)
        candidates = np.flatnonzero(cost == lowest[node])
        of_node = node[candidates]
        chosen = candidates[np.append(True, of_node[1:] != of_node[:-1])]  # the first per node
        better = lowest < best_cost
        best_cost[better] = lowest[better]
        best_split[better] = local[chosen[better]]
        best_axis[better] = axis
        sorted_members.append(ordered)
        sweeps.append((prefix_low, prefix_high, suffix_low, suffix_high))
    new_members = np.choose(best_axis[node], sorted_members)
    bounds = [np.empty((3, nodes)) for _ in range(4)]
    for axis, (prefix_low, prefix_high, suffix_low, suffix_high) in enumerate(sweeps):
        chosen = np.flatnonzero(best_axis == axis)
        at = first[chosen] + best_split[chosen]
        bounds[0][:, chosen], bounds[1][:, chosen] = prefix_low[:, at], prefix_high[:, at]
        bounds[2][:, chosen], bounds[3][:, chosen] = suffix_low[:, at + 1], suffix_high[:, at + 1]
    return positions, new_members, best_split + 1, bounds


def _running(values: np.ndarray, node: np.ndarray, stride: float, ufunc: np.ufunc) -> np.ndarray:
    """Running minimum or maximum (``ufunc``) of ``values`` (3, m) along m, restarting where
    ``node`` (m,), non-decreasing, changes: each node's values are shifted by ``stride`` (more
    than their range) beyond the previous node's, so one accumulate never reaches back across
    nodes. The shift costs a rounding of about 1e-16 stride * nodes, far inside BOX_PADDING."""
    shift = (stride if ufunc is np.maximum else -stride) * node
    return ufunc.accumulate(values + shift, axis=1) - shift


def _half_area(extent: np.ndarray) -> np.ndarray:
    x, y, z = extent
    return x * y + y * z + z * x


class _Chunk:
    """Rays traced together (at most CHUNK_RAYS): their packets, per-ray data and results."""

    def __init__(self, tracer: NumpyTracer, origins, directions, safe, dists, occluded: bool) -> None:
        self.tracer = tracer
        self.occluded = occluded
        count = len(origins)
        origins, directions = np.ascontiguousarray(origins.T), np.ascontiguousarray(directions.T)  # (3, m)
        inverse = (1 / safe.T).astype(np.float32)
        self.slabs = np.concatenate([origins, inverse])  # (6, m): for the per-ray box test
        # each ray in the frame mirrored along the axes it runs down: all its directions positive
        negative = np.signbit(safe.T)
        sign = np.where(negative, np.float32(-1), np.float32(1))
        mirrored, inverse = origins * sign, inverse * sign
        self.start, self.size = self._packets(tracer, mirrored, directions, negative)
        # (3, p): per packet and axis, the column offset of its planes in the slab tables
        self.flip = negative[:, self.start] * tracer.node_count
        # per packet: (12, p) highest origin (against near planes), lowest origin (against far
        # planes), smallest and largest inverse direction
        self.packets = np.concatenate([np.maximum.reduceat(mirrored, self.start, axis=1),
                                       np.minimum.reduceat(mirrored, self.start, axis=1),
                                       np.minimum.reduceat(inverse, self.start, axis=1),
                                       np.maximum.reduceat(inverse, self.start, axis=1)])
        self.nearest = dists.copy()  # the nearest hit so far; -inf once blocked (OCCLUDED)
        self.hit = np.full(count, -1, dtype=np.int32)
        # the triangle test's frame: z along the direction's largest component, then x, y
        size = np.abs(directions)
        self.major = np.where(size[0] >= np.maximum(size[1], size[2]), 0, np.where(size[1] >= size[2], 1, 2))
        rows = [np.choose(self.major, [data[(kz + shift) % 3] for kz in range(3)])
                for data in (origins, directions) for shift in (1, 2, 0)]
        with np.errstate(divide="ignore", invalid="ignore"):  # a zero direction: NaN, never hits
            shear = 1 / rows[5]
            # (6, m): origin x, y, z, shear x, y, z (Woop et al.: Sx = dx / dz, Sy = dy / dz, Sz = 1 / dz)
            self.frame = np.stack(rows[:3] + [rows[3] * shear, rows[4] * shear, shear])

    @staticmethod
    def _packets(tracer: NumpyTracer, mirrored: np.ndarray, directions: np.ndarray, negative: np.ndarray):
        """First ray and ray count of each packet: runs of at most PACKET_SIZE consecutive rays
        into the same octant (``negative``, (3, m): the signs of their directions) whose origins
        (``mirrored``, (3, m)) are close, halved until their directions (3, m) are close (both
        relative to the scene, see PACKET_ORIGIN and PACKET_SPREAD)."""
        count = mirrored.shape[1]
        new = np.ones(count, dtype=bool)
        step = np.abs(mirrored[:, 1:] - mirrored[:, :-1])
        new[1:] = np.maximum(np.maximum(step[0], step[1]), step[2]) > tracer._packet_origin
        new[1:] |= (negative[0, 1:] != negative[0, :-1]) | (negative[1, 1:] != negative[1, :-1])
        new[1:] |= negative[2, 1:] != negative[2, :-1]
        run_start = np.flatnonzero(new)
        position = np.arange(count) - np.repeat(run_start, np.diff(np.append(run_start, count)))
        with np.errstate(divide="ignore", invalid="ignore"):
            units = directions / np.sqrt(np.einsum("xm,xm->m", directions, directions))
        size = PACKET_SIZE
        new |= position % size == 0
        while size > 1:
            start = np.flatnonzero(new)
            spread = np.maximum.reduceat(units, start, axis=1) - np.minimum.reduceat(units, start, axis=1)
            wide = np.maximum(np.maximum(spread[0], spread[1]), spread[2]) > tracer._packet_spread
            if not wide.any():
                break
            size //= 2
            new |= np.repeat(wide, np.diff(np.append(start, count))) & (position % size == 0)
        start = np.flatnonzero(new)
        return start, np.diff(np.append(start, count))

    def trace(self) -> np.ndarray:
        """(m,) int32: the triangle hit by each ray (OCCLUDED: any; INTERSECT: the nearest)."""
        tracer = self.tracer
        packet = np.arange(len(self.start))
        node = np.zeros(len(packet), dtype=np.intp)
        if tracer._is_leaf[0]:
            self._leaves(packet, node)
            return self.hit
        reach = np.maximum.reduceat(self.nearest, self.start)
        work = [(packet, node)]
        while work:
            packet, node = work.pop()
            if len(packet) > FRONTIER_PAIRS:
                half = len(packet) // 2
                work += [(packet[half:], node[half:]), (packet[:half], node[:half])]
                continue
            flip_x, flip_y, flip_z = np.take(self.flip, packet, axis=1, mode="clip")
            (top_x, top_y, top_z, bottom_x, bottom_y, bottom_z,
             small_x, small_y, small_z, large_x, large_y, large_z) = np.take(self.packets, packet, axis=1, mode="clip")
            # every ray of the packet enters a box no sooner than (near - highest origin) times the
            # smallest or largest inverse direction, and leaves it no later than (far - lowest
            # origin) times one of them; both children at once, (2, k) arrays
            planes = np.take(tracer._slab_tables[0], node + flip_x, axis=1, mode="clip")  # near, far
            gap = planes[:2] - top_x
            entry = np.minimum(gap * small_x, gap * large_x)
            gap = planes[2:] - bottom_x
            exit_ = np.maximum(gap * small_x, gap * large_x)
            planes = np.take(tracer._slab_tables[1], node + flip_y, axis=1, mode="clip")
            gap = planes[:2] - top_y
            np.maximum(entry, np.minimum(gap * small_y, gap * large_y), out=entry)
            gap = planes[2:] - bottom_y
            np.minimum(exit_, np.maximum(gap * small_y, gap * large_y), out=exit_)
            planes = np.take(tracer._slab_tables[2], node + flip_z, axis=1, mode="clip")
            gap = planes[:2] - top_z
            np.maximum(entry, np.minimum(gap * small_z, gap * large_z), out=entry)
            gap = planes[2:] - bottom_z
            np.minimum(exit_, np.maximum(gap * small_z, gap * large_z), out=exit_)
            exit_ *= _ROBUST_EXIT
            passed = np.flatnonzero((entry <= exit_) & (exit_ >= 0) & (entry <= reach[packet]))
            right = passed >= len(packet)
            pair = passed - right * len(packet)
            node = tracer._child[node[pair]] + right
            packet = packet[pair]
            leaf = tracer._is_leaf[node]
            if leaf.any():
                at = np.flatnonzero(leaf)
                self._leaves(packet[at], node[at])
                reach = np.maximum.reduceat(self.nearest, self.start)
                at = np.flatnonzero(~leaf & (reach[packet] >= 0)) if self.occluded else np.flatnonzero(~leaf)
                packet, node = packet[at], node[at]
            if len(packet):
                work.append((packet, node))
        return self.hit

    def _leaves(self, packet: np.ndarray, node: np.ndarray) -> None:
        """Every ray of packets ``packet`` against the triangles of leaves ``node``, in batches of
        at most about LEAF_PAIRS (ray, leaf) pairs."""
        per_pair = self.size[packet]
        total = np.cumsum(per_pair)
        for begin, end in _batches(total, LEAF_PAIRS):
            size = per_pair[begin:end]
            first = total[begin:end] - size
            ray = np.repeat(self.start[packet[begin:end]] - first, size) + np.arange(first[0], total[end - 1])
            self._leaf_rays(ray, np.repeat(node[begin:end], size))

    def _leaf_rays(self, ray: np.ndarray, node: np.ndarray) -> None:
        """Each ray ``ray`` against the box of leaf ``node``, then against its triangles."""
        tracer = self.tracer
        low_x, low_y, low_z, high_x, high_y, high_z = np.take(tracer._bounds, node, axis=1, mode="clip")
        x, y, z, scale_x, scale_y, scale_z = np.take(self.slabs, ray, axis=1, mode="clip")
        ax, bx = (low_x - x) * scale_x, (high_x - x) * scale_x
        ay, by = (low_y - y) * scale_y, (high_y - y) * scale_y
        az, bz = (low_z - z) * scale_z, (high_z - z) * scale_z
        entry = np.maximum(np.maximum(np.minimum(ax, bx), np.minimum(ay, by)), np.minimum(az, bz))
        exit_ = np.minimum(np.minimum(np.maximum(ax, bx), np.maximum(ay, by)), np.maximum(az, bz))
        exit_ *= _ROBUST_EXIT
        at = np.flatnonzero((entry <= exit_) & (exit_ >= 0) & (entry <= self.nearest[ray]))
        ray, node = ray[at], node[at]
        per_pair = tracer._count[node]
        first = np.cumsum(per_pair) - per_pair
        slot = np.repeat(tracer._start[node] - first, per_pair) + np.arange(int(per_pair.sum()))
        ray = np.repeat(ray, per_pair)
        major = self.major[ray]
        for axis in range(3):
            at = np.flatnonzero(major == axis)
            if len(at):
                self._triangles(ray[at], slot[at], axis)

    def _triangles(self, ray: np.ndarray, slot: np.ndarray, kz: int) -> None:
        """The watertight test of rays ``ray``, running mostly along axis ``kz``, against the
        triangles in slots ``slot``; records hits in ``hit`` and ``nearest``."""
        kx, ky = (kz + 1) % 3, (kz + 2) % 3
        ox, oy, oz, shear_x, shear_y, shear_z = np.take(self.frame, ray, axis=1, mode="clip")
        corners = np.take(self.tracer._corners, slot, axis=1, mode="clip")
        # each corner relative to the origin, sheared so that the ray runs along z
        z = [corners[3 * c + kz] - oz for c in range(3)]
        x = [corners[3 * c + kx] - ox - shear_x * z[c] for c in range(3)]
        y = [corners[3 * c + ky] - oy - shear_y * z[c] for c in range(3)]
        # edge functions U, V, W: the ray against the edge opposite each corner
        u = x[2] * y[1] - y[2] * x[1]
        v = x[0] * y[2] - y[0] * x[2]
        w = x[1] * y[0] - y[1] * x[0]
        determinant = u + v + w
        distance = (u * z[0] + v * z[1] + w * z[2]) * shear_z  # t * determinant
        # a hit: U, V, W all >= 0 or all <= 0, their sum (the determinant) not 0, and
        # 0 <= t <= nearest, both ends included as by Embree
        nearest = self.nearest
        with np.errstate(invalid="ignore"):  # inf * 0 = NaN: a ray in the triangle's plane, no hit
            reach = nearest[ray] * determinant
        hit = np.flatnonzero(np.where(
            determinant > 0,
            (u >= 0) & (v >= 0) & (w >= 0) & (distance >= 0) & (distance <= reach),
            (u <= 0) & (v <= 0) & (w <= 0) & (distance <= 0) & (distance >= reach) & (determinant < 0),
        ))
        if not len(hit):
            return
        ray, slot = ray[hit], slot[hit]
        if self.occluded:
            self.hit[ray] = self.tracer._order[slot]
            nearest[ray] = -np.inf
            return
        t = distance[hit] / determinant[hit]
        # the nearest hit of each ray; of two at the same distance (a shared edge), either
        np.minimum.at(nearest, ray, t)
        nearest_hit = t <= nearest[ray]
        self.hit[ray[nearest_hit]] = self.tracer._order[slot[nearest_hit]]


def _batches(total: np.ndarray, limit: int):
    """(begin, end) index ranges over items with cumulative sizes ``total`` (non-decreasing,
    positive), each of at most ``limit`` in size unless one item alone is larger."""
    begin = 0
    while begin < len(total):
        base = total[begin - 1] if begin else 0
        end = max(begin + 1, int(np.searchsorted(total, base + limit, side="right")))
        yield begin, end
        begin = end
