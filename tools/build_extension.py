"""Build the installable extension with Blender's own extension tool, run from the bpy wheel (no
Blender binary), and validate what it built.

    python tools/build_extension.py [--output-dir build] [--no-split]

Run it with a Python that has bpy installed (``make extension`` uses .venv); it imports neither bpy
nor anything outside the standard library, and runs Blender's ``blender_ext.py`` and pip as
subprocesses.

1. Wheels: the embreex wheel pinned in pyproject.toml, for every platform of blender_manifest.toml
   and every Python a supported Blender runs (3.11: Blender 4.2 to 5.0; 3.13: Blender 5.1 and
   newer), is downloaded once into wheels/ (git-ignored) and reused after that.
2. Staging: the checkout is copied to <output-dir>/stage/radiosity/ (without .git, the virtualenvs,
   build/ and wheels/), the wheels beside it, and its blender_manifest.toml gets the
   ``wheels = [...]`` list.
3. ``blender_ext.py build`` (one zip per platform unless --no-split), then ``blender_ext.py
   validate`` on every zip; the zips' contents are listed.

Why the committed blender_manifest.toml lists no wheels, and this script adds them to a staged copy:

- A fresh clone has no wheels/ (about 90 MB of binaries are not committed), and ``blender_ext.py
  build`` stops at the first listed wheel that is missing ("Error adding to archive, file not
  found"), so a committed list would break the plain build command until something downloads them.
  (``blender_ext.py validate`` on the source directory does not look for the files.)
- When the checkout itself is loaded as an extension (the add-on tests, a developer's symlink into
  Blender), Blender skips listed wheels that are absent without a word (``pkg_wheel_filter`` in
  bl_pkg/bl_extension_ops.py, 4.2 and 5.0) and the extension still enables: a committed list would
  not break that, but it would promise Embree that is not there.
- The list would repeat the embreex pin of pyproject.toml and the platforms of the manifest; here
  it is derived from both, so the three cannot drift apart.

Known limit: Blender 4.2.0 does not filter wheels by Python version (4.2.13 and later do, and 5.0):
given the cp311 and cp313 wheels of one platform and version it extracts the file name that sorts
last (cp313; ``wheel_list_deduplicate_as_skip_set`` in _bpy_internal/extensions/wheel_manager.py),
whose binaries Python 3.11 cannot import, so Blender 4.2.0 bakes with the core's NumPy ray caster
instead of Embree (tests/addon/test_extension_package.py shows it as a warning). Leaving
cp313 out would fix them but make Blender 5.1 and newer (Python 3.13) refuse the extension as
incompatible; separate packages per Python version (blender_version_max = "5.1.0" on the cp311
one) would fix both at the price of twice as many files to publish.
"""

from __future__ import annotations

import argparse
import fnmatch
import os
import re
import shutil
import subprocess
import sys
import tomllib
import zipfile
from pathlib import Path
from typing import NamedTuple

ROOT = Path(__file__).resolve().parent.parent
WHEELS_DIR = ROOT / "wheels"

# Python versions of the supported Blenders: 3.11 (Blender 4.2 to 5.0), 3.13 (Blender 5.1 and newer).
PYTHON_VERSIONS = ("3.11", "3.13")

# Blender platform -> (pip --platform tag, glob matching the wheel's platform tag). The macOS
# wheels of embreex 4.4.0.post1 need macOS 13; Blender runs on older macOS, where the import fails
# and the core falls back to its NumPy ray caster.
PLATFORM_TAGS = {
    "linux-x64": ("manylinux_2_28_x86_64", "*manylinux*_x86_64"),
    "windows-x64": ("win_amd64", "win_amd64"),
    "macos-arm64": ("macosx_13_0_arm64", "macosx_*_arm64"),
    "macos-x64": ("macosx_13_0_x86_64", "macosx_*_x86_64"),
}

# Top-level entries of the checkout never staged (Blender's paths_exclude_pattern, from the
# committed manifest, decides the rest).
STAGE_SKIP = {".git", "build", "wheels", "__pycache__", ".pytest_cache"}


class BuildError(RuntimeError):
    """The extension could not be built; the message says why."""


class WheelsUnavailable(BuildError):
    """A wheel could not be downloaded (no network, or no such wheel on the package index)."""


