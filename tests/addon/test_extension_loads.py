"""The checkout loads as a real Blender extension, and its core is reached through the extension's
own package (relative imports), not through sys.path."""

import importlib
import sys
from pathlib import Path

import addon_utils
import bpy

ROOT = Path(__file__).resolve().parents[2]


def test_extension_is_enabled_from_the_checkout(addon, addon_module_name):
    assert addon_module_name.startswith("bl_ext.") and addon_module_name.endswith(".radiosity")
    assert addon_module_name in bpy.context.preferences.addons
    assert addon_utils.check(addon_module_name) == (True, True)
    assert addon_utils.check_extension(addon_module_name)
    assert Path(addon.__file__).resolve() == ROOT / "__init__.py"


def test_extension_stays_enabled_across_new_files(addon_module_name):
    bpy.ops.wm.read_homefile(use_factory_startup=True, use_empty=True)
    assert addon_module_name in bpy.context.preferences.addons
    assert not bpy.data.objects and not bpy.data.meshes


def test_core_is_a_subpackage_of_the_extension(addon, addon_module_name):
    core = importlib.import_module(f"{addon_module_name}.core")
    assert Path(core.__file__).resolve() == ROOT / "core" / "__init__.py"
    assert callable(core.bake) and core.Scene is not None
    # every core module came in under the extension's package, none under a top-level ``core``
    loaded = [name for name in sys.modules if name.startswith(f"{addon_module_name}.core.")]
    assert f"{addon_module_name}.core.bake" in loaded
    for name in loaded:
        assert not hasattr(sys.modules[name], "bpy"), f"{name} holds bpy"


def test_radiosity_addon_is_a_subpackage_of_the_extension(addon, addon_module_name):
    layer = importlib.import_module(f"{addon_module_name}.radiosity_addon")
    assert layer.__name__ == addon.radiosity_addon.__name__
    assert Path(layer.__file__).resolve() == ROOT / "radiosity_addon" / "__init__.py"
