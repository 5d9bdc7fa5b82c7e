"""Bake the sample Cornell box and draw it from the published camera, Gouraud-shaded from the
baked corner colours, into docs/cornell_box.png (the README's picture).

Run from the repository root: ``.venv/bin/python bench/picture.py``.
"""

from __future__ import annotations

import struct
import sys
import zlib
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))

from core import bake  # noqa: E402
from core.scene.objfile import read_obj, subdivide  # noqa: E402
from core.scene.plyfile import linear_to_srgb_bytes  # noqa: E402

CAMERA = np.array([278.0, 273.0, -800.0])  # Cornell's data: looking along +z, y up
FOCAL = 35.0 / 12.5  # focal length over half the 25 mm film
SIZE = 384
EXPOSURE = 1.6  # scene-linear radiosity times this, then sRGB


def project(points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Pixel coordinates (n, 2) and depths (n,) of world points; +x is to the camera's left."""
    relative = points - CAMERA
    depth = relative[:, 2]
    x = -relative[:, 0] / depth * FOCAL
    y = relative[:, 1] / depth * FOCAL
    return np.stack([(x + 1) * SIZE / 2, (1 - y) * SIZE / 2], axis=1), depth


def render(corners: np.ndarray, colors: np.ndarray) -> np.ndarray:
    """(SIZE, SIZE, 3) image: each triangle rasterised with a depth buffer and perspective-correct
    interpolation of its corner colours."""
    image = np.zeros((SIZE, SIZE, 3))
    nearest = np.full((SIZE, SIZE), np.inf)
    screen, depth = project(corners.reshape(-1, 3))
    screen, depth = screen.reshape(-1, 3, 2), depth.reshape(-1, 3)
    for triangle, z, color in zip(screen, depth, colors):
        low = np.maximum(np.floor(triangle.min(axis=0)).astype(int), 0)
        high = np.minimum(np.ceil(triangle.max(axis=0)).astype(int), SIZE - 1)
        if (high < low).any():
            continue
        xs, ys = np.meshgrid(np.arange(low[0], high[0] + 1) + 0.5, np.arange(low[1], high[1] + 1) + 0.5)
        a, b, c = triangle
        area = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
        if area == 0:
            continue
        w1 = ((xs - a[0]) * (c[1] - a[1]) - (ys - a[1]) * (c[0] - a[0])) / area
        w2 = ((b[0] - a[0]) * (ys - a[1]) - (b[1] - a[1]) * (xs - a[0])) / area
        w0 = 1 - w1 - w2
        inside = (w0 >= 0) & (w1 >= 0) & (w2 >= 0)
        weights = np.stack([w0, w1, w2], axis=-1)[inside] / z  # perspective-correct: over depth
        pixel_depth = 1 / weights.sum(axis=1)
        rows, columns = (ys[inside] - 0.5).astype(int), (xs[inside] - 0.5).astype(int)
        closer = pixel_depth < nearest[rows, columns]
        rows, columns = rows[closer], columns[closer]
        nearest[rows, columns] = pixel_depth[closer]
        image[rows, columns] = (weights[closer] * pixel_depth[closer, None]) @ color
    return image


def write_png(path: Path, pixels: np.ndarray) -> None:
    """8-bit RGB PNG (zlib-compressed scanlines, filter 0)."""
    height, width, _ = pixels.shape
    raw = b"".join(b"\x00" + pixels[row].tobytes() for row in range(height))

    def chunk(kind: bytes, data: bytes) -> bytes:
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)

    header = struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0)
    path.write_bytes(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header) + chunk(b"IDAT", zlib.compress(raw, 9)) + chunk(b"IEND", b""))


def main() -> None:
    scene, _ = read_obj(REPO / "sample_blends" / "cornell_box.obj")
    scene = subdivide(scene, 8)
    result = bake(scene)
    stats = result.stats
    print(f"baked {stats['triangles']} triangles in {stats['seconds']['total']:.2f} s")
    image = render(scene.vertices[scene.triangles], result.corner_colors)
    output = REPO / "docs" / "cornell_box.png"
    write_png(output, linear_to_srgb_bytes(image * EXPOSURE))
    print(f"wrote {output}")


if __name__ == "__main__":
    main()
