"""``blender -b FILE -c radiosity``: its plain function and its exit codes, called through the
bpy module as the registered command calls them (no Blender binary here)."""

import os

import bpy
import pytest

from tests.addon.blender_scenes import corner_colours, diffuse_material, grid_object, light_object


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
    (["--output", "x.blend", "--rays", "10"], "--rays must be one of"),
    (["--output", "x.blend", "--patch-size", "-1"], "--patch-size must be a positive length"),
    (["--output", "x.blend", "--max-shots", "-1"], "--max-shots must be 0 (no limit) or more"),
    (["--output", "x.blend", "--monte-carlo-rays", "100"], "--monte-carlo-rays must be one of auto, 0, 16, 64"),
    (["--output", "x.blend", "--preset", "draft", "--tolerance", "0.1"], "--preset draft fixes the knobs"),
    (["--output", "x.txt"], "must be a .blend file"),
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
    output = str(tmp_path / "stopped.blend")
    assert cli.main(["--output", output, "--max-shots", "1", "-q"]) == 0
    bpy.ops.wm.open_mainfile(filepath=output)
    settings = bpy.context.scene.radiosity
    assert settings.max_shots == 1
    assert ", stopped after 1 shot, " in settings.last_report, settings.last_report


def test_monte_carlo_rays_are_applied_and_saved_with_the_baked_file(cli, saved_scene, tmp_path):
    output = str(tmp_path / "monte_carlo.blend")
    assert cli.main(["--output", output, "--monte-carlo-rays", "64", "-q"]) == 0
    bpy.ops.wm.open_mainfile(filepath=output)
    settings = bpy.context.scene.radiosity
    assert settings.monte_carlo_rays == "64"
    assert "then Monte Carlo (64 rays per vertex)" in settings.last_report, settings.last_report
