"""The built extension package, as users get it: built by tools/build_extension.py with Blender's own
extension tool, installed into a repository with Blender's own operator, enabled, and baking.

The package is built into a temporary directory for this run, from the embreex wheels in wheels/
(downloaded once; the tests are skipped when they cannot be downloaded). The checkout's own copy
of the extension (conftest.py) is disabled meanwhile: both would register the same classes.
"""

from __future__ import annotations

import importlib.util
import platform
import sys
import sysconfig
import warnings
import zipfile
from pathlib import Path
from types import ModuleType

import addon_utils
import bpy
import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[2]

# Blender's platform names, as blender_ext.py build --split-platforms suffixes them.
PLATFORM = {
    ("Linux", "x86_64"): "linux_x64",
    ("Windows", "AMD64"): "windows_x64",
    ("Darwin", "arm64"): "macos_arm64",
    ("Darwin", "x86_64"): "macos_x64",
}.get((platform.system(), platform.machine()))

# What users get in the zip: the manifest, the register() module, the two packages, the wheels.
PACKAGED_TOP_LEVEL = {"blender_manifest.toml", "__init__.py", "README.md", "core", "radiosity_addon", "wheels"}

EMISSION_COLOR = np.array([0.8, 0.5, 0.25])
EMISSION_STRENGTH = 3.0
ALBEDO = 0.5


