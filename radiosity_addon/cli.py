"""``blender -b [FILE.blend] -c radiosity [options]``: bake the open file, or many files, headless.

A thin argparse wrapper (``main``) over ``run``, which bakes one file and which scripts and tests
call directly through the ``bpy`` module; ``batch`` plans where many files go and records what
became of each. Options override ``scene.radiosity`` and are saved with the baked file, so the file
says how it was baked. An input is never overwritten unless ``--overwrite``. One file that cannot
be baked does not stop the others. Exit codes: 0 every file baked; 2 bad arguments, or a file
refused as bad input (one line on stderr each); 1 an unexpected error in any file (with its trace).
Progress goes to stderr as plain lines, at most one a second, none that a render farm reads as
render output ("Fra:", "Saved: '...'").
"""

from __future__ import annotations

import argparse
import os
import sys
import time
import tomllib
import traceback
from datetime import datetime, timezone
from pathlib import Path

import bpy

from ..core.settings import KNOB, PRESET_KNOBS, PRESETS, add_knob_options, given_knobs
from . import batch
from .baking import Outcome, finish, prepare, run_straight
from .batch import BAKED, FAILED, REFUSED, FileResult, Plan, UsageError
from .preview import render_colours

COMMAND = "radiosity"
# How the colour attribute stores the colours: scene.radiosity's property -> the option setting it.
STORAGE_OPTIONS = {"color_type": "--color-type", "color_domain": "--color-domain", "exposure": "--exposure",
                   "tone": "--tone"}
# A bake's figures kept in the JSON summary.
SUMMARY_STATS = ("triangles", "patches", "nodes", "lights")


class _Parser(argparse.ArgumentParser):
    def error(self, message):
        raise UsageError(message)


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(prog=f"blender -b [FILE.blend] -c {COMMAND}",
                     description=__doc__.split("\n\n")[0].replace("``", ""))
    files = parser.add_argument_group("files")
    files.add_argument("--input", metavar="FILE", nargs="+", action="extend",
                       help="open these .blend files (paths or quoted globs such as 'levels/**/*.blend') and bake "
                            "each in turn (default: the open file)")
    files.add_argument("-o", "--output", metavar="FILE.blend", help="save the baked file here (one input)")
    files.add_argument("--output-dir", metavar="DIR", help="save each baked file into DIR, named after its input")
    files.add_argument("--suffix", metavar="TEXT", help="name each baked file after its input plus TEXT "
                       "(scene.blend -> scene_baked.blend with --suffix _baked), beside it or in --output-dir")
    files.add_argument("--overwrite", action="store_true", help="save each baked file over its input")
    files.add_argument("--render", metavar="FILE.png", nargs="?", const="",
                       help="also render the baked colours from the scene's camera into FILE.png (one input), "
                            "or, given alone, into a picture beside each baked file")
    files.add_argument("--summary", metavar="FILE.json", help="write what became of each file as JSON "
                       "(rewritten after each file)")
    files.add_argument("-q", "--quiet", action="store_true", help="no progress on stderr")
    parser.add_argument("--preset", choices=[p.lower() for p in PRESETS] + ["custom"],
                        help=f"sets {', '.join(PRESET_KNOBS)}; setting one of them makes the preset custom")
    parser.add_argument("--lighting-only", action="store_true", help="write the lighting, not the full radiosity")
    parser.add_argument("--attribute", metavar="NAME", help="colour attribute to write (default: the file's, "
                        "'Radiosity' when unset)")
    parser.add_argument("--light-groups", action="store_true",
                        help="also write each light group's light into '<attribute> <group>' (re-solves: the "
                        "geometry work is done once)")
    for name, flag in STORAGE_OPTIONS.items():
        prop = bpy.types.Scene.bl_rna.properties["radiosity"].fixed_type.properties[name]
        if prop.type == "ENUM":
            parser.add_argument(flag, choices=[item.identifier.lower() for item in prop.enum_items],
                                help=f"{prop.description} (default: the file's)")
        else:
            parser.add_argument(flag, type=float, metavar="STOPS", help=f"{prop.description} (default: the file's)")
    add_knob_options(parser)
    return parser


def main(argv: list[str]) -> int:
    """The ``-c radiosity`` command: bakes every input, then exits with ``batch.exit_code``."""
    started = time.perf_counter()
    try:
        options = build_parser().parse_args(argv)
        inputs = batch.expand_inputs(options.input) if options.input else [None]
        plans = batch.plan(inputs, options.output, options.output_dir, options.suffix, options.overwrite,
                           options.render, bpy.data.filepath)
        knobs = given_knobs(options)
        _check_preset(options.preset, knobs)
        settings = dict(preset=options.preset, knobs=knobs, properties=_properties(options))
    except UsageError as error:
        print(f"{COMMAND}: error: {error}", file=sys.stderr)
        return 2
    about = {"command": COMMAND, "argv": list(argv), "extension": _version(), "blender": bpy.app.version_string,
             "started": datetime.now(timezone.utc).isoformat(timespec="seconds")}
    results: list[FileResult] = []
    for index, item in enumerate(plans):
        label = f"[{index + 1}/{len(plans)}] {os.path.basename(item.input)}: " if len(plans) > 1 else ""
        results.append(_bake_reporting(item, settings, label, quiet=options.quiet))
        if options.summary:
            batch.write_summary(options.summary, results, {**about, "seconds": time.perf_counter() - started})
    if len(plans) > 1:
        print(f"{COMMAND}: {batch.summary_line(results)}", flush=True)
    return batch.exit_code(results)


