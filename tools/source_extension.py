"""Load this checkout into the ``bpy`` module as a real extension, as Blender would load it
once installed: for the add-on tests, the sample bake (``make bake``) and the benchmarks.

    from tools.source_extension import blender_with_extension
    bpy, package = blender_with_extension()     # package.radiosity_addon, package.core

Blender's user resources (preferences, extension repositories, extracted wheels) go to a
temporary directory, never to ~/.config/blender; ``bpy`` is imported here, after that is set.
"""

from __future__ import annotations

import atexit
import os
import shutil
import sys
import tempfile
import tomllib
from pathlib import Path
from types import ModuleType

ROOT = Path(__file__).resolve().parents[1]
EXTENSION_ID = tomllib.loads((ROOT / "blender_manifest.toml").read_text())["id"]
REPOSITORY_MODULE = "radiosity_source"


def import_bpy() -> ModuleType:
    """``bpy``, with Blender's user resources in a temporary directory (removed at exit)."""
    if "bpy" not in sys.modules:
        resources = tempfile.mkdtemp(prefix="radiosity-blender-user-")
        os.environ["BLENDER_USER_RESOURCES"] = resources
        atexit.register(shutil.rmtree, resources, ignore_errors=True)
    import bpy

    return bpy


def enable(module_name: str) -> ModuleType:
    """Enable an extension add-on as Blender's preferences do; Blender's own error if it fails."""
    import addon_utils
    import bpy

    errors: list[BaseException] = []
    module = addon_utils.enable(module_name, default_set=True, handle_error=errors.append)
    if errors:
        raise RuntimeError(f"enabling {module_name} failed") from errors[0]
    is_enabled, is_loaded = addon_utils.check(module_name)
    if module is None or not (is_enabled and is_loaded) or module_name not in bpy.context.preferences.addons:
        raise RuntimeError(f"{module_name} did not enable")
    return module


def disable(module_name: str) -> None:
    import addon_utils
    import bpy

    addon_utils.disable(module_name, default_set=True)
    if module_name in bpy.context.preferences.addons:
        raise RuntimeError(f"{module_name} is still enabled")


def add_source_repository(repo_dir: Path):
    """Symlink the checkout into ``repo_dir`` under the manifest id and register that directory
    as a user extension repository; returns the repository."""
    import bpy

    (repo_dir / EXTENSION_ID).symlink_to(ROOT, target_is_directory=True)
    return bpy.context.preferences.extensions.repos.new(
        name="radiosity source tree", module=REPOSITORY_MODULE, custom_directory=str(repo_dir), source="USER"
    )


def blender_with_extension() -> tuple[ModuleType, ModuleType]:
    """Factory settings, then this checkout enabled as an extension: (bpy, the package)."""
    bpy = import_bpy()
    bpy.ops.wm.read_factory_settings(use_empty=True)
    repo_dir = Path(tempfile.mkdtemp(prefix="radiosity-repo-"))
    atexit.register(shutil.rmtree, repo_dir, ignore_errors=True)
    repo = add_source_repository(repo_dir)
    module_name = f"bl_ext.{repo.module}.{EXTENSION_ID}"
    enable(module_name)
    return bpy, sys.modules[module_name]
