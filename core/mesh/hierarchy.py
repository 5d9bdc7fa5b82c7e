"""The hierarchy over a discretisation's patches for hierarchical radiosity: a binary tree whose
leaves are the patches, whose first levels above them are face clusters (the patches of one
panel's side: flat), and whose upper levels are volume clusters of nearby panels.

The tree is a radix tree over sorted keys (Karras 2012, "Maximizing parallelism in the
construction of BVHs, octrees, and k-d trees"): the panel sides are ranked by the Morton code of
their centroids, each patch keyed by its side's rank, then its own centroid's Morton code, and
every range of keys is split where the highest bit in which its first and last keys differ
changes. A side's patches share the key's high bits, so they form a subtree of their own. The
tree is built top-down, one depth at a time for every node of that depth; each node keeps what the
link oracle and the solver read (Smits, Arvo and Greenberg 1994; Sillion 1995): area, vector area
(sum of area x normal), bounding sphere, area-weighted emission and reflectance, and whether it is
flat.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .discretize import Discretization

# A node is flat (one plane, one side) when its vector area is at least this share of its area.
FLAT = 1 - 1e-6
MORTON_BITS = 10  # per axis


@dataclass(frozen=True)
class Hierarchy:
    """H nodes: the P leaves first (node i is the patch ``patch[i]``), then the internal nodes
    from the root (node P) down; arrays per node unless noted.

    patch : (P,) int, the patch of each leaf.
    left, right : (H,) int, children (-1 at leaves).
    parent : (H,) int (-1 at the root). depth : (H,) int (0 at the root).
    first, last : (H,) int, the range of leaves (positions 0..P-1) below each node.
    area : (H,). vector_area : (H, 3), sum of area x unit normal.
    center, radius : (H, 3), (H,) bounding sphere (of the node's bounding box).
    centroid : (H, 3) the area-weighted centroid of its patches (on their plane where flat).
    emission, reflectance : (H, C), area-weighted means.
    flat : (H,) bool, every patch below in one plane and facing one way.
    """

    patch: np.ndarray
    left: np.ndarray
    right: np.ndarray
    parent: np.ndarray
    depth: np.ndarray
    first: np.ndarray
    last: np.ndarray
    area: np.ndarray
    vector_area: np.ndarray
    center: np.ndarray
    radius: np.ndarray
    centroid: np.ndarray
    emission: np.ndarray
    reflectance: np.ndarray
    flat: np.ndarray
    root: int

    @property
    def leaf_count(self) -> int:
        return len(self.patch)

    @property
    def node_count(self) -> int:
        return len(self.left)

    def normal(self, nodes: np.ndarray) -> np.ndarray:
        """(k, 3) unit mean normals of ``nodes`` (the direction of their vector area)."""
        vector = self.vector_area[nodes]
        length = np.linalg.norm(vector, axis=1, keepdims=True)
        return np.divide(vector, length, out=np.zeros_like(vector), where=length > 0)

    def by_depth(self) -> list[np.ndarray]:
        """The internal nodes of each depth, the root's first."""
        return _internal_by_depth(self.left, self.depth)


def morton_codes(points: np.ndarray, low: np.ndarray, size: float) -> np.ndarray:
    """(n,) int64 Morton codes (MORTON_BITS per axis, interleaved) of points (n, 3) in the cube
    of side ``size`` from ``low``."""
    cells = (1 << MORTON_BITS) - 1
    quantised = np.clip(((points - low) / max(size, np.finfo(float).tiny) * cells).astype(np.int64), 0, cells)
    code = np.zeros(len(points), dtype=np.int64)
    for bit in range(MORTON_BITS):
        for axis in range(3):
            code |= ((quantised[:, axis] >> bit) & 1) << (3 * bit + 2 - axis)
    return code


def build(mesh: Discretization) -> Hierarchy:
    """The hierarchy over ``mesh``'s patches (see the module docstring)."""
    corners = mesh.patch_corners
    count = len(corners)
    low = corners.reshape(-1, 3).min(axis=0)
    size = float((corners.reshape(-1, 3).max(axis=0) - low).max())
    # a panel side: its panel, front or back
    side = mesh.patch_triangle * 2 + (np.arange(count) >= mesh.front_patch_count)
    sides, side_of = np.unique(side, return_inverse=True)
    side_area = np.bincount(side_of, mesh.patch_areas, len(sides))
    side_center = np.stack([np.bincount(side_of, mesh.patch_areas * mesh.patch_centroids[:, k], len(sides))
                            for k in range(3)], axis=1) / np.maximum(side_area, np.finfo(float).tiny)[:, None]
    side_rank = np.empty(len(sides), dtype=np.int64)
    side_rank[np.lexsort((np.arange(len(sides)), morton_codes(side_center, low, size)))] = np.arange(len(sides))
    key = (side_rank[side_of] << (3 * MORTON_BITS)) | morton_codes(mesh.patch_centroids, low, size)
    order = np.lexsort((np.arange(count), key))
    key = key[order]
    left, right, first, last, depth = _radix_tree(key)
    return _with_properties(mesh, order, left, right, first, last, depth)


def _radix_tree(key: np.ndarray):
    """Children, leaf ranges and depths of the radix tree over sorted ``key`` (n,): leaves are
    nodes 0..n-1 (positions), internal nodes n.. in the order made, top-down."""
    count = len(key)
    left, right = [np.full(count, -1)], [np.full(count, -1)]
    first, last = [np.arange(count)], [np.arange(count)]
    depth = [np.zeros(count, dtype=np.int64)]
    if count == 1:
        return (*(np.concatenate(part) for part in (left, right, first, last)), depth[0])
    begin, end, made = np.array([0]), np.array([count - 1]), count
    level = 0
    leaf_depth = np.zeros(count, dtype=np.int64)
    while len(begin):
        made += len(begin)
        differ = key[begin] ^ key[end]
        split = (begin + end) // 2  # equal keys: halve
        varied = np.flatnonzero(differ > 0)
        if len(varied):
            bit = np.floor(np.log2(differ[varied].astype(np.float64))).astype(np.int64)
            # float64's log2 can round up next to a power of two: keep the highest set bit
            bit -= (differ[varied] >> bit) == 0
            boundary = ((key[begin[varied]] >> bit) + 1) << bit
            split[varied] = np.searchsorted(key, boundary, side="left") - 1
        split = np.clip(split, begin, end - 1)
        children = []
        for low_end, high_end in ((begin, split), (split + 1, end)):
            single = low_end == high_end
            child = np.where(single, low_end, -1)
            leaf_depth[low_end[single]] = level + 1
            children.append((child, low_end[~single], high_end[~single], np.flatnonzero(~single)))
        # internal children are numbered in the next round, in this order: left ones, then right
        next_begin = np.concatenate([children[0][1], children[1][1]])
        next_end = np.concatenate([children[0][2], children[1][2]])
        next_ids = made + np.arange(len(next_begin))
        for (child, _, _, internal), offset in zip(children, (0, len(children[0][3]))):
            child[internal] = next_ids[offset: offset + len(internal)]
        left.append(children[0][0])
        right.append(children[1][0])
        first.append(begin)
        last.append(end)
        depth.append(np.full(len(begin), level))
        begin, end, level = next_begin, next_end, level + 1
    depth[0] = leaf_depth
    return tuple(np.concatenate(part) for part in (left, right, first, last, depth))


def _with_properties(mesh: Discretization, order, left, right, first, last, depth) -> Hierarchy:
    """The Hierarchy of the tree, its nodes' properties summed up from the leaves."""
    count, total = len(order), len(left)
    corners = mesh.patch_corners[order]
    area = np.zeros(total)
    vector_area = np.zeros((total, 3))
    low, high = np.zeros((total, 3)), np.zeros((total, 3))
    channels = mesh.patch_emission.shape[1]
    emitted, reflected = np.zeros((total, channels)), np.zeros((total, channels))
    moment = np.zeros((total, 3))
    area[:count] = mesh.patch_areas[order]
    vector_area[:count] = area[:count, None] * mesh.patch_normals[order]
    low[:count], high[:count] = corners.min(axis=1), corners.max(axis=1)
    emitted[:count] = area[:count, None] * mesh.patch_emission[order]
    reflected[:count] = area[:count, None] * mesh.patch_reflectance[order]
    moment[:count] = area[:count, None] * mesh.patch_centroids[order]
    parent = np.full(total, -1)
    internal = np.flatnonzero(left >= 0)
    parent[left[internal]] = internal
    parent[right[internal]] = internal
    for nodes in reversed(_internal_by_depth(left, depth)):
        a, b = left[nodes], right[nodes]
        area[nodes] = area[a] + area[b]
        vector_area[nodes] = vector_area[a] + vector_area[b]
        low[nodes], high[nodes] = np.minimum(low[a], low[b]), np.maximum(high[a], high[b])
        emitted[nodes], reflected[nodes] = emitted[a] + emitted[b], reflected[a] + reflected[b]
        moment[nodes] = moment[a] + moment[b]
    safe = np.maximum(area, np.finfo(float).tiny)[:, None]
    flat = np.linalg.norm(vector_area, axis=1) >= FLAT * area
    root = count if total > 1 else 0
    return Hierarchy(order, left, right, parent, depth, first, last, area, vector_area, (low + high) / 2,
                     np.linalg.norm(high - low, axis=1) / 2, moment / safe, emitted / safe, reflected / safe, flat,
                     root)


def _internal_by_depth(left: np.ndarray, depth: np.ndarray) -> list[np.ndarray]:
    """The internal nodes (``left`` >= 0) of each depth, the root's first."""
    internal = np.flatnonzero(left >= 0)
    order = internal[np.argsort(depth[internal], kind="stable")]
    bounds = np.searchsorted(depth[order], np.arange(depth.max() + 2))
    return [order[bounds[d]:bounds[d + 1]] for d in range(len(bounds) - 1)]
