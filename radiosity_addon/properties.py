"""``scene.radiosity``: the bake settings, saved in the .blend so a batch bake reproduces the
UI bake. Names are stable: scripts and farms set them."""

from __future__ import annotations

import math

import bpy

from ..core.settings import (
    LARGE_SCENE_MONTE_CARLO_RAYS, LARGE_SCENE_TRIANGLES, PRESETS, auto_monte_carlo_rays, preset_knobs,
)

DEFAULT_ATTRIBUTE = "Radiosity"

PRESET_ITEMS = [(key, preset.label, preset.description) for key, preset in PRESETS.items()] + [
    ("CUSTOM", "Custom", "The knobs below"),
]
RAY_ITEMS = [(str(n), str(n), f"{n} visibility rays per form factor") for n in (1, 4, 9, 16, 36, 64, 144, 256)]
MONTE_CARLO_RAYS = (16, 64, 256, 1024)
MONTE_CARLO_ITEMS = [
    ("AUTO", "Auto", f"{LARGE_SCENE_MONTE_CARLO_RAYS} rays from {LARGE_SCENE_TRIANGLES:,} triangles on (a large "
     "scene would take hours to shoot to the tolerance), off below"),
    ("0", "Off", "The light not yet shot when the shots stop is added as the ambient term"),
] + [
    (str(n), str(n), f"{n} final-gather rays per vertex, {n // 16} particle(s) per patch") for n in MONTE_CARLO_RAYS
]


