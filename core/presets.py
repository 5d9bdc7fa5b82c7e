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


PRESETS: dict[str, Preset] = {
    "DRAFT": Preset("Draft", "Seconds: large patches, 4 rays, stops with 1% of the light unshot", 2, 4, 1e-2),
    "PREVIEW": Preset("Preview", "The core's defaults: patches of a quarter of the scene, 16 rays, 0.1%", 4, 16, 1e-3),
    "PRODUCTION": Preset("Production", "Patches of an eighth of the scene, 64 rays, 0.01% unshot", 8, 64, 1e-4),
    "REFERENCE": Preset("Reference", "Slow, near converged: to check other bakes against", 16, 256, 1e-5),
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