def load_build_script() -> ModuleType:
    spec = importlib.util.spec_from_file_location("build_extension", ROOT / "tools" / "build_extension.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope="module")
def package_zip(tmp_path_factory: pytest.TempPathFactory) -> Path:
    if PLATFORM is None:
        pytest.skip(f"the extension has no package for {platform.system()} {platform.machine()}")
    build_extension = load_build_script()
    try:
        build_extension.ensure_wheels(quiet=True)
    except build_extension.WheelsUnavailable as error:
        pytest.skip(f"the package bundles embreex wheels, and they could not be downloaded: {error}")
    zips = build_extension.build(tmp_path_factory.mktemp("package"), quiet=True)
    (package,) = [z for z in zips if z.stem.endswith(PLATFORM)]
    return package


@pytest.fixture(scope="module")
def installed_package(package_zip, addon_module_name, extension_switch, tmp_path_factory) -> str:
    """Installs the package into a user repository of its own and enables it as a farm worker is
    set up (farm/README.md): Blender's ``-c extension install-file --repo ID --enable FILE.zip``;
    returns its module name."""
    extension_switch.disable(addon_module_name)
    repos = bpy.context.preferences.extensions.repos
    repo = repos.new(
        name="radiosity package",
        module="radiosity_package",
        custom_directory=str(tmp_path_factory.mktemp("package-repo")),
        source='USER',
    )
    module_name = f"bl_ext.{repo.module}.radiosity"
    try:
        from bl_pkg import cli_extension

        assert cli_extension(["install-file", "--repo", repo.module, "--enable", str(package_zip)]) == 0
        yield module_name
    finally:
        if module_name in bpy.context.preferences.addons:
            extension_switch.disable(module_name)
        repos.remove(repo)
        extension_switch.enable(addon_module_name)


def test_package_holds_only_what_users_need(package_zip):
    with zipfile.ZipFile(package_zip) as archive:
        names = archive.namelist()
    assert {name.split("/")[0] for name in names} == PACKAGED_TOP_LEVEL
    assert not [n for n in names if "__pycache__" in n or n.endswith((".pyc", ".blend", ".blend1"))]
    wheels = [n for n in names if n.startswith("wheels/")]
    assert len(wheels) == 2 and {n.split("-")[2] for n in wheels} == {"cp311", "cp313"}, wheels


def test_package_installs_and_enables(installed_package):
    assert installed_package in bpy.context.preferences.addons
    assert addon_utils.check(installed_package) == (True, True)
    module = sys.modules[installed_package]
    repo_directory = Path(module.__file__).resolve().parent
    assert (repo_directory / "blender_manifest.toml").is_file()
    assert not (repo_directory / "tests").exists()
    assert ROOT not in Path(module.__file__).resolve().parents


def blender_filters_wheels_by_python_version() -> bool:
    from bl_pkg import bl_extension_utils

    return hasattr(bl_extension_utils, "python_versions_from_wheel_python_tag")


def test_blender_extracts_the_bundled_embreex_wheel(installed_package):
    site_packages = (
        Path(bpy.utils.user_resource('EXTENSIONS'))
        / ".local"
        / "lib"
        / f"python{sys.version_info.major}.{sys.version_info.minor}"
        / "site-packages"
    )
    binaries = sorted(p.name for p in (site_packages / "embreex").glob("*.*") if p.suffix in {".so", ".pyd"})
    assert binaries, f"Blender extracted no embreex wheel into {site_packages}"
    suffix = sysconfig.get_config_var("EXT_SUFFIX")
    wrong = [name for name in binaries if not name.endswith(suffix)]
    if blender_filters_wheels_by_python_version():
        assert not wrong, f"Blender extracted embreex binaries for another Python: {wrong}"
    elif wrong:
        # Blender 4.2.0 extracts the cp313 wheel (tools/build_extension.py, "Known limit"); there the
        # core falls back to its NumPy ray caster.
        warnings.warn(
            f"Blender {bpy.app.version_string} extracted embreex binaries for another Python ({wrong[0]}): "
            "the bake uses the NumPy ray caster there",
            stacklevel=1,
        )


def node_material(name: str, shader: str, color, strength: float | None = None) -> bpy.types.Material:
    material = bpy.data.materials.new(name)
    if material.node_tree is None:  # Blender 4.x; 5.0 gives every material nodes (and deprecates use_nodes)
        material.use_nodes = True
    nodes = material.node_tree.nodes
    nodes.clear()
    node = nodes.new(shader)
    node.inputs["Color"].default_value = (*color, 1.0)
    if strength is not None:
        node.inputs["Strength"].default_value = strength
    output = nodes.new("ShaderNodeOutputMaterial")
    material.node_tree.links.new(node.outputs[0], output.inputs["Surface"])
    return material


def square(name: str, size: float, height: float, facing_down: bool, material) -> bpy.types.Object:
    h = size / 2
    face = (0, 3, 2, 1) if facing_down else (0, 1, 2, 3)
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata([(-h, -h, height), (h, -h, height), (h, h, height), (-h, h, height)], [], [face])
    mesh.update()
    mesh.materials.append(material)
    obj = bpy.data.objects.new(name, mesh)
    bpy.context.scene.collection.objects.link(obj)
    obj.select_set(True)
    return obj


def corner_colors(obj: bpy.types.Object) -> np.ndarray:
    """(corners, 3) scene-linear RGB of the object's "Radiosity" attribute."""
    attribute = obj.data.color_attributes.get("Radiosity")
    assert attribute is not None, f"no Radiosity colour attribute on {obj.name}"
    assert (attribute.domain, attribute.data_type) == ('CORNER', 'FLOAT_COLOR')
    rgba = np.empty(len(attribute.data) * 4, dtype=np.float32)
    attribute.data.foreach_get("color", rgba)
    assert len(attribute.data) == len(obj.data.loops)
    return rgba.reshape(-1, 4)[:, :3].astype(float)


def test_package_bakes_an_emitter_over_a_diffuse_floor(installed_package):
    """A 1 m emitter (Emission shader, colour c, strength S) 1 m above a 2 m grey floor, nothing
    else, no world: the emitter bakes to S*c exactly, and the floor to albedo * F * S*c, with
    0 < F < 1 the same for the three channels."""
    bpy.context.scene.world = None
    light = node_material("Light", "ShaderNodeEmission", EMISSION_COLOR, EMISSION_STRENGTH)
    emitter = square("Emitter", 1.0, 1.0, True, light)
    floor = square("Floor", 2.0, 0.0, False, node_material("Grey", "ShaderNodeBsdfDiffuse", (ALBEDO,) * 3))
    bpy.context.view_layer.objects.active = emitter

    assert bpy.ops.radiosity.bake() == {'FINISHED'}

    emitted = EMISSION_STRENGTH * EMISSION_COLOR
    np.testing.assert_allclose(corner_colors(emitter), np.broadcast_to(emitted, (4, 3)), rtol=1e-5)
    form_factors = corner_colors(floor) / (ALBEDO * emitted)
    assert np.all(np.isfinite(form_factors))
    assert np.all((form_factors > 0) & (form_factors < 1)), form_factors
    np.testing.assert_allclose(form_factors, form_factors[:, :1].repeat(3, axis=1), rtol=1e-4)