class RadiositySettings(bpy.types.PropertyGroup):
    preset: bpy.props.EnumProperty(
        name="Preset", items=PRESET_ITEMS, default="PREVIEW",
        description="Speed against accuracy; Custom uses the knobs below",
    )
    output: bpy.props.EnumProperty(
        name="Output",
        items=[
            ("RADIOSITY", "Full Radiosity", "Emitted plus reflected light: what Cycles' Combined bake gives"),
            ("LIGHTING", "Lighting Only", "The light arriving (irradiance / pi), to multiply with textures later"),
        ],
        default="RADIOSITY",
    )
    attribute_name: bpy.props.StringProperty(
        name="Attribute", default=DEFAULT_ATTRIBUTE,
        description="Colour attribute written on every baked mesh (Float Color, Face Corner); "
        "baking again replaces only this attribute",
    )
    method: bpy.props.EnumProperty(
        name="Form Factors",
        items=[
            ("raycast", "Ray Casting", "Exact point-to-patch form factors times ray-cast visibility"),
            ("hemicube", "Hemicube", "The classic half-cube of pixels around each receiver"),
        ],
        default="raycast",
    )
    solver: bpy.props.EnumProperty(
        name="Solver",
        items=[
            ("progressive", "Progressive", "Shoot the brightest patch first; memory grows with the scene"),
            ("jacobi", "Jacobi", "Iterate on the full matrix (small scenes)"),
            ("gauss_seidel", "Gauss-Seidel", "Iterate on the full matrix, in place (small scenes)"),
        ],
        default="progressive",
    )
    patch_size: bpy.props.FloatProperty(
        name="Patch Size", default=0.0, min=0.0, soft_max=10.0, subtype="DISTANCE", unit="LENGTH",
        description="Longest patch edge; 0 picks an eighth of the scene's size (the Preview preset's)",
    )
    rays: bpy.props.EnumProperty(name="Rays", items=RAY_ITEMS, default="16",
                                 description="Visibility rays per form factor, area-light sample and sky point")
    hemicube_resolution: bpy.props.IntProperty(
        name="Hemicube Resolution", default=64, min=2, soft_max=512, step=2,
        description="Pixels across the hemicube's top face (even)",
    )
    tolerance: bpy.props.FloatProperty(
        name="Tolerance", default=1e-3, min=1e-7, max=0.5, precision=5,
        description="Stop when this share of the light is still to be distributed",
    )
    refinement_levels: bpy.props.IntProperty(
        name="Refinement Levels", default=0, min=0, max=4,
        description="Split patches where light changes fast this many times, re-solving after each; "
        "the error estimate follows the refined patches",
    )
    max_shots: bpy.props.IntProperty(
        name="Max Shots", default=0, min=0, soft_max=100_000,
        description="Progressive: stop after this many shots, the light not yet shot added as the ambient term "
        "or carried by Monte Carlo (0: shoot until the tolerance is met; with Monte Carlo, until every "
        "emitter has shot). For large scenes, where converging takes hours: the report's estimated error "
        "says how much was left",
    )
    monte_carlo_rays: bpy.props.EnumProperty(
        name="Monte Carlo", items=MONTE_CARLO_ITEMS, default="AUTO",
        description="Progressive: when the shots stop, carry the light not yet shot, with all its bounces, "
        "by particles from the patches and a final gather of this many rays at each vertex, instead of "
        "the ambient term. The emitters shoot first, so direct light and shadows stay exact. For large "
        "scenes (Sponza: 52 % -> 12 % from Cycles); a little noise, which the estimated error includes",
    )
    ambient: bpy.props.BoolProperty(
        name="Ambient Term", default=True,
        description="Add an estimate of the light not yet shot (progressive only)",
    )
    merge_flat: bpy.props.BoolProperty(
        name="Merge Flat Surfaces", default=True,
        description="Solve finely tessellated flat surfaces on panels up to the patch size, not triangle by "
        "triangle (a 40 x 40 grid wall costs about what a plain one does); colours are still evaluated at "
        "every vertex. Off: every triangle is at least one patch",
    )
    two_sided: bpy.props.BoolProperty(
        name="Two-Sided Surfaces", default=True,
        description="Surfaces reflect and emit on both sides, as in Cycles (but a wall with the whole scene "
        "in front of it, whose back nothing sees); off: front sides only, fewer patches",
    )
    vertex_normals: bpy.props.EnumProperty(
        name="Vertex Colours",
        items=[
            ("SHADING", "Follow Shading", "Faces share a vertex colour where they share a shading normal: flat "
             "faces get their own, smooth faces share theirs, split at sharp edges (as Cycles bakes them)"),
            ("CREASE", "Crease Angle", "Faces share a vertex colour unless they meet at more than the crease "
             "angle, whatever their shading"),
        ],
        default="SHADING",
        description="Where neighbouring faces share a vertex colour and which way it faces",
    )
    crease_angle: bpy.props.FloatProperty(
        name="Crease Angle", default=0.5235987755982988, min=0.0, max=3.141592653589793, subtype="ANGLE",
        description="Crease Angle mode: faces meeting at a sharper angle do not share a vertex colour",
    )
    modified_topology: bpy.props.EnumProperty(
        name="Changed Topology",
        items=[
            ("SKIP", "Skip", "Meshes whose modifiers change the number of corners take part in the lighting "
             "but get no colours (a warning says which)"),
            ("COPY", "Bake Applied Copy", "Write the colours into a new object holding the evaluated mesh"),
        ],
        default="SKIP",
        description="What to do with meshes whose modifiers change their topology",
    )
    last_report: bpy.props.StringProperty(name="Last Bake", default="", description="What the last bake did")

    def core_arguments(self, extent: float, triangles: int) -> tuple[str, str, dict]:
        """(method, solver, knobs) for ``core.bake`` on a scene of bounding-box diagonal ``extent``
        and ``triangles`` triangles."""
        if self.preset == "CUSTOM":
            knobs = {
                "patch_size": self.patch_size or None,
                "rays_per_form_factor": int(self.rays),
                "hemicube_resolution": self.hemicube_resolution,
                "tolerance": self.tolerance,
                "refinement_levels": self.refinement_levels,
            }
        else:
            knobs = preset_knobs(self.preset, extent)
        knobs |= {"ambient": self.ambient, "crease_angle": math.degrees(self.crease_angle),
                  "merge_flat": self.merge_flat, "max_shots": self.max_shots or None,
                  "monte_carlo_rays": auto_monte_carlo_rays(triangles) if self.monte_carlo_rays == "AUTO"
                  else int(self.monte_carlo_rays)}
        return self.method, self.solver, knobs


classes = (RadiositySettings,)


def register() -> None:
    for cls in classes:
        bpy.utils.register_class(cls)
    bpy.types.Scene.radiosity = bpy.props.PointerProperty(type=RadiositySettings)


def unregister() -> None:
    del bpy.types.Scene.radiosity
    for cls in reversed(classes):
        bpy.utils.unregister_class(cls)
