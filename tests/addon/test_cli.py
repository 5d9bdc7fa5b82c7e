"""``blender -b FILE -c radiosity``: its plain function and its exit codes, called through the
bpy module as the registered command calls them (no Blender binary here)."""

import json
import os
import tomllib
from pathlib import Path

import bpy
import numpy as np
import pytest

from tests.addon.blender_scenes import corner_colours, diffuse_material, grid_object, light_object

MANIFEST = tomllib.loads((Path(__file__).resolve().parents[2] / "blender_manifest.toml").read_text())


@pytest.fixture
def saved_scene(tmp_path) -> str:
    grid_object("Floor", 2.0, 2, material=diffuse_material("Grey", (0.5, 0.5, 0.5)))
    light_object("Sun", "SUN", (0, 0, 5), 2.0)
    path = str(tmp_path / "scene.blend")
    bpy.ops.wm.save_as_mainfile(filepath=path)
    return path


@pytest.fixture
def cli(addon):
    return addon.radiosity_addon.cli


def test_the_command_is_registered(addon_module_name):
    import bpy.utils

    assert hasattr(bpy.utils, "register_cli_command")


def test_bake_to_an_output_file_leaves_the_input_alone(cli, saved_scene, tmp_path):
    stamp = os.stat(saved_scene).st_mtime_ns
    output = str(tmp_path / "out" / "baked.blend")
    assert cli.main(["--output", output, "--preset", "draft", "-q"]) == 0
    assert os.stat(saved_scene).st_mtime_ns == stamp
    bpy.ops.wm.open_mainfile(filepath=output)
    _, colours = corner_colours(bpy.data.objects["Floor"])
    assert colours[:, :3].min() > 0
    assert bpy.context.scene.radiosity.preset == "DRAFT"  # the file says how it was baked


def test_input_option_opens_the_file_first(cli, saved_scene, tmp_path):
    bpy.ops.wm.read_homefile(use_factory_startup=True, use_empty=True)
    output = str(tmp_path / "baked.blend")
    assert cli.main(["--input", saved_scene, "--output", output, "-q"]) == 0
    assert os.path.isfile(output)


def test_overwrite_only_when_asked(cli, saved_scene):
    stamp = os.stat(saved_scene).st_mtime_ns
    assert cli.main(["--output", saved_scene]) == 2
    assert cli.main([]) == 2  # nothing would be kept
    assert os.stat(saved_scene).st_mtime_ns == stamp
    assert cli.main(["--overwrite", "-q"]) == 0
    assert os.stat(saved_scene).st_mtime_ns != stamp


@pytest.mark.parametrize("argv, message", [
    (["--output", "x.blend", "--preset", "fast"], "invalid choice"),
    (["--output", "x.blend", "--rays-per-form-factor", "10"], "rays_per_form_factor must be a perfect square"),
    (["--output", "x.blend", "--rays-per-form-factor", "25"], "--rays-per-form-factor must be one of 1, 4, 9"),
    (["--output", "x.blend", "--patch-size", "-1"], "patch_size must be a positive length"),
    (["--output", "x.blend", "--max-shots", "-1"], "max_shots must be a non-negative integer or None"),
    (["--output", "x.blend", "--monte-carlo-rays", "100"], "--monte-carlo-rays must be one of auto, 0, 16, 64"),
    (["--output", "x.blend", "--preset", "draft", "--tolerance", "0.1"], "--preset draft fixes --tolerance"),
    (["--output", "x.txt"], "must be a .blend file"),
    (["--output", "x.blend", "--suffix", "_baked"], "leave out --output-dir and --suffix"),
    (["--overwrite", "--output-dir", "baked"], "give either --overwrite or where to save"),
    (["--render", "x.jpg"], "--render must be a .png file"),
    (["--input", "/nonexistent.blend", "--output", "x.blend"], "no such file"),
    (["--output", "x.blend", "--bogus"], "unrecognized arguments"),
])
def test_bad_arguments_exit_2_with_one_line(cli, saved_scene, capsys, argv, message):
    assert cli.main(argv) == 2
    error = capsys.readouterr().err.strip()
    assert message in error and len(error.splitlines()) == 1


def test_bad_input_exits_2(cli, tmp_path):
    bpy.ops.wm.read_homefile(use_factory_startup=True, use_empty=True)
    assert cli.main(["--output", str(tmp_path / "x.blend")]) == 2  # no mesh to bake


def test_unexpected_errors_exit_1(cli, saved_scene, monkeypatch, capsys):
    def broken(*args, **kwargs):
        raise RuntimeError("disk on fire")

    monkeypatch.setattr(cli, "prepare", broken)
    assert cli.main(["--overwrite"]) == 1
    assert "disk on fire" in capsys.readouterr().err


