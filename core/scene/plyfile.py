"""Write baked corner colours to a PLY file any mesh viewer shows (one vertex per corner)."""

from __future__ import annotations

from pathlib import Path

import numpy as np


def linear_to_srgb_bytes(linear: np.ndarray) -> np.ndarray:
    """uint8 sRGB of scene-linear values, clipped to [0, 1] (IEC 61966-2-1 transfer function)."""
    value = np.clip(linear, 0.0, 1.0)
    srgb = np.where(value <= 0.0031308, 12.92 * value, 1.055 * value ** (1 / 2.4) - 0.055)
    return np.round(srgb * 255).astype(np.uint8)


def write_ply(path: str | Path, corners: np.ndarray, corner_colors: np.ndarray, exposure: float = 1.0) -> None:
    """Binary PLY of triangles (T, 3, 3) with per-corner colours (T, 3, 3), scene-linear values
    times ``exposure`` stored as sRGB bytes."""
    count = len(corners)
    vertex = np.zeros(count * 3, dtype=[("x", "<f4"), ("y", "<f4"), ("z", "<f4"),
                                        ("red", "u1"), ("green", "u1"), ("blue", "u1")])
    points = corners.reshape(-1, 3)
    colors = linear_to_srgb_bytes(corner_colors.reshape(-1, 3) * exposure)
    for axis, name in enumerate("xyz"):
        vertex[name] = points[:, axis]
    for channel, name in enumerate(("red", "green", "blue")):
        vertex[name] = colors[:, channel]
    faces = np.zeros(count, dtype=[("n", "u1"), ("v", "<i4", (3,))])
    faces["n"] = 3
    faces["v"] = np.arange(count * 3).reshape(-1, 3)
    header = (
        "ply\nformat binary_little_endian 1.0\n"
        f"element vertex {count * 3}\n"
        "property float x\nproperty float y\nproperty float z\n"
        "property uchar red\nproperty uchar green\nproperty uchar blue\n"
        f"element face {count}\nproperty list uchar int vertex_indices\nend_header\n"
    )
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    with path.open("wb") as stream:
        stream.write(header.encode("ascii"))
        stream.write(vertex.tobytes())
        stream.write(faces.tobytes())
