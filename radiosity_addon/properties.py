"""``scene.radiosity``: the bake settings, saved in the .blend so a batch bake reproduces the
UI bake. The knobs take their names, tooltips, defaults and bounds from the core's knob table
(``core.settings.KNOBS``), so they read the same here, on both command lines and in scripts;
the rest (preset, output, attribute, how the scene is read) are the add-on's own."""

from __future__ import annotations

import math

import bpy

from ..core.settings import KNOB, PRESETS, preset_knobs

DEFAULT_ATTRIBUTE = "Radiosity"

PRESET_ITEMS = [(key, preset.label, preset.description) for key, preset in PRESETS.items()] + [
    ("CUSTOM", "Custom", "The knobs below"),
]
RAYS = (1, 4, 9, 16, 36, 64, 144, 256)
MONTE_CARLO_RAYS = (16, 64, 256, 1024)
AUTO = "AUTO"  # the Monte Carlo enum's item for None


def knob_property(name: str, label: str, none: str = "", **blender) -> dict:
    """Keyword arguments of the bpy property of knob ``name``: its label, the table's tooltip
    (ending with ``none``, what stands for None here), default and bounds; ``blender`` adds or
    overrides (a subtype, a unit, items)."""
    knob = KNOB[name]
    arguments = {"name": label, "description": f"{knob.description}{'. ' + none if none else ''}"}
    if knob.default is not None and not knob.choices:
        arguments["default"] = knob.default
    if "items" not in blender:  # an enum has no bounds
        arguments |= {bound: value for bound, value in (("min", knob.low), ("max", knob.high)) if value is not None}
    return arguments | blender


def choice_items(name: str, labels: dict[str, tuple[str, str]]) -> list[tuple[str, str, str]]:
    """EnumProperty items of a knob with choices: the table's values, each with its label and
    tooltip from ``labels``."""
    return [(value, *labels[value]) for value in KNOB[name].choices]