def test_render_writes_a_picture(cli, saved_scene, tmp_path):
    camera = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    camera.location = (0, 0, 4)
    bpy.context.scene.collection.objects.link(camera)
    bpy.context.scene.camera = camera
    bpy.context.scene.render.resolution_x = bpy.context.scene.render.resolution_y = 32
    picture = str(tmp_path / "picture.png")
    assert cli.main(["--render", picture, "-q"]) == 0
    image = bpy.data.images.load(picture)
    assert tuple(image.size) == (32, 32)


def test_max_shots_is_applied_and_saved_with_the_baked_file(cli, saved_scene, tmp_path):
    """``--max-shots 1`` stops after one shot and the file keeps the limit; ``--max-shots none``
    (the knob's word for None) lifts it again."""
    stopped, unlimited = str(tmp_path / "stopped.blend"), str(tmp_path / "unlimited.blend")
    assert cli.main(["--output", stopped, "--max-shots", "1", "-q"]) == 0
    bpy.ops.wm.open_mainfile(filepath=stopped)
    settings = bpy.context.scene.radiosity
    assert settings.use_max_shots and settings.max_shots == 1
    assert ", stopped after 1 shot, " in settings.last_report, settings.last_report
    assert cli.main(["--output", unlimited, "--max-shots", "none", "-q"]) == 0
    bpy.ops.wm.open_mainfile(filepath=unlimited)
    settings = bpy.context.scene.radiosity
    assert not settings.use_max_shots and "stopped" not in settings.last_report, settings.last_report


def test_monte_carlo_rays_are_applied_and_saved_with_the_baked_file(cli, saved_scene, tmp_path):
    output = str(tmp_path / "monte_carlo.blend")
    assert cli.main(["--output", output, "--monte-carlo-rays", "64", "-q"]) == 0
    bpy.ops.wm.open_mainfile(filepath=output)
    settings = bpy.context.scene.radiosity
    assert settings.monte_carlo_rays == "64"
    assert "then Monte Carlo (64 rays per vertex)" in settings.last_report, settings.last_report


def test_every_exposed_knob_is_a_property_and_an_option_of_the_same_name(addon, cli):
    """The knob table (core.settings.KNOBS) names each knob once: Blender's property of that name
    has the table's tooltip, and the command takes the knob's flag (``--patch-size``); the core's
    command line takes the same flags (tests/core/test_settings.py)."""
    settings = bpy.context.scene.radiosity
    options = {flag for action in cli.build_parser()._actions for flag in action.option_strings}
    for knob in addon.core.settings.KNOBS:
        if not knob.exposed:
            continue
        assert knob.flag in options, knob.name
        tooltip = settings.bl_rna.properties[knob.name].description
        assert tooltip.startswith(knob.description), (knob.name, tooltip)


def test_knobs_given_on_the_command_line_reach_the_core(cli, saved_scene, tmp_path, monkeypatch):
    """Each exposed knob given on the command line arrives in the core's bake with its value (to
    float32, which Blender's float properties hold)."""
    seen = {}
    original = cli.run_straight

    def spy(prepared, **options):
        seen.update(prepared.knobs)
        return original(prepared, **options)

    monkeypatch.setattr(cli, "run_straight", spy)
    argv = ["--output", str(tmp_path / "baked.blend"), "-q", "--patch-size", "0.5", "--rays-per-form-factor", "4",
            "--hemicube-resolution", "16", "--tolerance", "0.01", "--max-shots", "7", "--monte-carlo-rays", "16",
            "--no-ambient", "--no-merge-flat", "--crease-angle", "45", "--refinement-levels", "1", "--seed", "3",
            "--method", "raycast", "--solver", "progressive", "--link-tolerance", "0.02", "--denoise", "2.5"]
    assert cli.main(argv) == 0
    assert seen == {"patch_size": 0.5, "rays_per_form_factor": 4, "hemicube_resolution": 16,
                    "tolerance": pytest.approx(0.01, rel=1e-7),
                    "max_shots": 7, "monte_carlo_rays": 16, "ambient": False, "merge_flat": False,
                    "crease_angle": pytest.approx(45.0), "refinement_levels": 1, "seed": 3, "method": "raycast",
                    "solver": "progressive", "link_tolerance": pytest.approx(0.02, rel=1e-7), "denoise": 2.5,
                    "split_direct": False}


def _scene_file(path, grey: float) -> str:
    """A saved file: a grey floor under a sun."""
    bpy.ops.wm.read_homefile(use_factory_startup=True, use_empty=True)
    grid_object("Floor", 2.0, 2, material=diffuse_material("Grey", (grey, grey, grey)))
    light_object("Sun", "SUN", (0, 0, 5), 2.0)
    os.makedirs(os.path.dirname(path), exist_ok=True)
    bpy.ops.wm.save_as_mainfile(filepath=str(path))
    return str(path)


