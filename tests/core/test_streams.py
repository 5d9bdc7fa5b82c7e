"""The bake's random streams (core/util/streams.py): no two uses, and no two blocks of one use,
draw the same numbers, where NumPy's own lists of numbers would."""

from __future__ import annotations

import itertools

import numpy as np

from core.util import streams

# Every use's tag, one entry per name (a list, so that two names of one value show as a repeat).
TAGS = [value for name, value in vars(streams).items()
        if name.isupper() and not name.startswith("_") and name not in ("NODES", "PATCHES", "BOUNCES")]
INDICES = [(), (0,), (0, 0), (4,), (4, 0), (0, 4), (2, 0, 0), (1, 1024), (1, 1024, 0), (3, 2, 0, 1)]


def test_keys_that_differ_only_by_trailing_zeros_draw_the_same_numbers_in_numpy():
    """The hazard the module exists for: NumPy's SeedSequence pads entropy with zeros."""
    first = [np.random.default_rng(key).random(4) for key in ([7, 4], [7, 4, 0], [7, 4, 0, 0])]
    assert all(np.array_equal(first[0], other) for other in first[1:])


def test_every_use_and_block_draws_numbers_of_its_own():
    assert len(TAGS) == len(set(TAGS)) and 0 not in TAGS
    draws = {}
    for tag, indices in itertools.product(TAGS, INDICES):
        draws[tag, indices] = tuple(streams.generator(7, tag, *indices).random(4))
    assert len(set(draws.values())) == len(draws)
    # and another seed draws other numbers again
    assert tuple(streams.generator(8, TAGS[0]).random(4)) not in set(draws.values())
