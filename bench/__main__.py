"""``python -m bench <study> [options]``: run one study of bench/studies/ (``python -m bench --help``
lists them; ``python -m bench <study> --help`` gives a study's options). Run from the repository root."""

from __future__ import annotations

import importlib
import sys

# Each study: what it measures and writes, and about how long a full run takes on 2 cores (its
# --quick run: a few minutes at most, written into build/bench-quick/).
STUDIES = {
    "benchmarks": ("speed, accuracy and memory of bake() on the Cornell box and Sponza, and its rays against raw "
                   "Embree: benchmarks.md", "7 min"),
    "tradeoffs": ("every knob, method, solver and preset against exact answers, converged references and path "
                  "tracing: tradeoffs.md and its figures", "30 min"),
    "versus_cycles": ("our bakes of the sample Cornell box against Cycles': versus_cycles.md, headline.png and the "
                      "README's two pictures", "5 min"),
    "fine_mesh": ("our bake against Cycles' on the Cornell box with 40 x 40 walls: fine_mesh.md", "7 min"),
    "sponza": ("our bakes against Cycles' on Sponza: sponza.md", "12 min"),
    "path_traced": ("the last sponza run's bakes against path tracing, checked on the Cornell box: path_traced.md",
                    "3 min"),
    "resolve": ("re-solves after colour changes against first and fresh bakes (Cornell box, Sponza): resolve.md",
                "10 min"),
    "breakfast": ("the breakfast room (269,538 triangles) under a sky: time, peak memory, progress and error against "
                  "path tracing: breakfast.md", "10 min"),
    "interior": ("our bake of the breakfast room in Blender against Cycles', both against path tracing: interior.md",
                 "25 min"),
    "growth": ("time and peak memory against triangles on the Cornell box tiled 1 to 64 times: growth.md, growth.png",
               "25 min"),
    "rescore": ("a core bake of the sample Cornell box scored against the last versus_cycles run's Cycles answer "
                "(prints; writes nothing)", "1 min"),
}


def usage() -> str:
    """The list of studies."""
    lines = ["usage: python -m bench <study> [options]   (python -m bench <study> --help: its options)", "",
             "Studies (reports go to docs/results/; about how long a full run takes on 2 cores):"]
    lines += [f"  {name:<14} {description} ({duration})" for name, (description, duration) in STUDIES.items()]
    return "\n".join(lines)


def main(argv: list[str]) -> int:
    if not argv or argv[0] in ("-h", "--help"):
        print(usage())
        return 0
    if argv[0] not in STUDIES:
        print(f"error: no study {argv[0]!r}\n\n{usage()}", file=sys.stderr)
        return 2
    return importlib.import_module(f"bench.studies.{argv[0]}").main(argv[1:])


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
