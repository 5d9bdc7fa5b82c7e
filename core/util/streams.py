"""The random streams of a bake: one per use, so that no two uses draw the same numbers.

A stream is ``np.random.default_rng([seed, *indices, tag])``: the bake's seed, the indices that
tell one block (or round, or look) of a use from another, and last the use's own nonzero ``tag``.
NumPy's ``SeedSequence`` takes lists that differ only by trailing zeros as one ([s, 4], [s, 4, 0]
and [s, 4, 0, 0] draw the same numbers), so a key that could end in an index could meet another
use's; ending in a nonzero tag of its own, two keys of different uses differ in their last place
(or, of different lengths, where the longer has its tag and the shorter nothing), and two of one
use differ where their indices do (docs/notes/experiments.md, "Random streams that coincide").
"""

from __future__ import annotations

import numpy as np

# One tag per use; never reuse one, and never 0.
PARTICLE_OFFSET = 1  # the systematic sampling of the particles' sources (montecarlo.trace_paths)
PARTICLE_BLOCK = 2  # a block of particles: where they start, where they go
GATHER_RAYS = 3  # a block of a final gather's rays (gather._ray_points), per gather stream
PATCH_GATHER_POINTS = 4  # the points of the patches that gather their own light (gather.patch_hits)
POOL_PROBES = 5  # the probes that find crevices between a vertex's nodes (gather.node_pools)
SKY_DIRECTIONS = 6  # the sky's directions at a block of points, per look (transport.direct)
LIGHT_SAMPLES = 7  # a soft light's one sample at each paired point of a block (patches', bounces': transport.direct)
PATCH_LIGHT_POINTS = 8  # the stratified points where a block of patches reads the lights
SHOT_SAMPLES = 9  # the stratified samples of each patch a shot's rays aim at (transport.raycast)
CLOSE_DIRECTIONS = 10  # the directions into close emitters' solid angles (transport.raycast)
EMITTER_SAMPLES = 11  # the samples of emitters read finely (transport.raycast)
MEAN_POINTS = 12  # the points of patches whose light near a lamp is a mean (transport.formfactors)
LINK_RAYS = 13  # a block of the hierarchical links' visibility rays, per round (solve.hierarchical)
CLOSURE_RAYS = 14  # the hierarchical solver's test of a closed scene (solve.hierarchical)
POINT_TURNS = 15  # a soft light's samples at a point, from the point itself (``point_uniforms``; transport.direct)
CLOSE_MIXED_DIRECTIONS = 16  # the directions into close emitters where the first ones disagree (transport.raycast)
EMITTER_MIXED_SAMPLES = 17  # the samples of emitters read finely where the first ones disagree (transport.raycast)
POINT_MIXED_TURNS = 18  # a soft light's samples at a point where its first ones disagree (transport.direct)
EMITTER_SECOND_SAMPLES = 19  # the second set of samples of emitters read finely (transport.raycast)
CLOSE_SECOND_DIRECTIONS = 20  # the second set of directions into close emitters (transport.raycast)
POINT_SECOND_TURNS = 21  # a soft light's second set of samples at a point (transport.direct)

# The parts of a bake that read lights and sky, an index of the keys above.
NODES, PATCHES, BOUNCES = 1, 2, 3


def generator(seed: int, tag: int, *indices: int) -> np.random.Generator:
    """The stream of use ``tag`` at ``indices`` for the bake's ``seed``."""
    return np.random.default_rng([seed, *indices, tag])


_MASK = (1 << 64) - 1
_GOLDEN = 0x9E3779B97F4A7C15


def point_uniforms(seed: int, tag: int, index: int, points: np.ndarray, count: int) -> np.ndarray:
    """(k, count) numbers uniform in [0, 1) for each of ``points`` (k, 3), made from the bits of its
    coordinates, the bake's ``seed``, the use's ``tag`` and ``index`` by splitmix64 (Steele, Lea
    and Flood 2014): the same wherever, and with whatever other points, a point is asked, so that a
    reading kept at a point equals one made afresh there (``transport.arriving``). -0.0 is taken
    as 0.0."""
    bits = np.ascontiguousarray(np.asarray(points, dtype=np.float64) + 0.0).view(np.uint64)  # (k, 3)
    state = np.full(len(points), _mixed(((seed * _GOLDEN) ^ (tag << 32) ^ index) & _MASK), dtype=np.uint64)
    for column in bits.T:
        state = _mix(state ^ column)
    numbers = [_mix(state + np.uint64(((draw + 1) * _GOLDEN) & _MASK)) for draw in range(count)]
    return (np.stack(numbers, axis=1) >> np.uint64(11)).astype(np.float64) * 2.0 ** -53


def _mix(state: np.ndarray) -> np.ndarray:
    """splitmix64's finaliser on (n,) uint64, wrapping as it does."""
    state = (state ^ (state >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)
    state = (state ^ (state >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)
    return state ^ (state >> np.uint64(31))


def _mixed(value: int) -> int:
    """``_mix`` of one integer."""
    return int(_mix(np.array([value], dtype=np.uint64))[0])