def _live_toggled(settings, context) -> None:
    from . import live  # live needs the bake, which needs these settings registered first

    live.toggled(settings, context)


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
    method: bpy.props.EnumProperty(**knob_property("method", "Form Factors", items=choice_items("method", {
        "raycast": ("Ray Casting", "Exact point-to-patch form factors times ray-cast visibility"),
        "hemicube": ("Hemicube", "The classic half-cube of pixels around each receiver"),
    }), default=KNOB["method"].default))
    solver: bpy.props.EnumProperty(**knob_property("solver", "Solver", items=choice_items("solver", {
        "progressive": ("Progressive", "Shoot the brightest patch first; memory grows with the scene"),
        "jacobi": ("Jacobi", "Iterate on the full matrix (small scenes)"),
        "gauss_seidel": ("Gauss-Seidel", "Iterate on the full matrix, in place (small scenes)"),
        "hierarchical": ("Hierarchical", "Gather along links between clusters, as fine as the light needs"),
    }), default=KNOB["solver"].default))
    patch_size: bpy.props.FloatProperty(**knob_property(
        "patch_size", "Patch Size", "0: auto, the scene's extent / 8 (the Preview preset's)", default=0.0,
        soft_max=10.0, subtype="DISTANCE", unit="LENGTH"))
    rays_per_form_factor: bpy.props.EnumProperty(**knob_property(
        "rays_per_form_factor", "Rays", items=[(str(n), str(n), f"{n} rays") for n in RAYS],
        default=str(KNOB["rays_per_form_factor"].default)))
    hemicube_resolution: bpy.props.IntProperty(**knob_property("hemicube_resolution", "Hemicube Resolution",
                                                               soft_max=512, step=2))
    tolerance: bpy.props.FloatProperty(**knob_property("tolerance", "Tolerance", min=1e-7, max=0.5, precision=5))
    refinement_levels: bpy.props.IntProperty(**knob_property("refinement_levels", "Refinement Levels"))
    use_max_shots: bpy.props.BoolProperty(
        name="Limit Shots", default=False,
        description="Progressive: stop after Max Shots; off: shoot until the tolerance is met (with Monte Carlo, "
        "until every emitter has shot)",
    )
    max_shots: bpy.props.IntProperty(**knob_property("max_shots", "Max Shots", default=1000, soft_max=100_000))
    monte_carlo_rays: bpy.props.EnumProperty(**knob_property(
        "monte_carlo_rays", "Monte Carlo", items=[
            (AUTO, "Auto", KNOB["monte_carlo_rays"].none_means),
            ("0", "Off", "The light not yet shot when the shots stop is added as the ambient term"),
        ] + [(str(n), str(n), f"{n} final-gather rays per vertex") for n in MONTE_CARLO_RAYS], default=AUTO))
    link_tolerance: bpy.props.FloatProperty(**knob_property("link_tolerance", "Link Tolerance", min=1e-5, max=0.5,
                                                            precision=4))
    denoise: bpy.props.FloatProperty(**knob_property("denoise", "Denoise", soft_max=4.0, precision=2))
    ambient: bpy.props.BoolProperty(**knob_property("ambient", "Ambient Term"))
    merge_flat: bpy.props.BoolProperty(**knob_property("merge_flat", "Merge Flat Surfaces"))
    seed: bpy.props.IntProperty(**knob_property("seed", "Seed"))
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
    crease_angle: bpy.props.FloatProperty(**knob_property(
        "crease_angle", "Crease Angle", "Crease Angle mode only", default=math.radians(KNOB["crease_angle"].default),
        min=0.0, max=math.pi, subtype="ANGLE"))
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
    color_type: bpy.props.EnumProperty(
        name="Colour Type",
        items=[
            ("FLOAT_COLOR", "Float", "32-bit float per channel, scene-linear: any brightness, as baked"),
            ("BYTE_COLOR", "Byte", "8-bit sRGB per channel, as game engines and glTF take vertex colours: "
             "exposure, then the tone curve, then clipped to 0..1"),
        ],
        default="FLOAT_COLOR", description="How the colour attribute stores the colours",
    )
    color_domain: bpy.props.EnumProperty(
        name="Domain",
        items=[
            ("CORNER", "Face Corner", "A colour per face corner: colour may jump at creases and material borders"),
            ("POINT", "Vertex", "A colour per vertex, the mean of its corners' (smooth across creases; what "
             "some engines take)"),
        ],
        default="CORNER", description="Where the colour attribute stores the colours",
    )
    exposure: bpy.props.FloatProperty(
        name="Exposure", default=0.0, soft_min=-10.0, soft_max=10.0, step=10,
        description="Stops: the colours are multiplied by 2 to this power before they are stored",
    )
    tone: bpy.props.EnumProperty(
        name="Tone",
        items=[
            ("CLIP", "Clip", "Byte colours: values above 1 are clipped"),
            ("SOFT", "Soft", "Byte colours: x (1 + x / 16) / (1 + x) per channel (Reinhard's, white at 4), so "
             "values up to 4 keep their differences"),
        ],
        default="CLIP", description="How byte colours fit the brighter values into 0..1",
    )
    separate_direct: bpy.props.BoolProperty(
        name="Direct and Indirect", default=False,
        description="Also write the direct light (from lights, sky and emitters) and the rest into the attributes "
        "'<Attribute> Direct' and '<Attribute> Indirect', which add up to the bake",
    )
    instances: bpy.props.EnumProperty(
        name="Instances",
        items=[
            ("LIGHT_ONLY", "Light and Shade", "Instances (of collections, particles, geometry nodes) light and shade "
             "the others but get no colours: their meshes belong to the instanced objects"),
            ("OBJECTS", "Bake Into Objects", "Each instance becomes an object of its own, with a copy of its mesh "
             "holding its colours; the instancer is hidden"),
        ],
        default="LIGHT_ONLY", description="What instanced meshes get",
    )
    selected_only: bpy.props.BoolProperty(
        name="Selected Only", default=False,
        description="Write colours only on the selected objects; the rest of the scene still lights and shades "
        "them",
    )
    light_groups: bpy.props.BoolProperty(
        name="Per Light Group", default=False,
        description="Also write the light of each light group (View Layer > Light Groups; set on lights, emitting "
        "objects and the world) into '<Attribute> <group>': the geometry work is done once, each group re-solves",
    )
    live: bpy.props.BoolProperty(
        name="Live", default=False, update=_live_toggled,
        description="After a bake, re-solve and rewrite the colours whenever a material's colour, a light's colour or "
        "power or the world's colour or strength changes (the geometry work of the bake is reused)",
    )
    live_status: bpy.props.StringProperty(name="Live", default="", description="What Live last did")
    last_report: bpy.props.StringProperty(name="Last Bake", default="", description="What the last bake did")

    def knobs(self) -> dict:
        """The core knobs these settings stand for, None where they leave the core to decide,
        before a preset's (``core_arguments``)."""
        return {
            "method": self.method,
            "solver": self.solver,
            "patch_size": self.patch_size or None,
            "rays_per_form_factor": int(self.rays_per_form_factor),
            "hemicube_resolution": self.hemicube_resolution,
            "tolerance": self.tolerance,
            "refinement_levels": self.refinement_levels,
            "max_shots": self.max_shots if self.use_max_shots else None,
            "monte_carlo_rays": None if self.monte_carlo_rays == AUTO else int(self.monte_carlo_rays),
            "link_tolerance": self.link_tolerance,
            "denoise": self.denoise,
            "ambient": self.ambient,
            "merge_flat": self.merge_flat,
            "crease_angle": math.degrees(self.crease_angle),
            "seed": self.seed,
        }

    def set_knob(self, name: str, value) -> None:
        """Store core knob ``name`` = ``value`` (None where the knob allows it); ValueError when
        Blender's property cannot hold it (a ray count it does not offer)."""
        if name == "patch_size":
            self.patch_size = value or 0.0
        elif name == "max_shots":
            self.use_max_shots = value is not None
            self.max_shots = self.max_shots if value is None else value
        elif name == "crease_angle":
            self.crease_angle = math.radians(value)
        elif name in ("rays_per_form_factor", "monte_carlo_rays"):
            item = AUTO if value is None else str(value)
            choices = [choice.identifier for choice in self.bl_rna.properties[name].enum_items]
            if item not in choices:
                offered = ", ".join("auto" if choice == AUTO else choice for choice in choices)
                raise ValueError(f"{KNOB[name].flag} must be one of {offered} here, got {value}")
            setattr(self, name, item)
        else:
            setattr(self, name, value)

    def core_arguments(self, extent: float) -> dict:
        """The knobs for ``core.bake`` on a scene of bounding-box diagonal ``extent``: a preset's
        over these settings' own."""
        knobs = self.knobs()
        if self.preset != "CUSTOM":
            knobs |= preset_knobs(self.preset, extent)
        return knobs


class RadiosityObjectSettings(bpy.types.PropertyGroup):
    """``object.radiosity``: the part one object plays in the bake (all on by default)."""

    receives: bpy.props.BoolProperty(
        name="Receives Colours", default=True,
        description="Write the baked colours on this object's mesh; off: it still lights and shades the others",
    )
    reflects: bpy.props.BoolProperty(
        name="Reflects Light", default=True,
        description="Light arriving here is reflected on into the scene; off: it is absorbed (a black surface "
        "for the others, though it still receives colours)",
    )
    emits: bpy.props.BoolProperty(
        name="Emits Light", default=True,
        description="Emissive materials on this object light the scene; off: their emission is ignored",
    )


classes = (RadiositySettings, RadiosityObjectSettings)


def register() -> None:
    for cls in classes:
        bpy.utils.register_class(cls)
    bpy.types.Scene.radiosity = bpy.props.PointerProperty(type=RadiositySettings)
    bpy.types.Object.radiosity = bpy.props.PointerProperty(type=RadiosityObjectSettings)


def unregister() -> None:
    del bpy.types.Object.radiosity
    del bpy.types.Scene.radiosity
    for cls in reversed(classes):
        bpy.utils.unregister_class(cls)
