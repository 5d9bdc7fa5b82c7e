"""Every benchmark scene, by name: read from ../shared/scenes beside the repository (never copied
into it) or sample_blends/, or built from them into build/ (not committed: rebuilt in seconds,
and Sponza's licence is non-commercial).

- ``load(name)``, a core Scene: "cornell" (the Cornell box with a hole in its ceiling, split
  CORNELL_SPLIT x CORNELL_SPLIT), "sponza" (Dabrovic Sponza with its sky quad) and "breakfast"
  (the breakfast room under a uniform sky);
- ``blend(name)``, a .blend for the studies against Cycles: "cornell_box" (the sample file),
  "fine_mesh" (the same box with walls 40 x 40), "sponza" and "breakfast" (``load(name)`` in
  Blender, the breakfast room's sky its world);
- ``extracted(path)``: the core scene of a .blend as the add-on reads it, and where each triangle
  corner's colour is written.

The scenes with an exact answer (furnace, parallel squares, CIE room) are bench/exact.py's.
"""

from __future__ import annotations

from pathlib import Path
import dataclasses
from typing import NamedTuple

import numpy as np

from bench import in_blender
from bench.paths import BUILD, REPO, SCENES, shown
from bench.runner import value_in_fresh_process
from core import BakeSettings, Scene, read_obj
from core.scene import subdivide
from core.util.geometry import areas_and_normals

CORNELL_BOX = SCENES / "cornell_box" / "cornell_box_ceiling_hole.obj"
SPONZA = SCENES / "dabrovic_sponza" / "dabrovic_sponza.obj"
BREAKFAST = SCENES / "breakfast_room" / "breakfast_room.obj"
SAMPLE_BLEND = REPO / "sample_blends" / "cornell_box.blend"
BUILT = BUILD / "scenes"

CORNELL_SPLIT = 4  # each input triangle split into 4 x 4, so corner colours can show the blocks' shadows
FINE_MESH_CELL = 0.01375  # m: grid cells that split the sample box's 0.55 m walls 40 x 40
# Sponza's courtyard is open to the sky over x in (-10.8, 10.8), z in (-2.4, 2.4) (m) up to the roof at
# y = 15.65; no triangle reaches into this rectangle at y = 15.4, so the sky quad there touches nothing.
SKY_CORNERS = ((-10.5, 15.4, -2.3), (10.5, 15.4, -2.3), (10.5, 15.4, 2.3), (-10.5, 15.4, 2.3))
SKY_EMISSION = 5.0
SKY = "sky"  # the sky quad's object in Sponza's .blend
# The breakfast room has no emitters: its source is lit by an environment through its open windows.
BREAKFAST_SKY = 1.0

DESCRIPTIONS = {
    "cornell": f"Cornell box with a hole cut in the ceiling for the light (`{CORNELL_BOX.name}`), "
    f"each triangle split {CORNELL_SPLIT} x {CORNELL_SPLIT} (`subdivide`) so corner colours can show the "
    "blocks' shadows",
    "sponza": f"Dabrovic Sponza (`{SPONZA.name}`) plus a sky light: a downward-facing emissive quad "
    f"(2 triangles, emission {SKY_EMISSION:g} in R, G and B, reflectance 0) spanning x -10.5..10.5 m, "
    "z -2.3..2.3 m at y = 15.4 m, just below the open roof of the atrium",
    "breakfast": f"the breakfast room (`{BREAKFAST.name}`, 269,538 triangles, its materials' reflectances as in "
    f"the file, up to 1.0) under a uniform white sky of strength {BREAKFAST_SKY:g} (`Scene.sky`) that enters "
    "through its open windows",
}


def missing() -> str | None:
    """Why the shared scenes cannot be read, or None."""
    if SCENES.is_dir():
        return None
    return f"no scenes at {SCENES} (shared/ must sit beside the repository)"


def load(name: str) -> Scene:
    """The core scene ``name``: "cornell", "sponza" or "breakfast"."""
    if name == "cornell":
        return subdivide(read_obj(CORNELL_BOX)[0], CORNELL_SPLIT)
    if name == "sponza":
        return sponza_with_names()[0]
    if name == "breakfast":
        return breakfast_with_names()[0]
    raise ValueError(f"no benchmark scene {name!r}: 'cornell', 'sponza' or 'breakfast'")


