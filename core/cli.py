"""Command line: ``python -m core bake SCENE.obj [options]`` bakes an OBJ/MTL scene and prints
what it did. Exit codes: 0 success, 2 bad arguments or input, 1 an unexpected error."""

from __future__ import annotations

import argparse
import sys

import numpy as np

from .bake import BakeSettings, bake
from .formfactors import METHODS
from .geometry import areas_and_normals
from .objfile import read_obj, subdivide
from .plyfile import write_ply
from .presets import LARGE_SCENE_MONTE_CARLO_RAYS, LARGE_SCENE_TRIANGLES, auto_monte_carlo_rays
from .solvers import SOLVERS


def parser() -> argparse.ArgumentParser:
    main = argparse.ArgumentParser(prog="python -m core", description=__doc__.splitlines()[0])
    commands = main.add_subparsers(dest="command", required=True)
    command = commands.add_parser("bake", help="bake an OBJ scene (Kd reflectance, Ke emission)")
    command.add_argument("scene", help="an .obj file; its .mtl libraries give Kd and Ke")
    command.add_argument("--subdivide", type=int, default=1, metavar="N",
                         help="split each input triangle into N*N first, so colours can show shadows")
    command.add_argument("--method", choices=METHODS, default="raycast")
    command.add_argument("--solver", choices=SOLVERS, default="progressive")
    defaults = BakeSettings()
    command.add_argument("--patch-size", type=float, default=None, help="longest patch edge (scene units)")
    command.add_argument("--rays", type=int, default=defaults.rays_per_form_factor, help="rays per form factor")
    command.add_argument("--resolution", type=int, default=defaults.hemicube_resolution, help="hemicube resolution")
    command.add_argument("--tolerance", type=float, default=defaults.tolerance, help="convergence tolerance")
    command.add_argument("--max-shots", type=int, default=None, metavar="N",
                         help="progressive refinement stops after N shots; the rest goes by Monte Carlo, or as the "
                         "ambient term")
    command.add_argument("--monte-carlo-rays", type=_monte_carlo_rays, default=None, metavar="N|auto",
                         help="progressive only: after the emitters' shots (and --max-shots), carry the light left "
                         "by Monte Carlo with N final-gather rays per vertex (a perfect square; 0: off); auto (the "
                         f"default, as in Blender): {LARGE_SCENE_MONTE_CARLO_RAYS} from {LARGE_SCENE_TRIANGLES:,} "
                         "triangles on, where shooting to the tolerance would take hours, else 0")
    command.add_argument("--keep-triangles", action="store_true",
                         help="patch every input triangle on its own: flat regions of small triangles are not "
                         "merged into panels up to the patch size")
    command.add_argument("--output", help="write the baked triangles with corner colours to this .ply")
    return main


def _monte_carlo_rays(value: str) -> int | None:
    """--monte-carlo-rays: "auto" (None) or a count."""
    if value == "auto":
        return None
    try:
        return int(value)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number of rays or auto, got {value!r}") from None


def main(argv: list[str] | None = None) -> int:
    try:
        arguments = parser().parse_args(argv)
    except SystemExit as exit_:
        return int(exit_.code or 0)
    try:
        scene, materials = read_obj(arguments.scene)
        if arguments.subdivide < 1:
            raise ValueError(f"--subdivide must be at least 1, got {arguments.subdivide}")
        if arguments.subdivide > 1:
            scene = subdivide(scene, arguments.subdivide)
        monte_carlo_rays = arguments.monte_carlo_rays
        if monte_carlo_rays is None:  # auto, as the add-on's (the explicit solvers ignore it)
            monte_carlo_rays = auto_monte_carlo_rays(len(scene.triangles))
        result = bake(
            scene, arguments.method, arguments.solver, patch_size=arguments.patch_size,
            rays_per_form_factor=arguments.rays, hemicube_resolution=arguments.resolution,
            tolerance=arguments.tolerance, merge_flat=not arguments.keep_triangles, max_shots=arguments.max_shots,
            monte_carlo_rays=monte_carlo_rays,
        )
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
    print(f"  estimated error {100 * stats['error_estimate']['total']:.2g}% (RMS over the vertex colours, of their mean)")
    print(f"  {stats['rays_cast']:,} rays; {seconds}")
    mean = np.average(result.triangle_radiosity, axis=0, weights=areas_and_normals(scene.vertices[scene.triangles])[0])
    print(f"  mean radiosity (area-weighted, linear RGB): {mean[0]:.4f} {mean[1]:.4f} {mean[2]:.4f}")
    if arguments.output:
        write_ply(arguments.output, scene.vertices[scene.triangles], result.corner_colors)
        print(f"  wrote {arguments.output}")
    return 0

