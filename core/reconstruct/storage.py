"""What a colour attribute stores of the baked colours: exposure and a tone curve for 8-bit
colours, and a colour per vertex as the mean of its corners'."""

from __future__ import annotations

import numpy as np

# The soft tone curve's white: the value it maps to 1.
SOFT_WHITE = 4.0
TONES = ("CLIP", "SOFT")


def exposed(colours: np.ndarray, exposure: float, tone: str | None) -> np.ndarray:
    """``colours`` (..., 3) times 2^``exposure``; with a ``tone`` (for 8-bit storage) fitted into
    [0, 1]: CLIP clips, SOFT applies Reinhard's extended curve x (1 + x / w^2) / (1 + x) with white
    w = SOFT_WHITE (Reinhard et al. 2002, eq. 4), then clips. ``tone`` None keeps any value."""
    values = np.asarray(colours, dtype=np.float64) * 2.0 ** exposure
    if tone is None:
        return values
    if tone not in TONES:
        raise ValueError(f"tone must be one of {TONES}, got {tone!r}")
    if tone == "SOFT":
        values = np.maximum(values, 0.0)
        values = values * (1.0 + values / SOFT_WHITE ** 2) / (1.0 + values)
    return np.clip(values, 0.0, 1.0)


def vertex_means(corner_values: np.ndarray, corner_vertex: np.ndarray, vertex_count: int) -> np.ndarray:
    """(V, C) mean of the values (L, C) of the corners at each vertex (``corner_vertex`` (L,));
    zero at a vertex no corner uses."""
    sums = np.zeros((vertex_count, corner_values.shape[1]))
    np.add.at(sums, corner_vertex, corner_values)
    counts = np.bincount(corner_vertex, minlength=vertex_count)
    return sums / np.maximum(counts, 1)[:, None]
