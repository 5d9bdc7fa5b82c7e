"""The core scene of a .blend as the add-on reads it (its fields, as arrays), with the (object
name, loop) each triangle corner's colour is written to, pickled to the path given: for
bench/path_traced.py (Sponza's .blend and the sample Cornell box), in a process of its own
(bench/path_traced.py imports bench/cycles.py as ``cycles``, the name of Blender's own add-on).

Run: ``.venv/bin/python bench/blend_scene.py BLEND OUT.pkl``.
"""

from __future__ import annotations

import pickle
import sys
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parent.parent
sys.path[0] = str(REPO)  # not bench/, whose cycles.py would stand in for Blender's add-on
from tools.source_extension import blender_with_extension  # noqa: E402


def main(blend: str, out: str) -> None:
    bpy, package = blender_with_extension()
    bpy.ops.wm.open_mainfile(filepath=blend, load_ui=False)
    extraction = package.radiosity_addon.extract.extract(bpy.context.evaluated_depsgraph_get())
    scene = extraction.scene
    if scene.lights or np.any(scene.sky):
        raise SystemExit("the path tracer samples emitting surfaces only: this scene has lights or a sky")
    # plain arrays: the extension's own classes cannot be unpickled without Blender
    fields = {name: getattr(scene, name) for name in scene.__dataclass_fields__ if name != "lights"}
    count = len(scene.triangles)
    owner, loop = np.empty((count, 3), dtype=object), np.zeros((count, 3), dtype=np.int64)
    for target in extraction.targets:
        owner[target.start:target.stop] = target.object_name
        loop[target.start:target.stop] = np.asarray(target.loops).reshape(-1, 3)
    Path(out).write_bytes(pickle.dumps((fields, owner, loop)))


if __name__ == "__main__":
    main(*sys.argv[1:3])
