"""Named trade-offs between speed and accuracy, as knobs of ``bake``.

The patch size of a preset is a fraction of the scene's extent (the diagonal of its bounding
box), so a preset means the same at any scale. Times and errors of each preset on the benchmark
scenes are measured by ``bench/`` (docs/benchmarks.md).
"""

from __future__ import annotations

from typing import NamedTuple


class Preset(NamedTuple):
    label: str
    description: str
    patch_divisions: int  # patch size = scene extent / this
    rays_per_form_factor: int
    tolerance: float
    refinement_levels: int = 0


# Chosen from the Pareto fronts of docs/tradeoffs.md (bench/sweep.py; Cornell box of 736 triangles,
# NRMSE of the corner colours against a converged bake): the patch size is what buys accuracy (flat
# regions of small triangles are merged into panels up to it: ``simplify``); beyond 16 rays (the
# probe rays make 16 cost about what 4 do) and a tolerance of 1e-3 the error hardly moves.
# Refinement levels cost more than finer uniform patches for the same error there, so no preset
# uses them. The descriptions quote the measured time and error.
PRESETS: dict[str, Preset] = {
    "DRAFT": Preset("Draft", "Patches a quarter of the scene, 16 rays, 1 % of the light unshot. "
                    "Cornell box: 0.3 s, 4.6 % from converged", 4, 16, 1e-2),
    "PREVIEW": Preset("Preview", "The defaults: patches an eighth of the scene, 16 rays, 0.1 % unshot. "
                      "Cornell box: 0.9 s, 0.65 % from converged", 8, 16, 1e-3),
    "PRODUCTION": Preset("Production", "Patches a twelfth of the scene, 16 rays, 0.1 % unshot. "
                         "Cornell box: 2.9 s, 0.34 % from converged", 12, 16, 1e-3),
    "REFERENCE": Preset("Reference", "Patches a sixteenth of the scene, 16 rays, 0.01 % unshot: to check other "
                        "bakes against. Cornell box: 7 s, 0.26 % from converged", 16, 16, 1e-4),
}


def preset_knobs(name: str, extent: float) -> dict:
    """The ``bake`` knobs of preset ``name`` for a scene of bounding-box diagonal ``extent``."""
    if name not in PRESETS:
        raise ValueError(f"preset must be one of {tuple(PRESETS)}, got {name!r}")
    preset = PRESETS[name]
    return {
        "patch_size": extent / preset.patch_divisions,
        "rays_per_form_factor": preset.rays_per_form_factor,
        "tolerance": preset.tolerance,
        "refinement_levels": preset.refinement_levels,
    }


# From this many triangles on, "Auto" (the add-on's default) carries the light left after the
# emitters' shots by Monte Carlo (``monte_carlo_rays``): progressive refinement needs about a shot per
# patch to converge and a shot costs a form factor at every receiver, so Sponza (66,456 triangles)
# would take hours; there Monte Carlo with 64 rays bakes in 51 s at 9.7 % from Cycles' answer
# (6.3 % from path tracing, docs/path_traced.md), against 51 % for 300 shots and the ambient term
# in 65 s (docs/sponza.md). 256 rays (68 s; 8.6 and 4.5 %) buy more per second against path
# tracing (3.2 times Cycles' speed at equal error, against 2.1) and less against Cycles' answer
# (0.59 against 0.63): the default stays the quicker bake. The 40 x 40 Cornell box
# (20,348 triangles on 738 panels) still converges, in 7.2 s (docs/fine_mesh.md).
LARGE_SCENE_TRIANGLES = 50_000
LARGE_SCENE_MONTE_CARLO_RAYS = 64


def auto_monte_carlo_rays(triangles: int) -> int:
    """``monte_carlo_rays`` for a scene of ``triangles``: LARGE_SCENE_MONTE_CARLO_RAYS from
    LARGE_SCENE_TRIANGLES on, else 0 (shoot to the tolerance)."""
    return LARGE_SCENE_MONTE_CARLO_RAYS if triangles >= LARGE_SCENE_TRIANGLES else 0