class BlenderTools(NamedTuple):
    blender_ext: Path  # bl_pkg/cli/blender_ext.py
    valid_tags: Path  # _bpy_internal/extensions/tags.py
    version: str  # "5.0"


def blender_tools() -> BlenderTools:
    """Blender's extension tool inside the installed bpy wheel, found without importing bpy."""
    import importlib.util

    spec = importlib.util.find_spec("bpy")
    if spec is None or not spec.submodule_search_locations:
        raise BuildError(f"bpy is not installed for {sys.executable}: run `make extension` (it uses .venv)")
    package = Path(list(spec.submodule_search_locations)[0])
    versions = sorted(p for p in package.iterdir() if re.fullmatch(r"\d+\.\d+", p.name) and (p / "scripts").is_dir())
    if len(versions) != 1:
        raise BuildError(f"expected one <version>/scripts directory in {package}, found {versions}")
    scripts = versions[0] / "scripts"
    tools = BlenderTools(
        scripts / "addons_core" / "bl_pkg" / "cli" / "blender_ext.py",
        scripts / "modules" / "_bpy_internal" / "extensions" / "tags.py",
        versions[0].name,
    )
    for path in tools[:2]:
        if not path.is_file():
            raise BuildError(f"{path} not found in the bpy wheel")
    return tools


def embreex_requirement() -> tuple[str, str]:
    """(name, version) of the embreex pin in pyproject.toml."""
    dependencies = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["dependencies"]
    for requirement in dependencies:
        name, _, version = requirement.partition("==")
        if name.strip() == "embreex" and version:
            return "embreex", version.strip()
    raise BuildError("pyproject.toml pins no embreex==<version>")


def manifest_platforms() -> list[str]:
    manifest = tomllib.loads((ROOT / "blender_manifest.toml").read_text())
    platforms = manifest.get("platforms") or []
    unknown = sorted(set(platforms) - set(PLATFORM_TAGS))
    if not platforms or unknown:
        raise BuildError(f"blender_manifest.toml platforms {platforms}: no wheel tag known for {unknown}")
    return platforms


def find_wheel(name: str, version: str, python: str, platform: str, directory: Path = WHEELS_DIR) -> Path | None:
    """The downloaded wheel for this Python ("3.11") and Blender platform, or None."""
    cp = "cp" + python.replace(".", "")
    pattern = f"{name}-{version}-{cp}-{cp}-{PLATFORM_TAGS[platform][1]}.whl"
    found = sorted(p for p in directory.glob(f"{name}-{version}-*.whl") if fnmatch.fnmatch(p.name, pattern))
    return found[-1] if found else None


def ensure_wheels(directory: Path = WHEELS_DIR, quiet: bool = False) -> list[Path]:
    """Every wheel the extension bundles, downloaded into ``directory`` unless already there.

    Raises WheelsUnavailable naming each (platform, Python) pip could not get."""
    name, version = embreex_requirement()
    directory.mkdir(exist_ok=True)
    wheels, missing = [], []
    for platform in manifest_platforms():
        for python in PYTHON_VERSIONS:
            wheel = find_wheel(name, version, python, platform, directory)
            if wheel is None:
                command = [
                    # short timeouts: without a network the eight downloads give up in minutes, not hours
                    sys.executable, "-m", "pip", "download", "--quiet", "--disable-pip-version-check",
                    "--timeout", "30", "--retries", "1",
                    "--only-binary=:all:", "--no-deps", "--implementation", "cp",
                    "--platform", PLATFORM_TAGS[platform][0], "--python-version", python,
                    "--dest", str(directory), f"{name}=={version}",
                ]
                if not quiet:
                    print(f"downloading {name}=={version} for {platform}, Python {python}", flush=True)
                result = subprocess.run(command, capture_output=True, text=True)
                wheel = find_wheel(name, version, python, platform, directory)
                if wheel is None:
                    last = (result.stderr.strip().splitlines() or ["(no output)"])[-1]
                    missing.append(f"{platform} / Python {python}: {last}")
                    continue
            wheels.append(wheel)
    if missing:
        raise WheelsUnavailable(f"{name}=={version} wheels not available:\n  " + "\n  ".join(missing))
    return wheels