def sponza_with_names() -> tuple[Scene, list[str]]:
    """Sponza with the sky quad SKY_CORNERS as its only emitter (facing down, of a material of its
    own, SKY), and the name of each material."""
    scene, names = read_obj(SPONZA)
    return with_emitter_quad(scene, np.array(SKY_CORNERS), SKY_EMISSION, facing=(0.0, -1.0, 0.0)), [*names, SKY]


def breakfast_with_names() -> tuple[Scene, list[str]]:
    """The breakfast room under its uniform sky BREAKFAST_SKY, and the name of each material."""
    scene, names = read_obj(BREAKFAST)
    return dataclasses.replace(scene, sky=np.full(3, BREAKFAST_SKY)), names


def with_emitter_quad(scene: Scene, corners: np.ndarray, emission: float, facing: tuple[float, float, float]) -> Scene:
    """``scene`` plus the quad ``corners`` (4, 3) as two one-sided, black, emissive triangles of their
    own material; raises ValueError unless both triangles' fronts face the unit vector ``facing``."""
    first = len(scene.vertices)
    quad = np.array([[first, first + 1, first + 2], [first, first + 2, first + 3]])
    vertices = np.vstack([scene.vertices, corners])
    _areas, normals = areas_and_normals(vertices[quad])
    if not np.allclose(normals, facing, atol=1e-9):
        raise ValueError(f"the emitter's normals {normals.tolist()} do not face {facing}")
    return Scene(
        vertices,
        np.vstack([scene.triangles, quad]),
        np.vstack([scene.reflectance, np.zeros((2, 3))]),
        np.vstack([scene.emission, np.full((2, 3), emission)]),
        material=np.concatenate([scene.material, np.full(2, scene.material.max() + 1)]),
        two_sided=np.concatenate([scene.two_sided, np.zeros(2, dtype=bool)]),
    )


class Blend(NamedTuple):
    """A .blend of the studies against Cycles, what it holds (for the report) and the mesh
    objects that emit (left out of every comparison)."""

    path: Path
    description: str
    emitters: tuple[str, ...]

    def case(self) -> dict:
        """What a case of bench/in_blender.py on this file carries: the file and its emitters."""
        return {"blend": str(self.path), "emitters": list(self.emitters)}


def blend(name: str) -> Blend:
    """The .blend ``name``: "cornell_box" (sample_blends/), or "fine_mesh", "sponza" or "breakfast",
    built afresh into build/ by Blender in a process of its own."""
    if name == "cornell_box":
        return Blend(SAMPLE_BLEND, shown(SAMPLE_BLEND), in_blender.CORNELL_EMITTERS)
    BUILT.mkdir(parents=True, exist_ok=True)
    if name == "fine_mesh":
        path = BUILT / "fine_mesh.blend"
        built = value_in_fresh_process(in_blender.build_cornell_box, path, FINE_MESH_CELL)
        return Blend(path, f"{shown(path)}: {built}", in_blender.CORNELL_EMITTERS)
    if name == "sponza":
        path = BUILT / "sponza.blend"
        return Blend(path, f"{shown(path)}: {value_in_fresh_process(build_sponza, path)}", (SKY,))
    if name == "breakfast":
        path = BUILT / "breakfast.blend"
        return Blend(path, f"{shown(path)}: {value_in_fresh_process(build_breakfast, path)}", ())
    raise ValueError(f"no .blend {name!r}: 'cornell_box', 'fine_mesh', 'sponza' or 'breakfast'")


def build_sponza(path: Path) -> str:
    """Sponza saved as a .blend at ``path`` (bench/in_blender.py ``save_scene``); what was built."""
    scene, names = sponza_with_names()
    return in_blender.save_scene(scene, names, path)


def build_breakfast(path: Path) -> str:
    """The breakfast room under its sky saved as a .blend at ``path`` (``save_scene``), shaded smooth
    but across edges sharper than the bake's crease angle, so that its nodes are those of the core's
    bake of the OBJ (the breakfast study's); what was built."""
    scene, names = breakfast_with_names()
    return in_blender.save_scene(scene, names, path, smooth_angle=BakeSettings().crease_angle)


class Extracted(NamedTuple):
    """The core scene of a .blend as the add-on reads it (no lights: they stay in Blender), and
    the (object name, loop) each triangle corner's colour is written to, both (T, 3)."""

    scene: Scene
    owner: np.ndarray
    loop: np.ndarray


def extracted(path: Path) -> Extracted:
    """The scene of the .blend at ``path``, read by the add-on in a process of its own."""
    fields, owner, loop = value_in_fresh_process(in_blender.extract, path)
    return Extracted(Scene(**fields), owner, loop)