def test_three_files_in_one_command_one_broken(cli, tmp_path, capsys):
    """Two good files (one reached through a glob) and one that is not a .blend file: the good
    ones are baked and saved, the broken one is refused with Blender's reason, the summary says
    so, the exit code is 2, and the JSON summary records each file."""
    first = _scene_file(tmp_path / "levels" / "first.blend", 0.5)
    second = _scene_file(tmp_path / "levels" / "more" / "second.blend", 0.8)
    broken = tmp_path / "levels" / "broken.blend"
    broken.write_bytes(b"this is not a blend file\n" * 10)
    summary = tmp_path / "summary.json"
    argv = ["--input", first, str(broken), str(tmp_path / "levels" / "more" / "*.blend"),
            "--output-dir", str(tmp_path / "baked"), "--suffix", "_lit", "--preset", "draft",
            "--summary", str(summary)]
    assert cli.main(argv) == 2
    out, err = capsys.readouterr()
    assert out.strip().splitlines()[-1] == "radiosity: 3 files: 2 baked, 1 refused (broken.blend)"
    assert f"[2/3] broken.blend: error: cannot open {broken}" in err
    lines = (out + err).splitlines()
    assert not any(line.startswith("Fra:") or "Saved: '" in line for line in lines)  # nothing a farm takes for a render

    report = json.loads(summary.read_text())
    assert report["exit_code"] == 2 and report["argv"] == argv and report["extension"] == MANIFEST["version"]
    assert [(f["input"], f["status"]) for f in report["files"]] == [
        (first, "baked"), (str(broken), "refused"), (second, "baked")]
    for entry, grey in zip([report["files"][0], report["files"][2]], (0.5, 0.8)):
        assert entry["output"] == str(tmp_path / "baked" / (os.path.basename(entry["input"])[:-6] + "_lit.blend"))
        assert entry["stats"]["triangles"] == 8 and 0 < entry["stats"]["error_estimate"] < 0.1
        bpy.ops.wm.open_mainfile(filepath=entry["output"])
        _, colours = corner_colours(bpy.data.objects["Floor"])
        # a sun of irradiance 2 W/m^2 straight down on a diffuse floor: B = rho E / pi
        assert np.allclose(colours[:, :3], grey * 2.0 / np.pi, rtol=1e-3)
    assert not (tmp_path / "baked" / "broken_lit.blend").exists()


def test_an_unexpected_error_in_one_file_does_not_stop_the_others(cli, tmp_path, monkeypatch, capsys):
    files = [_scene_file(tmp_path / f"{name}.blend", 0.5) for name in ("a", "b", "c")]
    original = cli.prepare

    def broken_on_b(scene, view_layer=None):
        if bpy.data.filepath.endswith("b.blend"):
            raise RuntimeError("disk on fire")
        return original(scene, view_layer)

    monkeypatch.setattr(cli, "prepare", broken_on_b)
    assert cli.main(["--input", *files, "--suffix", "_baked", "-q"]) == 1
    out, err = capsys.readouterr()
    assert "disk on fire" in err and "[2/3] b.blend: unexpected error" in err
    assert "3 files: 2 baked, 1 failed (b.blend)" in out
    assert [os.path.exists(tmp_path / f"{name}_baked.blend") for name in "abc"] == [True, False, True]


@pytest.mark.parametrize("argv, message", [
    (["--input", "a.blend", "b.blend", "--output", "x.blend"], "--output names one file but 2 are baked"),
    (["--input", "a.blend", "b.blend", "--render", "x.png"], "names one picture but 2 files are baked"),
    (["--input", "one/a.blend", "two/a.blend", "--output-dir", "baked"], "would both be saved to"),
    (["--input", "a.blend", "--output-dir", "."], "would replace its input"),
])
def test_batch_arguments_are_checked_before_anything_is_baked(cli, tmp_path, monkeypatch, capsys, argv, message):
    monkeypatch.chdir(tmp_path)
    assert cli.main(argv) == 2
    error = capsys.readouterr().err.strip()
    assert message in error and len(error.splitlines()) == 1
    assert os.listdir(tmp_path) == []


def test_a_pattern_that_matches_nothing_fails_alone(cli, tmp_path, capsys):
    good = _scene_file(tmp_path / "good.blend", 0.5)
    missing = str(tmp_path / "nothing" / "*.blend")
    assert cli.main(["--input", missing, good, "--suffix", "_baked", "-q"]) == 2
    assert f"no such file: {missing}" in capsys.readouterr().err
    assert os.path.exists(tmp_path / "good_baked.blend")


def test_render_alone_puts_a_picture_beside_each_baked_file(cli, tmp_path, capsys):
    files = []
    for name in ("a", "b"):
        _scene_file(tmp_path / f"{name}.blend", 0.5)
        camera = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
        camera.location = (0, 0, 4)
        bpy.context.scene.collection.objects.link(camera)
        bpy.context.scene.camera = camera
        bpy.context.scene.render.resolution_x = bpy.context.scene.render.resolution_y = 16
        bpy.ops.wm.save_mainfile()
        files.append(bpy.data.filepath)
    assert cli.main(["--input", *files, "--suffix", "_baked", "--render", "-q"]) == 0
    for name in ("a", "b"):
        assert tuple(bpy.data.images.load(str(tmp_path / f"{name}_baked.png")).size) == (16, 16)
