"""Comparing corner colours of the Cornell box's bakes (bench/cycles.py, bench/cycles_headline.py):
corners stacked in one order, NRMSE, noise from two seeds, where surfaces meet; and the Markdown
helpers of the report."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from cycles_worker import SURFACES

LUMINANCE = np.array([0.2126, 0.7152, 0.0722])  # Rec. 709 weights: one number per surface
TOUCH = 1e-4  # m: a corner whose vertex is this close to another surface sits where two surfaces meet


@dataclass
class Corners:
    """Corner colours of the non-emitting surfaces, stacked in SURFACES order."""

    colours: np.ndarray  # (M, 3)
    weights: np.ndarray  # (M,) the corner's share of its polygon's area
    surface: np.ndarray  # (M,) index into SURFACES

    @classmethod
    def of(cls, result: dict) -> Corners:
        """The corners of a worker's result (its "objects")."""
        objects = result["objects"]
        return cls(
            np.concatenate([np.array(objects[name]["colours"], dtype=np.float64) for name in SURFACES]),
            np.concatenate([np.array(objects[name]["weights"], dtype=np.float64) for name in SURFACES]),
            np.concatenate([np.full(len(objects[name]["weights"]), k) for k, name in enumerate(SURFACES)]),
        )

    def surface_means(self) -> np.ndarray:
        """(S, 3) area-weighted mean colour of each surface."""
        return np.array([np.average(self.colours[self.surface == k], axis=0, weights=self.weights[self.surface == k])
                         for k in range(len(SURFACES))])


def touching(objects: dict) -> np.ndarray:
    """(M,) bool in SURFACES order: the corner's vertex lies within TOUCH of a triangle of another
    non-emitting mesh, i.e. where two surfaces meet (the room's edges, the blocks' bottom edges)."""
    parts = []
    for name in SURFACES:
        others = np.concatenate([np.array(objects[other]["triangles"]) for other in SURFACES if other != name])
        parts.append(_near_triangles(np.array(objects[name]["positions"]), others, TOUCH))
    return np.concatenate(parts)


def _near_triangles(points: np.ndarray, triangles: np.ndarray, distance: float) -> np.ndarray:
    """(n,) bool: points (n, 3) within ``distance`` of any of triangles (t, 3, 3) (of its plane, and
    of its inside or no further than ``distance`` outside its edges)."""
    a, b, c = triangles[:, 0], triangles[:, 1], triangles[:, 2]
    normal = np.cross(b - a, c - a)
    normal /= np.linalg.norm(normal, axis=1, keepdims=True)
    near = np.zeros(len(points), bool)
    for start in range(0, len(points), 128):
        p = points[start:start + 128, None, :]  # (k, 1, 3) against (t, 3)
        height = np.einsum("ktx,tx->kt", p - a, normal)
        foot = p - height[..., None] * normal
        hit = np.abs(height) <= distance
        for u, v in ((a, b), (b, c), (c, a)):  # signed distance of the foot inside each edge
            inside = np.einsum("ktx,tx->kt", np.cross(v - u, foot - u), normal)
            hit &= inside >= -distance * np.linalg.norm(v - u, axis=1)
        near[start:start + 128] = hit.any(axis=1)
    return near


def nrmse(values: np.ndarray, reference: np.ndarray) -> float:
    """RMS of the difference over the mean of the reference, over every element."""
    return float(np.sqrt(np.mean((values - reference) ** 2)) / np.mean(reference))


def without_noise(error: float, noise: float) -> float:
    """``error`` with ``noise`` subtracted in quadrature (0 when the noise explains it all)."""
    return math.sqrt(max(error**2 - noise**2, 0.0))


def seed_noise(first: np.ndarray, second: np.ndarray, scale: float) -> float:
    """One seed's noise relative to ``scale``, from two bakes that differ only in their seed:
    RMS(first - second) / sqrt(2) / scale (the mean of the two has 1/sqrt(2) of it)."""
    return float(np.sqrt(np.mean((first - second) ** 2) / 2) / scale)


# --------------------------------------------------------------------------------------------------
# Markdown
# --------------------------------------------------------------------------------------------------


def table(header: list[str], rows: list[list[str]]) -> str:
    """A Markdown table."""
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    return "\n".join(lines + ["| " + " | ".join(row) + " |" for row in rows])


def pct(value: float) -> str:
    """A fraction as a percentage."""
    return f"{100 * value:.2f} %"


def rgb(values, digits: int = 4) -> str:
    """R, G, B values."""
    return ", ".join(f"{v:.{digits}f}" for v in values)


