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

from ..core.settings import PRESETS
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
    parser.add_argument("--preset", choices=[p.lower() for p in PRESETS] + ["custom"])
    parser.add_argument("--method", choices=["raycast", "hemicube"])
    parser.add_argument("--solver", choices=["progressive", "jacobi", "gauss_seidel"])
    parser.add_argument("--patch-size", type=float, metavar="LENGTH", help="(sets --preset custom)")
    parser.add_argument("--rays", type=int, help="rays per form factor: 1, 4, 9, 16, 36, 64, 144 or 256 "
                        "(sets --preset custom)")
    parser.add_argument("--resolution", type=int, help="hemicube resolution (sets --preset custom)")
    parser.add_argument("--tolerance", type=float, help="(sets --preset custom)")
    parser.add_argument("--max-shots", type=int, metavar="N", help="progressive: stop after N shots, the rest as the "
                        "ambient term or by Monte Carlo (0: until the tolerance is met; with Monte Carlo, once "
                        "every emitter has shot)")
    parser.add_argument("--monte-carlo-rays", metavar="N", help="progressive: carry the light not yet shot by "
                        "Monte Carlo with N final-gather rays per vertex: 16, 64, 256 or 1024 (0: the ambient "
                        "term; auto: 64 for large scenes, the default)")
    parser.add_argument("--lighting-only", action="store_true", help="write the lighting, not the full radiosity")
    parser.add_argument("--attribute", metavar="NAME", help="colour attribute to write (default: the file's, "
                        "'Radiosity' when unset)")
    parser.add_argument("-q", "--quiet", action="store_true", help="no progress on stderr")
    return parser


def main(argv: list[str]) -> int:
    """The ``-c radiosity`` command: 0 on success, 2 on bad arguments or input, 1 otherwise."""
    try:
        options = build_parser().parse_args(argv)
        outcome = run(**vars(options))
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
        preset: str | None = None, method: str | None = None, solver: str | None = None,
        patch_size: float | None = None, rays: int | None = None, resolution: int | None = None,
        tolerance: float | None = None, max_shots: int | None = None, monte_carlo_rays: str | None = None,
        lighting_only: bool = False, attribute: str | None = None, quiet: bool = True) -> Outcome:
    """Bake the open (or ``input``) file's scene, then save it to ``output`` (or over itself
    with ``overwrite``) and render the colours to ``render``. ValueError for bad input; the
    open file is not saved anywhere unless asked."""
    if input is not None:
        if not os.path.isfile(input):
            raise UsageError(f"no such file: {input}")
        bpy.ops.wm.open_mainfile(filepath=input, load_ui=False)
    source = bpy.data.filepath
    target = _target(source, output, overwrite, render)
    scene = bpy.context.scene
    _apply(scene.radiosity, preset, method, solver, patch_size, rays, resolution, tolerance, max_shots,
           monte_carlo_rays, lighting_only, attribute)
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


def _apply(settings, preset, method, solver, patch_size, rays, resolution, tolerance, max_shots, monte_carlo_rays,
           lighting_only, attribute):
    """Command-line options onto ``scene.radiosity`` (so the saved file records them)."""
    if patch_size is not None and not patch_size > 0:
        raise UsageError(f"--patch-size must be a positive length, got {patch_size}")
    if tolerance is not None and not 0 < tolerance < 0.5:
        raise UsageError(f"--tolerance must be in (0, 0.5), got {tolerance}")
    if resolution is not None and (resolution < 2 or resolution % 2):
        raise UsageError(f"--resolution must be an even number of pixels >= 2, got {resolution}")
    knobs = {"patch_size": patch_size, "hemicube_resolution": resolution, "tolerance": tolerance}
    if preset is not None:
        settings.preset = preset.upper()
    if any(value is not None for value in (patch_size, rays, resolution, tolerance)):
        if preset not in (None, "custom"):
            raise UsageError(f"--preset {preset} fixes the knobs: leave it out, or use --preset custom")
        settings.preset = "CUSTOM"
    for name, value in knobs.items():
        if value is not None:
            setattr(settings, name, value)
    if rays is not None:
        _set_choice(settings, "rays", rays, "--rays")
    if max_shots is not None:
        if max_shots < 0:
            raise UsageError(f"--max-shots must be 0 (no limit) or more, got {max_shots}")
        settings.max_shots = max_shots
    if monte_carlo_rays is not None:
        _set_choice(settings, "monte_carlo_rays", monte_carlo_rays, "--monte-carlo-rays")
    if method is not None:
        settings.method = method
    if solver is not None:
        settings.solver = solver
    if lighting_only:
        settings.output = "LIGHTING"
    if attribute is not None:
        settings.attribute_name = attribute


def _set_choice(settings, name: str, value, option: str) -> None:
    """Set the enum ``name`` to ``value`` (a number or a name, in any case), or say which values
    ``option`` takes."""
    choices = [item.identifier for item in settings.bl_rna.properties[name].enum_items]
    if str(value).upper() not in choices:
        raise UsageError(f"{option} must be one of {', '.join(c.lower() for c in choices)}, got {value}")
    setattr(settings, name, str(value).upper())


_handle = None


def register() -> None:
    global _handle
    _handle = bpy.utils.register_cli_command(COMMAND, main)


def unregister() -> None:
    global _handle
    if _handle is not None:
        bpy.utils.unregister_cli_command(_handle)
        _handle = None

