"""Build Sponza as a .blend for the Cycles comparison (bench/sponza.py), with the bpy module:

    .venv/bin/python bench/sponza_blend.py OUTPUT.blend

The scene is bench/scenes.py's ``sponza()`` (../shared/scenes/dabrovic_sponza plus the sky quad
under the open roof), turned from the OBJ's +Y up to Blender's +Z up by the rotation
(x, y, z) -> (x, -z, y): one mesh object per material, named after it, and ``sky`` for the
quad. Surfaces are purely diffuse Principled BSDFs of the MTL's Kd (as read_obj clamps it), the
quad a plain Emission shader; no world light; Cycles set up as ../shared/CYCLES.md says. Not
committed: the model's licence is non-commercial (../shared/scenes), and it is rebuilt in seconds.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
REPO = HERE.parent
# bench/ is first on sys.path (the script's directory), where bench/cycles.py would shadow Blender's
# own "cycles" add-on: take it off before bpy is imported, and reach the helpers by the repository
sys.path[:] = [entry for entry in sys.path if os.path.abspath(entry or ".") != str(HERE)]
sys.path[:0] = [str(REPO), str(REPO / "sample_blends")]

import numpy as np  # noqa: E402

from core.scene.objfile import read_obj  # noqa: E402

SKY = "sky"  # the emitting quad's object


def build(path: Path) -> str:
    """Save the scene to ``path``; a line saying what was built."""
    sys.path.insert(0, str(HERE))
    import scenes  # bench/scenes.py: the sky quad's corners and emission

    sys.path.remove(str(HERE))
    from tools.source_extension import import_bpy

    bpy = import_bpy()
    import build_samples as blend

    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.context.preferences.filepaths.save_version = 0
    model, names = read_obj(scenes.SPONZA)
    scene = scenes.with_emitter_quad(model, np.array(scenes.SKY_CORNERS), scenes.SKY_EMISSION, facing=(0.0, -1.0, 0.0))
    names = [*names, SKY]
    vertices = scene.vertices[:, [0, 2, 1]] * np.array([1.0, -1.0, 1.0])
    for material in np.unique(scene.material):
        chosen = np.flatnonzero(scene.material == material)
        used, corners = np.unique(scene.triangles[chosen], return_inverse=True)
        mesh = bpy.data.meshes.new(names[material])
        mesh.from_pydata(vertices[used].tolist(), [], corners.reshape(-1, 3).tolist())
        mesh.update()
        emission = scene.emission[chosen[0]]
        if emission.any():
            strength = float(emission.max())
            mesh.materials.append(blend.emission(names[material], tuple(emission / strength), strength))
        else:
            mesh.materials.append(blend.diffuse_principled(names[material], tuple(scene.reflectance[chosen[0]])))
        blend.link_object(names[material], mesh)
    blend.set_render(bpy.context.scene, "sponza", 512, 512)
    path.parent.mkdir(parents=True, exist_ok=True)
    bpy.ops.wm.save_as_mainfile(filepath=str(path), compress=True, check_existing=False)
    return f"{path}: {len(scene.triangles)} triangles, {len(names)} meshes, {path.stat().st_size / 1024:.0f} KiB"


if __name__ == "__main__":
    print(build(Path(sys.argv[1]).resolve()))
