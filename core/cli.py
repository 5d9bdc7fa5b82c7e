"""Command line: ``python -m core bake SCENE.obj [knobs]`` bakes an OBJ/MTL scene and prints what
it did; ``python -m core knobs`` prints the knob table. Exit codes: 0 success, 2 bad arguments or
input, 1 an unexpected error."""

from __future__ import annotations

import argparse
import sys

import numpy as np

from .bake import bake
from .scene import read_obj, subdivide, write_ply
from .settings import add_knob_options, given_knobs, knob_table
from .util.geometry import areas_and_normals


class _Parser(argparse.ArgumentParser):
    def error(self, message):
        self.exit(2, f"error: {message}\n")


def parser() -> argparse.ArgumentParser:
    main = _Parser(prog="python -m core", description=__doc__.splitlines()[0])
    commands = main.add_subparsers(dest="command", required=True, parser_class=_Parser)
    command = commands.add_parser("bake", help="bake an OBJ scene (Kd reflectance, Ke emission)")
    command.add_argument("scene", help="an .obj file; its .mtl libraries give Kd and Ke")
    command.add_argument("--subdivide", type=int, default=1, metavar="N",
                         help="split each input triangle into N*N first, so colours can show shadows")
    command.add_argument("--output", help="write the baked triangles with corner colours to this .ply")
    add_knob_options(command)
    commands.add_parser("knobs", help="print the knob table (Markdown)")
    return main


def main(argv: list[str] | None = None) -> int:
    try:
        arguments = parser().parse_args(argv)
    except SystemExit as exit_:
        return int(exit_.code or 0)
    if arguments.command == "knobs":
        print(knob_table())
        return 0
    try:
        scene, materials = read_obj(arguments.scene)
        if arguments.subdivide < 1:
            raise ValueError(f"--subdivide must be at least 1, got {arguments.subdivide}")
        if arguments.subdivide > 1:
            scene = subdivide(scene, arguments.subdivide)
        result = bake(scene, **given_knobs(arguments))
    except (OSError, ValueError) as error:
        print(f"error: {error}", file=sys.stderr)
        return 2
    stats = result.stats
    seconds = ", ".join(f"{name} {value:.2f} s" for name, value in stats["seconds"].items())
    merged = f" merged into {stats['panels']:,} panels" if stats["panels"] != stats["triangles"] else ""
    print(f"baked {arguments.scene}: {stats['triangles']:,} triangles{merged}, {stats['patches']:,} patches, "
          f"{stats['nodes']:,} vertex nodes, {len(materials)} materials")
    if "monte_carlo" in stats:
        work = f"{stats['shots']:,} shots, then Monte Carlo ({stats['monte_carlo']['gather_rays']:,} rays per vertex)"
    elif "shots" in stats:
        work = f"{stats['shots']:,} shots, {100 * stats['unshot_fraction']:.3g}% of the light unshot"
    else:
        work = f"{stats['iterations']:,} iterations, error bound {stats['error_bound']:.2g}"
    print(f"  {stats['method']} form factors, {stats['solver']} solver: {work}")
    print(f"  estimated error {100 * stats['error_estimate']['total']:.2g}% "
          "(RMS over the vertex colours, of their mean)")
    print(f"  {stats['rays_cast']:,} rays; {seconds}")
    mean = np.average(result.triangle_radiosity, axis=0, weights=areas_and_normals(scene.vertices[scene.triangles])[0])
    print(f"  mean radiosity (area-weighted, linear RGB): {mean[0]:.4f} {mean[1]:.4f} {mean[2]:.4f}")
    if arguments.output:
        write_ply(arguments.output, scene.vertices[scene.triangles], result.corner_colors)
        print(f"  wrote {arguments.output}")
    return 0