def _version() -> str:
    """The extension's version, from its manifest."""
    manifest = Path(__file__).resolve().parents[1] / "blender_manifest.toml"
    return tomllib.loads(manifest.read_text(encoding="utf-8"))["version"]


def _bake_reporting(item: Plan, settings: dict, label: str, quiet: bool) -> FileResult:
    """Bake one planned file, print its outcome (or its error) and record it; never raises but
    for an interrupt."""
    start = time.perf_counter()
    try:
        outcome, stats = _bake(item, **settings, quiet=quiet, label=label)
    except (UsageError, ValueError) as error:
        print(f"{COMMAND}: {label}error: {error}", file=sys.stderr, flush=True)
        return FileResult(item.input, item.output, item.render, REFUSED, str(error), time.perf_counter() - start)
    except Exception as error:  # the command's contract: any other failure is exit code 1, with its trace
        traceback.print_exc()
        print(f"{COMMAND}: {label}unexpected error (see above)", file=sys.stderr, flush=True)
        return FileResult(item.input, item.output, item.render, FAILED, f"{type(error).__name__}: {error}",
                          time.perf_counter() - start)
    for note in outcome.notes:
        print(f"{COMMAND}: {label}note: {note}", file=sys.stderr)
    print(f"{COMMAND}: {label}{outcome.summary}", flush=True)
    return FileResult(item.input, item.output, item.render, BAKED, outcome.summary, time.perf_counter() - start,
                      outcome.notes, stats)


def run(input: str | None = None, output: str | None = None, overwrite: bool = False, render: str | None = None,
        preset: str | None = None, knobs: dict | None = None, properties: dict | None = None,
        quiet: bool = True) -> Outcome:
    """Bake the open (or ``input``) file's scene, with ``knobs`` (core knob names: None for
    auto or no limit) and ``properties`` (``scene.radiosity``'s own, such as ``output="LIGHTING"``
    or ``color_type="BYTE_COLOR"``) over its settings, then save it to ``output`` (or over itself
    with ``overwrite``) and render the colours to ``render``. ValueError for bad input; the open
    file is not saved anywhere unless asked."""
    [item] = batch.plan([input], output, None, None, overwrite, render, bpy.data.filepath)
    _check_preset(preset, knobs or {})
    outcome, _ = _bake(item, preset, knobs or {}, properties or {}, quiet)
    return outcome


def _bake(item: Plan, preset: str | None, knobs: dict, properties: dict, quiet: bool,
          label: str = "") -> tuple[Outcome, dict]:
    if item.input is not None:
        if not os.path.isfile(item.input):
            raise UsageError(f"no such file: {item.input}")
        try:
            bpy.ops.wm.open_mainfile(filepath=item.input, load_ui=False)
        except RuntimeError as error:  # Blender's own words on a file it cannot read
            raise UsageError(f"cannot open {item.input}: {str(error).strip().removeprefix('Error: ')}") from None
    source = bpy.data.filepath
    scene = bpy.context.scene
    _apply(scene.radiosity, preset, knobs, properties)
    prepared = prepare(scene)
    baked = run_straight(prepared, echo=not quiet, label=label)
    outcome = finish(prepared, baked)
    result = baked.result
    scene.radiosity.last_report = outcome.summary
    if item.output is not None:
        os.makedirs(os.path.dirname(os.path.abspath(item.output)), exist_ok=True)
        bpy.ops.wm.save_as_mainfile(filepath=item.output, copy=item.output != source)
    if item.render is not None:
        os.makedirs(os.path.dirname(os.path.abspath(item.render)), exist_ok=True)
        render_colours(scene, prepared.attribute, os.path.abspath(item.render))
    stats = {name: result.stats[name] for name in SUMMARY_STATS}
    stats.update(seconds=result.stats["seconds"]["total"], error_estimate=result.stats["error_estimate"]["total"],
                 converged=result.stats["converged"], objects=len(outcome.written))
    return outcome, stats


def _check_preset(preset: str | None, knobs: dict) -> None:
    """UsageError when a knob is given that the chosen preset fixes."""
    fixed = [name for name in knobs if name in PRESET_KNOBS]
    if fixed and preset not in (None, "custom"):
        raise UsageError(f"--preset {preset} fixes {KNOB[fixed[0]].flag}: leave it out, or use --preset custom")


def _properties(options: argparse.Namespace) -> dict:
    """The ``scene.radiosity`` properties the command line sets (beyond the knobs)."""
    properties = {"output": "LIGHTING"} if options.lighting_only else {}
    if options.light_groups:
        properties["light_groups"] = True
    if options.attribute is not None:
        properties["attribute_name"] = options.attribute
    for name in STORAGE_OPTIONS:
        value = getattr(options, name)
        if value is not None:
            properties[name] = value.upper() if isinstance(value, str) else value
    return properties


def _apply(settings, preset: str | None, knobs: dict, properties: dict) -> None:
    """Command-line options onto ``scene.radiosity`` (so the saved file records them)."""
    if preset is not None:
        settings.preset = preset.upper()
    if any(name in PRESET_KNOBS for name in knobs):
        settings.preset = "CUSTOM"
    for name, value in knobs.items():
        try:
            settings.set_knob(name, value)
        except ValueError as error:
            raise UsageError(str(error)) from None
    for name, value in properties.items():
        setattr(settings, name, value)


_handle = None


def register() -> None:
    global _handle
    _handle = bpy.utils.register_cli_command(COMMAND, main)


def unregister() -> None:
    global _handle
    if _handle is not None:
        bpy.utils.unregister_cli_command(_handle)
        _handle = None
