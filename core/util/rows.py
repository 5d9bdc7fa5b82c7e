"""Labels of equal rows: ``np.unique(rows, axis=0, return_inverse=True)[1]`` up to the order of
the labels, several times faster on a million rows.

Each row is hashed to one 64-bit word (each of its 64-bit words mixed by the SplitMix64
finaliser, Steele, Lea and Flood 2014, which spreads a float's high bits into the low ones,
then times a fixed odd multiplier per column, summed with wrap-around), the hashes are labelled by ``np.unique``, and every row is then checked against
its label's first row; a collision (two different rows sharing a hash) falls back to the exact
``np.unique``, so the result never depends on luck. (np.unique sorts whole rows: a million rows
of a dozen numbers take seconds, where one sort of their hashes takes a fraction of that.)
"""

from __future__ import annotations

import numpy as np

_MULTIPLIERS = np.random.default_rng(20261202).integers(1, 1 << 62, 64, dtype=np.uint64) | np.uint64(1)


def labels(rows: np.ndarray) -> np.ndarray:
    """(n,) int64 labels 0 .. k - 1 of the rows (n, m) of numbers (at most 64 columns), equal
    exactly where the rows are equal (as numbers: 0.0 and -0.0 alike), in an arbitrary but
    fixed order."""
    rows = np.asarray(rows)
    if rows.ndim != 2 or rows.shape[1] > len(_MULTIPLIERS):
        raise ValueError(f"rows must be (n, m <= {len(_MULTIPLIERS)}), got shape {rows.shape}")
    if len(rows) == 0:
        return np.zeros(0, dtype=np.int64)
    if rows.dtype.kind == "f":
        words = np.ascontiguousarray(rows.astype(np.float64) + 0.0).view(np.uint64)  # + 0.0 turns -0.0 into 0.0
    else:
        words = np.ascontiguousarray(rows, dtype=np.int64).view(np.uint64)
    hashes = _mixed(words) @ _MULTIPLIERS[: words.shape[1]]
    _, first, result = np.unique(hashes, return_index=True, return_inverse=True)
    result = result.reshape(-1)
    if not (words == words[first[result]]).all():
        result = np.unique(words, axis=0, return_inverse=True)[1].reshape(-1)
    return result


def _mixed(words: np.ndarray) -> np.ndarray:
    """SplitMix64's finaliser of each uint64 word (wrapping arithmetic)."""
    z = words ^ (words >> np.uint64(30))
    z *= np.uint64(0xBF58476D1CE4E5B9)
    z ^= z >> np.uint64(27)
    z *= np.uint64(0x94D049BB133111EB)
    return z ^ (z >> np.uint64(31))
