"""``blender -b scene.blend -c radiosity [options]``: bake the open file headless.

A thin argparse wrapper (``main``) over ``run``, which scripts and tests call directly through
the ``bpy`` module. Options override ``scene.radiosity`` and are saved with the baked file, so
the file says how it was baked. The input file is never overwritten unless ``--overwrite``.
Exit codes: 0 baked, 2 bad arguments or input (one line on stderr), 1 unexpected error.
"""

from __future__ import annotations

import argparse
import os
import sys
import traceback

import bpy

from ..core.settings import KNOB, PRESET_KNOBS, PRESETS, add_knob_options, given_knobs
from .baking import Outcome, finish, prepare, run_straight
from .preview import render_colours

COMMAND = "radiosity"


class UsageError(ValueError):
    """Bad arguments or input: exit code 2."""


class _Parser(argparse.ArgumentParser):
    def error(self, message):
        raise UsageError(message)


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(prog=f"blender -b FILE.blend -c {COMMAND}", description=__doc__.split("\n\n")[0])
    parser.add_argument("--input", metavar="FILE.blend", help="open this file first (default: the open file)")
    parser.add_argument("-o", "--output", metavar="FILE.blend", help="save the baked file here")
    parser.add_argument("--overwrite", action="store_true", help="save the baked file over the input file")
    parser.add_argument("--render", metavar="FILE.png", help="also render the baked colours from the scene's camera")
    parser.add_argument("--preset", choices=[p.lower() for p in PRESETS] + ["custom"],
                        help=f"sets {', '.join(PRESET_KNOBS)}; setting one of them makes the preset custom")
    parser.add_argument("--lighting-only", action="store_true", help="write the lighting, not the full radiosity")
    parser.add_argument("--attribute", metavar="NAME", help="colour attribute to write (default: the file's, "
                        "'Radiosity' when unset)")
    parser.add_argument("-q", "--quiet", action="store_true", help="no progress on stderr")
    add_knob_options(parser)
    return parser


def main(argv: list[str]) -> int:
    """The ``-c radiosity`` command: 0 on success, 2 on bad arguments or input, 1 otherwise."""
    try:
        options = build_parser().parse_args(argv)
        own = {name: value for name, value in vars(options).items() if name not in KNOB}
        outcome = run(**own, knobs=given_knobs(options))
    except (UsageError, ValueError) as error:
        print(f"{COMMAND}: error: {error}", file=sys.stderr)
        return 2
    except Exception:  # the command's contract: any other failure is exit code 1, with its trace
        traceback.print_exc()
        print(f"{COMMAND}: unexpected error (see above)", file=sys.stderr)
        return 1
    for note in outcome.notes:
        print(f"{COMMAND}: note: {note}", file=sys.stderr)
    print(f"{COMMAND}: {outcome.summary}")
    return 0


def run(input: str | None = None, output: str | None = None, overwrite: bool = False, render: str | None = None,
        preset: str | None = None, lighting_only: bool = False, attribute: str | None = None, quiet: bool = True,
        knobs: dict | None = None) -> Outcome:
    """Bake the open (or ``input``) file's scene, with ``knobs`` (core knob names: None for
    auto or no limit) over its settings, then save it to ``output`` (or over itself with
    ``overwrite``) and render the colours to ``render``. ValueError for bad input; the open file
    is not saved anywhere unless asked."""
    if input is not None:
        if not os.path.isfile(input):
            raise UsageError(f"no such file: {input}")
        bpy.ops.wm.open_mainfile(filepath=input, load_ui=False)
    source = bpy.data.filepath
    target = _target(source, output, overwrite, render)
    scene = bpy.context.scene
    _apply(scene.radiosity, preset, knobs or {}, lighting_only, attribute)
    depsgraph = bpy.context.evaluated_depsgraph_get()
    prepared = prepare(scene, depsgraph)
    result = run_straight(prepared, echo=not quiet)
    outcome = finish(prepared, result, depsgraph)
    scene.radiosity.last_report = outcome.summary
    if target is not None:
        os.makedirs(os.path.dirname(os.path.abspath(target)), exist_ok=True)
        bpy.ops.wm.save_as_mainfile(filepath=target, copy=target != source)
    if render is not None:
        os.makedirs(os.path.dirname(os.path.abspath(render)), exist_ok=True)
        render_colours(scene, prepared.attribute, os.path.abspath(render))
    return outcome


def _target(source: str, output: str | None, overwrite: bool, render: str | None) -> str | None:
    """Where the baked file goes; UsageError when that would overwrite the input unasked."""
    if overwrite:
        if output is not None:
            raise UsageError("give either --output or --overwrite, not both")
        if not source:
            raise UsageError("--overwrite needs a saved file to overwrite")
        return source
    if output is None:
        if render is None:
            raise UsageError("nothing would be kept: give --output FILE.blend, --overwrite or --render FILE.png")
        return None
    if source and os.path.abspath(output) == os.path.abspath(source):
        raise UsageError(f"--output is the input file {source}: add --overwrite to replace it")
    if not output.endswith(".blend"):
        raise UsageError(f"--output must be a .blend file, got {output}")
    return output


def _apply(settings, preset: str | None, knobs: dict, lighting_only: bool, attribute: str | None) -> None:
    """Command-line options onto ``scene.radiosity`` (so the saved file records them)."""
    if preset is not None:
        settings.preset = preset.upper()
    preset_set = [name for name in knobs if name in PRESET_KNOBS]
    if preset_set:
        if preset not in (None, "custom"):
            raise UsageError(f"--preset {preset} fixes {KNOB[preset_set[0]].flag}: leave it out, or use --preset custom")
        settings.preset = "CUSTOM"
    for name, value in knobs.items():
        try:
            settings.set_knob(name, value)
        except ValueError as error:
            raise UsageError(str(error)) from None
    if lighting_only:
        settings.output = "LIGHTING"
    if attribute is not None:
        settings.attribute_name = attribute


_handle = None


def register() -> None:
    global _handle
    _handle = bpy.utils.register_cli_command(COMMAND, main)


def unregister() -> None:
    global _handle
    if _handle is not None:
        bpy.utils.unregister_cli_command(_handle)
        _handle = None

