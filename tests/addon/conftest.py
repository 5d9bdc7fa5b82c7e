"""The add-on tests run inside the bpy module, with the checkout loaded as a real extension.

Run them in a pytest process of their own (``make test`` does): bpy can be imported once per
process, and tests/core must not see it.

- Blender's user resources (preferences, extension repositories, the ``.local`` site-packages that
  extension wheels are extracted into) go to a temporary directory, never to ~/.config/blender.
- Once per session: ``read_factory_settings`` (it also resets the preferences, so it comes first),
  then the checkout is symlinked into a temporary directory under the manifest id, added as a user
  extension repository and enabled with ``addon_utils.enable("bl_ext.<repo module>.radiosity")``,
  so its modules import each other exactly as in an installed extension.
- Before each test: an empty file (``read_homefile(use_factory_startup=True, use_empty=True)``);
  the extension stays enabled.

Fixtures: ``addon`` (the enabled extension package: ``addon.radiosity_addon``, ``addon.core``),
``addon_module_name`` (``"bl_ext.<repo>.radiosity"``), and ``extension_switch`` (enable/disable
an extension by module name, for tests that load another copy: test_extension_package.py).
"""

from __future__ import annotations

import os
import sys
from types import ModuleType
from typing import Callable, NamedTuple

import pytest

from tools.source_extension import EXTENSION_ID, add_source_repository, import_bpy
from tools.source_extension import disable as _disable_extension
from tools.source_extension import enable as _enable_extension

bpy = import_bpy()  # Blender's user resources in a temporary directory, before anything else


@pytest.fixture(scope="session")
def addon_module_name(tmp_path_factory: pytest.TempPathFactory) -> str:
    bpy.ops.wm.read_factory_settings(use_empty=True)
    repo = add_source_repository(tmp_path_factory.mktemp("extension-repo"))
    repos = bpy.context.preferences.extensions.repos
    module_name = f"bl_ext.{repo.module}.{EXTENSION_ID}"
    _enable_extension(module_name)
    yield module_name
    if module_name in bpy.context.preferences.addons:
        _disable_extension(module_name)
    repos.remove(repo)


@pytest.fixture(scope="session")
def addon(addon_module_name: str) -> ModuleType:
    """The extension's package as Blender imported it: ``addon.radiosity_addon``, ``addon.core``..."""
    return sys.modules[addon_module_name]


@pytest.fixture(autouse=True)
def empty_file(addon_module_name: str) -> None:
    """A fresh empty file for every test, once the extension is enabled (which it stays)."""
    bpy.ops.wm.read_homefile(use_factory_startup=True, use_empty=True)


class ExtensionSwitch(NamedTuple):
    enable: Callable[[str], ModuleType]
    disable: Callable[[str], None]


@pytest.fixture(scope="session")
def extension_switch() -> ExtensionSwitch:
    return ExtensionSwitch(_enable_extension, _disable_extension)


_exit_status = [0]


def pytest_sessionfinish(session: pytest.Session, exitstatus: int) -> None:
    _exit_status[0] = int(exitstatus)


def pytest_unconfigure(config: pytest.Config) -> None:
    """Leave without Blender's exit handlers once pytest has reported. The bpy 4.2.0 module
    crashes (SIGSEGV) at interpreter exit after an add-on has used register_cli_command, even
    when it unregistered everything: ``python -c "import bpy; bpy.utils.register_cli_command('x',
    lambda argv: 0)"`` exits with 139 (5.0.1 exits cleanly). Blender itself, not the bpy module,
    runs users' -c commands, so this only concerns the test process."""
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(_exit_status[0])
