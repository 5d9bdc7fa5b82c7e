"""What a Flamenco worker runs for the job type's tasks: ``blender -b FILE.blend -c radiosity
ARGS``, here as Blender does it (the file opened, then the command called with ARGS), for the
command lines farm/flamenco/radiosity_bake.js makes (tests/farm/test_flamenco_job.py checks
their form)."""

import os

import bpy
import numpy as np

from tests.addon.blender_scenes import corner_colours, diffuse_material, grid_object, light_object
from tests.farm.flamenco import compile_job


def run_task(cli, task: dict) -> int:
    [command] = task["commands"]
    parameters = command["parameters"]
    bpy.ops.wm.open_mainfile(filepath=parameters["blendfile"], load_ui=False)
    assert parameters["args"][:2] == ["-c", "radiosity"]
    return cli.main(parameters["args"][2:])


def test_each_task_bakes_its_file(addon, tmp_path):
    files = []
    for name, grey in (("hall", 0.5), ("cellar", 0.25)):
        bpy.ops.wm.read_homefile(use_factory_startup=True, use_empty=True)
        grid_object("Floor", 2.0, 2, material=diffuse_material("Grey", (grey, grey, grey)))
        light_object("Sun", "SUN", (0, 0, 5), 2.0)
        files.append(str(tmp_path / "levels" / f"{name}.blend"))
        os.makedirs(os.path.dirname(files[-1]), exist_ok=True)
        bpy.ops.wm.save_as_mainfile(filepath=files[-1])
    compiled = compile_job({"files": "\n".join(files), "output": "folder", "output_folder": str(tmp_path / "baked"),
                            "preset": "draft", "options": "--attribute 'Sun Light' --lighting-only"})
    for task in compiled["tasks"]:
        assert run_task(addon.radiosity_addon.cli, task) == 0
    for name in ("hall", "cellar"):
        bpy.ops.wm.open_mainfile(filepath=str(tmp_path / "baked" / f"{name}_baked.blend"))
        assert bpy.context.scene.radiosity.preset == "DRAFT"
        _, colours = corner_colours(bpy.data.objects["Floor"], "Sun Light")
        # lighting only: the irradiance over pi, whatever the reflectance
        assert np.allclose(colours[:, :3], 2.0 / np.pi, rtol=1e-3)