def stage(output_dir: Path, wheels: list[Path]) -> Path:
    """A copy of the checkout under output_dir/stage/<id>/ whose manifest lists ``wheels``."""
    manifest_text = (ROOT / "blender_manifest.toml").read_text()
    manifest = tomllib.loads(manifest_text)
    if "wheels" in manifest:
        raise BuildError("blender_manifest.toml lists wheels itself; this script adds them (see its docstring)")
    source = output_dir / "stage" / manifest["id"]
    if source.exists():
        shutil.rmtree(source)

    skip_top = set(STAGE_SKIP)
    if ROOT in output_dir.parents:  # never copy the output into itself
        skip_top.add(output_dir.relative_to(ROOT).parts[0])

    def skip(directory: str, names: list[str]) -> set[str]:
        top = Path(directory).resolve() == ROOT
        return {n for n in names if n == "__pycache__" or (top and (n in skip_top or n.startswith(".venv")))}

    shutil.copytree(ROOT, source, ignore=skip, symlinks=True)
    (source / "wheels").mkdir()
    for wheel in wheels:
        try:
            os.link(wheel, source / "wheels" / wheel.name)
        except OSError:
            shutil.copy2(wheel, source / "wheels" / wheel.name)

    # Top-level keys must come before the first [table] of the TOML file.
    listing = "".join(f'  "./wheels/{w.name}",\n' for w in wheels)
    wheels_toml = (
        "# Added by tools/build_extension.py: the embreex wheels bundled with the extension.\n"
        f"wheels = [\n{listing}]\n\n"
    )
    table = re.search(r"^\[", manifest_text, re.MULTILINE)
    at = table.start() if table else len(manifest_text)
    (source / "blender_manifest.toml").write_text(manifest_text[:at] + wheels_toml + manifest_text[at:])
    return source


def run_blender_ext(tools: BlenderTools, *args: str) -> str:
    command = [sys.executable, str(tools.blender_ext), *args]
    result = subprocess.run(command, capture_output=True, text=True)
    output = result.stdout + result.stderr
    if result.returncode != 0:
        raise BuildError(f"{' '.join(command)} failed ({result.returncode}):\n{output}")
    return output


def build(output_dir: Path, split_platforms: bool = True, quiet: bool = False) -> list[Path]:
    """Download the wheels if needed, stage, build and validate; returns the built zips."""
    output_dir = output_dir.resolve()
    output_dir.mkdir(parents=True, exist_ok=True)
    tools = blender_tools()
    wheels = ensure_wheels(quiet=quiet)
    source = stage(output_dir, wheels)
    manifest = tomllib.loads((source / "blender_manifest.toml").read_text())
    stem = f"{manifest['id']}-{manifest['version']}"
    for old in output_dir.glob(f"{stem}*.zip"):
        old.unlink()

    args = ["build", "--source-dir", str(source), "--output-dir", str(output_dir)]
    args += ["--valid-tags", str(tools.valid_tags)]
    if split_platforms:
        args.append("--split-platforms")
    output = run_blender_ext(tools, *args)
    if not quiet:
        print(output.rstrip())
    zips = sorted(output_dir.glob(f"{stem}*.zip"))
    if not zips:
        raise BuildError(f"blender_ext.py build wrote no {stem}*.zip into {output_dir}:\n{output}")
    for path in zips:
        run_blender_ext(tools, "validate", str(path), "--valid-tags", str(tools.valid_tags))
        if not quiet:
            print(f"\n{path} ({path.stat().st_size / 1e6:.1f} MB), valid for Blender's extension tool {tools.version}:")
            with zipfile.ZipFile(path) as archive:
                for info in archive.infolist():
                    print(f"  {info.file_size:>10}  {info.filename}")
    return zips


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--output-dir", type=Path, default=ROOT / "build", help="where the zips go (default: build/)")
    parser.add_argument("--no-split", dest="split_platforms", action="store_false",
                        help="one zip with the wheels of every platform (about 90 MB) instead of one zip per platform")
    args = parser.parse_args(argv)
    try:
        build(args.output_dir, split_platforms=args.split_platforms)
    except BuildError as error:
        print(error, file=sys.stderr)
        return 2 if isinstance(error, WheelsUnavailable) else 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
