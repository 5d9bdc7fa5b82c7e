"""Transport along the links of hierarchical radiosity: how much of a source node's radiosity
reaches a receiver (a node of the hierarchy, or a point where a colour is read), and how much of
it is seen.

A link from source s to receiver r adds K B_s to the light G (irradiance / pi) arriving at r.
Between two patches, or a point and a patch, K is the exact point-to-polygon form factor from
r's receiving point times a ray-cast visibility (``raycast``). Otherwise s is seen from r's
centre as a disc of its projected area towards r, bounded as in the isotropic cluster model of
Sillion (1995) but keeping what the vector area V = sum A n says of the orientation:

    A_proj(u) = max(0, V . u) + (A - |V|) / 4,   K = A_proj cos_r / (pi d^2 + A_proj)

(the disc's exact on-axis form factor; a flat node is exact along its normal, a closed convex
cluster has |V| = 0 and A / 4, a sphere's exact mean projected area). A receiver that is not flat
takes K without its cosine, with the direction the light comes from: its patches each take
their own cosine when it is pushed down to them (``solve.hierarchical``). Visibility of such a
link is the share of VISIBILITY_RAYS rays between area-weighted random points of the two nodes'
patches that are not blocked (of those whose both ends face each other).
"""

from __future__ import annotations

import numpy as np

from ..mesh.hierarchy import Hierarchy
from ..rays.visibility import RAY_EPSILON, Visibility
from ..util.geometry import cosine_directions, uniform_points

VISIBILITY_RAYS = 4
# Rays from a receiver that all meet a surface if it is enclosed (``enclosed``).
CLOSURE_RAYS = 64


def projected_area(hierarchy: Hierarchy, nodes: np.ndarray, towards: np.ndarray) -> np.ndarray:
    """(k,) the area of ``nodes`` seen from unit directions ``towards`` (k, 3) (from the node to
    the viewer), by the bounded isotropic model of the module docstring."""
    vector = hierarchy.vector_area[nodes]
    coherent = np.einsum("kx,kx->k", vector, towards)
    return np.maximum(coherent, 0.0) + _isotropic(hierarchy, nodes)


def _isotropic(hierarchy: Hierarchy, nodes: np.ndarray) -> np.ndarray:
    """(k,) the isotropic part (A - |V|) / 4 of the projected area of ``nodes``, never below 0: in a
    flat node |V| = A, and rounding may leave it a hair above, which seen from the node's centre
    (a patch lying there) made K = A_proj / (pi d^2 + A_proj) a huge negative number on Sponza."""
    return np.maximum(hierarchy.area[nodes] - np.linalg.norm(hierarchy.vector_area[nodes], axis=1), 0.0) / 4


