"""The benchmark scenes, read from ../shared/scenes beside the repository (never copied into it)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from core import Scene
from core.util.geometry import areas_and_normals
from core.scene.objfile import read_obj, subdivide

REPO = Path(__file__).resolve().parent.parent
SCENES = REPO / ".." / "shared" / "scenes"
CORNELL_BOX = SCENES / "cornell_box" / "cornell_box_ceiling_hole.obj"
SPONZA = SCENES / "dabrovic_sponza" / "dabrovic_sponza.obj"

CORNELL_SPLIT = 4  # each input triangle split into 4 x 4, so corner colours can show the blocks' shadows
# Sponza's courtyard is open to the sky over x in (-10.8, 10.8), z in (-2.4, 2.4) (m) up to the roof at
# y = 15.65; no triangle reaches into this rectangle at y = 15.4, so the sky quad there touches nothing.
SKY_CORNERS = ((-10.5, 15.4, -2.3), (10.5, 15.4, -2.3), (10.5, 15.4, 2.3), (-10.5, 15.4, 2.3))
SKY_EMISSION = 5.0

DESCRIPTIONS = {
    "cornell": f"Cornell box with a hole cut in the ceiling for the light (`{CORNELL_BOX.name}`), "
    f"each triangle split {CORNELL_SPLIT} x {CORNELL_SPLIT} (`subdivide`) so corner colours can show the "
    "blocks' shadows",
    "sponza": f"Dabrovic Sponza (`{SPONZA.name}`) plus a sky light: a downward-facing emissive quad "
    f"(2 triangles, emission {SKY_EMISSION:g} in R, G and B, reflectance 0) spanning x -10.5..10.5 m, "
    "z -2.3..2.3 m at y = 15.4 m, just below the open roof of the atrium",
}


def cornell_box() -> Scene:
    """The Cornell box (ceiling-hole variant), every triangle split CORNELL_SPLIT x CORNELL_SPLIT."""
    scene, _materials = read_obj(CORNELL_BOX)
    return subdivide(scene, CORNELL_SPLIT)


def sponza() -> Scene:
    """Dabrovic Sponza with the sky quad SKY_CORNERS appended as its only emitter."""
    scene, _materials = read_obj(SPONZA)
    return with_emitter_quad(scene, np.array(SKY_CORNERS), SKY_EMISSION, facing=(0.0, -1.0, 0.0))


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


LOADERS = {"cornell": cornell_box, "sponza": sponza}
