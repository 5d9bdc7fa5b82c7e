"""Where a patch's light can land directly: the box around what rays from it reach.

A shot evaluates a form factor at every receiver facing the source, and in a scene of many rooms
most of those are behind walls, each costing its probe rays: the cost of shooting grows with the
square of the scene. Before a shot, REACH_RAYS rays leave the source from stratified points of it in
stratified cosine-distributed directions. The box around the source and the patches they hit (their
whole boxes; a ray that leaves the scene passes no receiver) holds every receiver the source sees
but those it sees only between its rays, and the shot evaluates the receivers in the box alone. A
ray that meets a surface that lets light through gives the source no box, and so does a source more
than OPEN_SHARE of whose rays leave the scene: in the open, the rays that meet a surface box in only
part of what it sees.

Each ray stands for its stratum of directions: the box holds, with the patches the rays hit, a
neighbourhood of where each lands, as wide as the strata are at that distance (SPREAD).

Where it leaks: a receiver seen only through a thin opening that all the rays miss, outside the
box of all they hit: in tests/core/test_reach.py a ceiling patch over a light panel, seeing the
walls' tops through the 2 cm between them, loses 0.6 % of its power; of a light panel's, a slit
4 mm high in the wall to the next room 0.13 % (all that went through it), one 0.2 m high 0.22 %
(5 % of what went through). The test's bound is 4 / REACH_RAYS, four rays' worth."""

from __future__ import annotations

import numpy as np

from ..rays.visibility import Visibility
from ..util.geometry import GOLDEN, cosine_directions
from .raycast import stratified_samples

REACH_RAYS = 256
# Each source's strata are shifted by the fractional parts of its index times these (the
# additive recurrence of Roberts' R4 sequence), so that they follow from its index alone.
_IRRATIONALS = np.array([0.8566748838545029, 0.7338918566271997, 0.6287067210378086, 0.5385972572236101])
PAIRING = 77  # prime to the number of strata (not a multiple of 7 or 11): a permutation of them
# Where a ray lands stands for SPREAD / sqrt(REACH_RAYS) radians of directions about it (a
# cosine-weighted stratum is about sqrt(pi / REACH_RAYS) across, more near the horizon). Wider
# boxes reach past the walls the rays hit: twice this evaluates twice the pairs beyond a wall in
# tests/core/test_reach.py, for about the same loss.
SPREAD = 1.0
# Boxes grow by this share of the scene's size: receivers lie on the surfaces the rays hit, to
# rounding.
MARGIN = 1e-6
# A source more than this share of whose rays leave the scene stands in the open: it gets no box.
# (A room's window lets a few out, and what lies beyond them holds no receiver.)
OPEN_SHARE = 0.25


def reach_boxes(corners: np.ndarray, normals: np.ndarray, names: np.ndarray, visibility: Visibility, seed: int,
                rays: int = REACH_RAYS) -> tuple[np.ndarray, np.ndarray]:
    """(k, 3) low and high corners of the box each source patch (corners (k, 3, 3), unit normals
    (k, 3)) lights directly, from ``rays`` (a perfect square) rays of its own; -inf and +inf for a
    source some of whose rays meet a surface that lets light through, or more than OPEN_SHARE of
    whose rays leave the scene (in the open, few rays hit what the source sees: two squares at a
    right angle lost 9 % of the floor's form factor to the wall). A source's rays follow from
    ``seed`` and its name in ``names`` (k,) int alone (not from the other sources asked about
    with it)."""
    count = len(corners)
    side = int(round(np.sqrt(rays)))
    lattice = (np.stack(np.meshgrid(np.arange(side), np.arange(side)), axis=-1).reshape(-1, 2) + 0.5) / side
    shift = (np.asarray(names, dtype=np.float64)[:, None] * _IRRATIONALS + seed * GOLDEN) % 1.0  # (k, 4)
    origins = stratified_samples(corners, rays, shift[:, None, :2]).reshape(-1, 3)
    # point i goes along direction stratum (PAIRING i + offset) mod rays: another one for each point
    pairing = (PAIRING * np.arange(rays) + (shift[:, :1] * rays).astype(np.int64)) % rays  # (k, rays)
    uv = (lattice[pairing] + shift[:, None, 2:]) % 1.0
    lift = np.repeat(normals, rays, axis=0)
    directions = cosine_directions(lift, uv.reshape(-1, 2))
    hit = visibility.nearest(origins, directions, lift)
    missed = hit < 0
    triangle = np.maximum(hit, 0)
    hit_corners = visibility.corners[triangle]  # (k rays, 3, 3)
    normal = visibility.triangle_normals[triangle]
    along = np.einsum("nx,nx->n", directions, normal)
    distance = np.divide(np.einsum("nx,nx->n", hit_corners[:, 0] - origins, normal), along,
                         out=np.zeros(len(hit)), where=along != 0)
    # each ray stands for its stratum of directions: around where it lands, as far as the
    # neighbouring strata's rays would land, SPREAD x the distance
    around = (SPREAD / np.sqrt(rays) * np.abs(distance))[:, None]
    landing = origins + distance[:, None] * directions
    low = np.minimum(hit_corners.min(axis=1), landing - around)
    high = np.maximum(hit_corners.max(axis=1), landing + around)
    low[missed], high[missed] = np.inf, -np.inf  # (the source gets no box: below)
    pad = MARGIN / visibility.scale
    low = np.minimum(low.reshape(count, rays, 3).min(axis=1), corners.min(axis=1)) - pad
    high = np.maximum(high.reshape(count, rays, 3).max(axis=1), corners.max(axis=1)) + pad
    through = (~visibility.opaque[triangle] & ~missed).reshape(count, rays).any(axis=1)
    through |= missed.reshape(count, rays).mean(axis=1) > OPEN_SHARE
    low[through], high[through] = -np.inf, np.inf
    return low, high
