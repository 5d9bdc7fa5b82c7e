"""Labels of equal rows, without ``np.unique(rows, axis=0)``: it sorts whole rows as records,
seconds for a million rows, holding the GIL all the while (no progress can be reported meanwhile).

``sorted_labels`` gives exactly its result, column by column, each step a sort of one int64 key.
``labels`` gives the same labels up to their order, several times faster again on a million rows.

Each row is hashed to one 64-bit word (each of its 64-bit words mixed by the SplitMix64
finaliser, Steele, Lea and Flood 2014, which spreads a float's high bits into the low ones,
then times a fixed odd multiplier per column, summed with wrap-around), the hashes are labelled by
``np.unique``, and every row is then checked against its label's first row; a collision (two
different rows sharing a hash) falls back to ``sorted_labels``, so the result never depends on luck.
"""

from __future__ import annotations

import numpy as np

_FOLDED = 1 << 62  # the largest key ``sorted_labels`` folds columns into
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
        result = sorted_labels(rows)[1]
    return result


def sorted_labels(rows: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``np.unique(rows, axis=0, return_inverse=True)`` of rows (n, m) of numbers (0.0 and -0.0
    alike): the distinct rows (k, m) in lexicographic order and (n,) int64 the label of each.
    The columns are folded into one int64 key, key * span + value (integers from their least,
    others by rank), the key ranked again whenever the next column would overflow it."""
    rows = np.asarray(rows)
    if rows.ndim != 2:
        raise ValueError(f"rows must be (n, m), got shape {rows.shape}")
    key, size = np.zeros(len(rows), dtype=np.int64), 1  # the key so far, in [0, size)
    for column in rows.T:
        if len(column) == 0:
            break
        low, high = (int(column.min()), int(column.max())) if column.dtype.kind in "ib" else (0, _FOLDED)
        if size * (high - low + 1) > _FOLDED:
            _, key = np.unique(key, return_inverse=True)
            key, size = key.reshape(-1), int(key.max()) + 1
        if size * (high - low + 1) <= _FOLDED:
            values, span = column.astype(np.int64) - low, high - low + 1
        else:  # floats, and integers too wide to fold
            ranked, values = np.unique(column + 0 if column.dtype.kind == "f" else column, return_inverse=True)
            values, span = values.reshape(-1), len(ranked)
        key, size = key * span + values, size * span
    _, label = np.unique(key, return_inverse=True)
    label = label.reshape(-1)
    distinct = np.empty((int(label.max()) + 1 if len(label) else 0, rows.shape[1]), dtype=rows.dtype)
    distinct[label] = rows
    return distinct, label


def _mixed(words: np.ndarray) -> np.ndarray:
    """SplitMix64's finaliser of each uint64 word (wrapping arithmetic)."""
    z = words ^ (words >> np.uint64(30))
    z *= np.uint64(0xBF58476D1CE4E5B9)
    z ^= z >> np.uint64(27)
    z *= np.uint64(0x94D049BB133111EB)
    return z ^ (z >> np.uint64(31))