def cluster_coefficients(hierarchy: Hierarchy, centers: np.ndarray, normals: np.ndarray,
                         sources: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """K (k,) of links from node ``sources`` (k,) to receivers at ``centers`` (k, 3) facing
    ``normals`` (k, 3; zero for a receiver that is not flat: K then leaves out its cosine), and
    the unit directions (k, 3) the light arrives from."""
    offset = hierarchy.center[sources] - centers
    distance2 = np.einsum("kx,kx->k", offset, offset)
    direction = offset / np.sqrt(np.maximum(distance2, np.finfo(float).tiny))[:, None]
    seen = projected_area(hierarchy, sources, -direction)
    cosine = np.einsum("kx,kx->k", normals, direction)
    cosine = np.where(np.any(normals != 0, axis=1), np.maximum(cosine, 0.0), 1.0)
    return seen * cosine / np.maximum(np.pi * distance2 + seen, np.finfo(float).tiny), direction


def averaged_coefficients(hierarchy: Hierarchy, centers: np.ndarray, normals: np.ndarray, sources: np.ndarray,
                          starts: np.ndarray, ends: np.ndarray) -> np.ndarray:
    """K (k,) as ``cluster_coefficients``, the receiver's cosine and the source's projected area
    averaged over the directions from the points ``starts`` (k, n, 3) on the receiver to ``ends``
    (k, n, 3) on the source, not taken at the centres: for a node across the other's plane, of
    which the centres do not tell what part is in front."""
    offset = hierarchy.center[sources] - centers
    distance2 = np.einsum("kx,kx->k", offset, offset)
    rays = ends - starts
    rays /= np.maximum(np.linalg.norm(rays, axis=2, keepdims=True), np.finfo(float).tiny)
    vector = hierarchy.vector_area[sources]
    seen = np.maximum(-np.einsum("knx,kx->kn", rays, vector), 0.0) + _isotropic(hierarchy, sources)[:, None]
    cosine = np.where(np.any(normals != 0, axis=1)[:, None], np.maximum(np.einsum("knx,kx->kn", rays, normals), 0.0),
                      1.0)
    return (seen * cosine / np.maximum(np.pi * distance2[:, None] + seen, np.finfo(float).tiny)).mean(axis=1)


def sample_points(hierarchy: Hierarchy, mesh_corners: np.ndarray, mesh_normals: np.ndarray, nodes: np.ndarray,
                  count: int, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """``count`` random points per node (k, count, 3), uniform over the area of its patches, and
    the normals there (k, count, 3)."""
    cumulative = np.concatenate([[0.0], np.cumsum(hierarchy.area[: hierarchy.leaf_count])])
    low, high = cumulative[hierarchy.first[nodes]], cumulative[hierarchy.last[nodes] + 1]
    u = low[:, None] + rng.random((len(nodes), count)) * (high - low)[:, None]
    leaf = np.clip(np.searchsorted(cumulative, u, side="right") - 1, hierarchy.first[nodes][:, None],
                   hierarchy.last[nodes][:, None])
    patch = hierarchy.patch[leaf.reshape(-1)]
    points = uniform_points(mesh_corners[patch], rng.random((len(patch), 2)))
    return points.reshape(len(nodes), count, 3), mesh_normals[patch].reshape(len(nodes), count, 3)


def seen_share(visibility: Visibility, starts: np.ndarray, start_normals: np.ndarray, ends: np.ndarray,
               end_normals: np.ndarray) -> np.ndarray:
    """(k,) the share of the rays from points ``starts`` (k, n, 3) (facing ``start_normals``; a
    zero normal faces every way) to ``ends`` (k, n, 3) (facing ``end_normals``) that reach them,
    among those whose ends face each other; 1 where none do."""
    offset = ends - starts
    facing = (np.einsum("knx,knx->kn", offset, end_normals) < 0) & \
        ((np.einsum("knx,knx->kn", offset, start_normals) > 0) | ~np.any(start_normals != 0, axis=2))
    rows, rays = np.nonzero(facing)
    blocked = np.zeros(facing.shape, dtype=bool)
    if len(rows):
        lift = start_normals[rows, rays]
        begin = visibility.to_unit(starts[rows, rays]) + RAY_EPSILON * lift
        direction = (visibility.to_unit(ends[rows, rays]) - begin).astype(np.float32)
        length = np.maximum(np.linalg.norm(direction, axis=1), np.finfo(np.float32).tiny)
        blocked[rows, rays] = visibility.occluded_between_unit(begin, direction, 1 - RAY_EPSILON / length)
    counted = facing.sum(axis=1)
    return np.where(counted > 0, 1 - blocked.sum(axis=1) / np.maximum(counted, 1), 1.0)


def enclosed(visibility: Visibility, points: np.ndarray, normals: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """(k,) bool: whether every one of CLOSURE_RAYS cosine-distributed rays from each point (k, 3)
    facing ``normals`` (k, 3) meets a surface: the point is enclosed, so its form factors to
    everything sum to 1."""
    normal = np.repeat(normals, CLOSURE_RAYS, axis=0)
    directions = cosine_directions(normal, rng.random((len(normal), 2)))
    hit = visibility.nearest(np.repeat(points, CLOSURE_RAYS, axis=0), directions, normal)
    return (hit >= 0).reshape(-1, CLOSURE_RAYS).all(axis=1)
