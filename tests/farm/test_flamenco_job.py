"""The Flamenco job type: the tasks and Blender command lines compileJob makes from a job's
settings, and the jobs it refuses, under Node with a stand-in for the Manager's API. That the
command lines bake what they say on real files is tests/addon/test_farm.py."""

import shlex

import pytest

from core.settings import PRESETS
from tests.farm.flamenco import compile_job

# Flamenco's setting types (its job type documentation and built-in scripts).
SETTING_TYPES = {"string", "int32", "float", "bool"}


def blender_commands(compiled: dict) -> list[tuple[str, list[str]]]:
    """(blend file, arguments after it) of each task's one blender-render command."""
    commands = []
    for task in compiled["tasks"]:
        assert task["type"] == "blender" and len(task["commands"]) == 1
        [command] = task["commands"]
        assert command["name"] == "blender-render"
        parameters = command["parameters"]
        assert ((parameters["exe"], parameters["exeArgs"], parameters["argsBefore"])
                == ("{blender}", "{blenderArgs}", []))
        commands.append((parameters["blendfile"], parameters["args"]))
    return commands


def test_one_task_per_file_each_baking_its_file_beside_itself():
    compiled = compile_job({"files": "/farm/levels/a.blend\n/farm/levels/b.blend; /farm/other/c.blend\n",
                            "blendfile": "/farm/submitted.blend"})
    assert [task["name"] for task in compiled["tasks"]] == ["bake-a", "bake-b", "bake-c"]
    assert blender_commands(compiled) == [
        (f"/farm/{path}", ["-c", "radiosity", "--suffix", "_baked"])
        for path in ("levels/a.blend", "levels/b.blend", "other/c.blend")]
    assert all(task["dependencies"] == [] for task in compiled["tasks"])  # any worker, any order


def test_without_a_list_the_submitted_file_is_baked():
    compiled = compile_job({"blendfile": "/jobs/scene-x1/scene.blend", "preset": "production", "render": True})
    assert blender_commands(compiled) == [
        ("/jobs/scene-x1/scene.blend", ["-c", "radiosity", "--suffix", "_baked", "--render", "--preset", "production"])]


def test_output_folder_and_overwrite():
    folder = compile_job({"files": "/a/x.blend;/b/y.blend", "output": "folder", "output_folder": "/baked",
                          "suffix": ""})
    assert [args for _, args in blender_commands(folder)] == [["-c", "radiosity", "--output-dir", "/baked"]] * 2
    overwrite = compile_job({"files": "/a/x.blend", "output": "overwrite"})
    assert blender_commands(overwrite) == [("/a/x.blend", ["-c", "radiosity", "--overwrite"])]


@pytest.mark.parametrize("options", [
    "--patch-size 0.25",
    "  --attribute 'Day Light'   --tolerance=0.001 ",
    '--attribute "Night \\"blue\\" light" --seed 3',
    "--attribute It\\'s\\ lit",
    "",
])
def test_options_are_split_as_a_shell_splits_them(options):
    [(_, args)] = blender_commands(compile_job({"files": "/a/x.blend", "options": options}))
    assert args[4:] == shlex.split(options)


@pytest.mark.parametrize("settings, message", [
    ({}, "No .blend file to bake"),
    ({"files": "/a/x.blend;/a/notes.txt"}, 'Not a .blend file: "/a/notes.txt"'),
    ({"files": "/a/x.blend", "suffix": ""}, "the suffix is empty"),
    ({"files": "/a/x.blend", "output": "folder"}, "choose the output folder"),
    ({"files": "/a/x.blend;/b/x.blend", "output": "folder", "output_folder": "/out"},
     '"/a/x.blend" and "/b/x.blend" would both be baked into /out/x_baked.blend'),
    ({"files": "/a/x.blend", "options": "--output /tmp/y.blend"}, "Option --output is set by the job's own"),
    ({"files": "/a/x.blend", "options": "--suffix=_x"}, "Option --suffix=_x is set by the job's own"),
    ({"files": "/a/x.blend", "options": "--attribute 'open"}, "Unbalanced ' in options"),
    ({"files": "/a/x.blend", "output": "elsewhere"}, 'Unknown output "elsewhere"'),
])
def test_jobs_that_cannot_work_are_refused_with_a_reason(settings, message):
    compiled = compile_job(settings)
    assert message in compiled.get("error", ""), compiled


def test_each_file_is_baked_once():
    compiled = compile_job({"files": "/a/x.blend\n/a/x.blend\n/a/y.blend"})
    assert [blend for blend, _ in blender_commands(compiled)] == ["/a/x.blend", "/a/y.blend"]


def test_job_type_settings_are_well_formed():
    """Keys once each, Flamenco's types, defaults among the choices, and the presets the
    extension has."""
    settings = compile_job({"files": "/a/x.blend"})["jobType"]["settings"]
    keys = [setting["key"] for setting in settings]
    assert len(keys) == len(set(keys))
    for setting in settings:
        assert setting["type"] in SETTING_TYPES and setting["description"], setting
        if "choices" in setting:
            assert setting["default"] in setting["choices"], setting
    [preset] = [setting for setting in settings if setting["key"] == "preset"]
    assert preset["choices"] == ["file"] + [name.lower() for name in PRESETS]
