"""rows.labels and rows.sorted_labels against np.unique's labelling of equal rows."""

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


@pytest.mark.parametrize("case", ["small integers", "signed floats", "wide integers", "full int64", "two wide columns",
                                  "booleans",
                                  "one column", "many columns", "empty"])
def test_sorted_labels_are_np_unique_s(case):
    """The distinct rows and the labels, exactly as np.unique(axis=0) gives them: integers folded
    into one key (wide ones ranked before the key would overflow), floats ranked (signed zeros
    alike), and the degenerate shapes."""
    rng = np.random.default_rng(7)
    values = {"small integers": rng.integers(-5, 5, (3_000, 3)),
              "signed floats": rng.integers(0, 3, (3_000, 4)) * np.where(rng.random((3_000, 4)) < 0.5, -1.0, 1.0),
              "wide integers": rng.integers(0, 10**9, (3_000, 3)) // 1000 * 1000,
              "full int64": rng.integers(-2**63, 2**63 - 1, (500, 2), dtype=np.int64),
              "two wide columns": rng.integers(0, 2**61, (500, 2), dtype=np.int64),
              "booleans": rng.random((300, 3)) < 0.5,
              "one column": rng.random((100, 1)).round(1),
              "many columns": rng.integers(0, 2, (200, 70)),
              "empty": np.zeros((0, 3))}[case]
    distinct, labels = rows.sorted_labels(values)
    expected_distinct, expected_labels = np.unique(values, axis=0, return_inverse=True)
    np.testing.assert_array_equal(distinct, expected_distinct)
    np.testing.assert_array_equal(labels, expected_labels.reshape(-1))


def test_bad_shapes_are_refused_and_empty_input_is_empty():
    with pytest.raises(ValueError, match="rows must be"):
        rows.labels(np.zeros(5))
    with pytest.raises(ValueError, match="rows must be"):
        rows.sorted_labels(np.zeros(5))
    assert rows.labels(np.zeros((0, 3))).shape == (0,)
