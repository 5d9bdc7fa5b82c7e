"""Wavefront OBJ + MTL reading into a Scene: positions, triangles (polygons fanned), and per
material Kd as reflectance and Ke as emission. Everything else in the files is ignored."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..util.geometry import barycentric_grid
from .model import Scene

DEFAULT_REFLECTANCE = (0.8, 0.8, 0.8)  # Blender's default material base colour


def read_mtl(path: Path) -> dict[str, dict[str, tuple[float, float, float]]]:
    """{material: {"Kd": rgb, "Ke": rgb}} from an MTL file."""
    materials: dict[str, dict[str, tuple[float, float, float]]] = {}
    current = None
    for line in path.read_text().splitlines():
        fields = line.split("#", 1)[0].split()
        if not fields:
            continue
        if fields[0] == "newmtl":
            current = materials.setdefault(" ".join(fields[1:]), {})
        elif fields[0] in ("Kd", "Ke") and current is not None:
            current[fields[0]] = tuple(float(value) for value in fields[1:4])
    return materials


def read_obj(path: str | Path, max_reflectance: float = 0.999) -> tuple[Scene, list[str]]:
    """Scene of an OBJ file and its MTL libraries, and the material name of each Scene material
    id. Reflectance is clamped to ``max_reflectance`` (some published scenes use Kd = 1)."""
    path = Path(path)
    vertices: list[list[float]] = []
    triangles: list[tuple[int, int, int]] = []
    triangle_material: list[int] = []
    names: list[str] = []
    library: dict[str, dict[str, tuple[float, float, float]]] = {}
    material = -1
    for number, line in enumerate(path.read_text().splitlines(), 1):
        fields = line.split("#", 1)[0].split()
        if not fields:
            continue
        keyword = fields[0]
        if keyword == "v":
            vertices.append([float(value) for value in fields[1:4]])
        elif keyword == "f":
            corners = [_vertex_index(field, len(vertices), path, number) for field in fields[1:]]
            for k in range(1, len(corners) - 1):
                triangles.append((corners[0], corners[k], corners[k + 1]))
                triangle_material.append(material)
        elif keyword == "usemtl":
            name = " ".join(fields[1:])
            if name not in names:
                names.append(name)
            material = names.index(name)
        elif keyword == "mtllib":
            for library_name in fields[1:]:
                library.update(read_mtl(path.parent / library_name))
    if -1 in triangle_material:
        names.append("(none)")
        triangle_material = [len(names) - 1 if m == -1 else m for m in triangle_material]
    reflectance = np.array([library.get(name, {}).get("Kd", DEFAULT_REFLECTANCE) for name in names])
    emission = np.array([library.get(name, {}).get("Ke", (0.0, 0.0, 0.0)) for name in names])
    ids = np.array(triangle_material, dtype=np.int64)
    scene = Scene(
        np.array(vertices, dtype=np.float64),
        np.array(triangles, dtype=np.int64),
        np.minimum(reflectance, max_reflectance)[ids],
        emission[ids],
        material=ids,
    )
    return scene, names


def _vertex_index(field: str, count: int, path: Path, line: int) -> int:
    index = int(field.split("/")[0])
    resolved = index - 1 if index > 0 else count + index
    if not 0 <= resolved < count:
        raise ValueError(f"{path}:{line}: face refers to vertex {index}, but only {count} are defined")
    return resolved


def subdivide(scene: Scene, divisions: int) -> Scene:
    """The scene with every triangle split regularly into divisions**2 triangles (what an artist
    does with Subdivide before baking vertex colours, so colours can show shadows)."""
    weights, cells = barycentric_grid(divisions)
    corners = scene.vertices[scene.triangles]
    points = (weights @ corners).reshape(-1, 3)
    offsets = (np.arange(len(corners)) * len(weights))[:, None, None]
    triangles = (cells[None] + offsets).reshape(-1, 3)
    repeat = len(cells)
    return Scene(
        points,
        triangles,
        np.repeat(scene.reflectance, repeat, axis=0),
        np.repeat(scene.emission, repeat, axis=0),
        material=np.repeat(scene.material, repeat),
        two_sided=np.repeat(scene.two_sided, repeat),
    )
