"""rows.labels against np.unique's labelling of equal rows."""

import numpy as np
import pytest

from core.util import rows


def same_partition(labels: np.ndarray, expected: np.ndarray) -> bool:
    """Whether two labellings group the same rows together."""
    pairs = np.unique(np.stack([labels, expected], axis=1), axis=0)
    return len(pairs) == len(np.unique(labels)) == len(np.unique(expected))


def test_labels_group_exactly_the_equal_rows():
    """Float rows with many repeats (small integers, whose float64 words end in zero bits: a
    naive multiply-and-add hash would collide on them), signed zeros alike, and integer rows."""
    rng = np.random.default_rng(3)
    values = rng.integers(0, 4, (20_000, 5)).astype(float)
    values[::7, 2] = -0.0 * values[::7, 2]  # -0.0 where it was 0.0
    expected = np.unique(values, axis=0, return_inverse=True)[1].reshape(-1)
    assert same_partition(rows.labels(values), expected)
    assert len(np.unique(expected)) == 4**5  # every combination occurs: the case is not trivial
    integers = rng.integers(-5, 5, (5_000, 3))
    assert same_partition(rows.labels(integers), np.unique(integers, axis=0, return_inverse=True)[1].reshape(-1))


def test_a_hash_collision_falls_back_to_the_exact_labels(monkeypatch):
    """With every row hashed alike (multipliers and mixing forced to zero), the labels are still
    exact."""
    monkeypatch.setattr(rows, "_mixed", lambda words: np.zeros_like(words))
    values = np.array([[1.0, 2.0], [1.0, 2.0], [2.0, 1.0], [0.5, 0.5]])
    np.testing.assert_array_equal(rows.labels(values)[[0, 2, 3]] != rows.labels(values)[[1, 3, 0]], [False, True, True])
    assert same_partition(rows.labels(values), np.array([0, 0, 1, 2]))


def test_bad_shapes_are_refused_and_empty_input_is_empty():
    with pytest.raises(ValueError, match="rows must be"):
        rows.labels(np.zeros(5))
    assert rows.labels(np.zeros((0, 3))).shape == (0,)
