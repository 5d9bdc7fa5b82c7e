"""The knobs of a bake, in one table (``KNOBS``): name, type, default, range, unit and a one-line
description. ``BakeSettings`` (and its validation), both command lines (``python -m core bake``,
``blender -c radiosity``), the add-on's properties and the README's knob table are all made from
it, so a knob has one name and one meaning everywhere. Presets are named sets of knobs.
"""

from __future__ import annotations

import argparse
import dataclasses
import math
from typing import Any, NamedTuple

METHODS = ("hemicube", "raycast")
SOLVERS = ("progressive", "jacobi", "gauss_seidel", "hierarchical")


@dataclasses.dataclass(frozen=True)
class Knob:
    """One knob. ``low`` and ``high`` bound it (``open`` names the bounds that are excluded:
    "low", "high" or "both"); ``square``: a perfect square (one ray per stratum; 0 too where
    ``low`` is 0); ``even``: an even number; ``none``: the word that stands for None on command
    lines ("auto", "none") where None is allowed, and ``none_means`` what it means;
    ``exposed``: offered on both command lines and in Blender (the others only to scripts)."""

    name: str
    type: type
    default: Any
    description: str
    unit: str = ""
    low: float | None = None
    high: float | None = None
    open: str = ""
    choices: tuple[str, ...] = ()
    square: bool = False
    even: bool = False
    none: str = ""
    none_means: str = ""
    exposed: bool = True

    @property
    def flag(self) -> str:
        """The command-line option: ``--patch-size`` for ``patch_size``."""
        return "--" + self.name.replace("_", "-")

    def rule(self) -> str:
        """What a valid value is, in words: "a positive length", "in (0, 1)", ..."""
        if self.choices:
            return f"one of {self.choices}"
        if self.type is bool:
            return "True or False"
        if self.square:
            squares = "a perfect square (1, 4, 9, 16, ...)"
            return f"0 or {squares}" if self.low == 0 else squares
        if self.even:
            return f"an even integer >= {self.low:g}"
        if self.type is int:
            if self.high is not None:
                return f"an integer from {self.low:g} to {self.high:g}"
            return "a non-negative integer" if self.low == 0 else f"an integer >= {self.low:g}"
        if self.high is None:
            if self.low == 0 and self.open not in ("low", "both"):
                return "a number >= 0"
            return "a positive length" if self.unit == "scene units" else "a positive number"
        left, right = ("(" if self.open in ("low", "both") else "["), (")" if self.open in ("high", "both") else "]")
        return f"in {left}{self.low:g}, {self.high:g}{right}" + (f" {self.unit}" if self.unit == "degrees" else "")

    def problem(self, value) -> str | None:
        """Why ``value`` is not valid for this knob, or None."""
        message = f"{self.name} must be {self.rule()}{' or None' if self.none else ''}, got {value!r}"
        if value is None:
            return None if self.none else message
        if self.choices:
            return None if value in self.choices else message
        if self.type is bool:
            return None if value in (True, False) else message
        try:
            number = float(value)
        except (TypeError, ValueError):
            return message
        if not math.isfinite(number) or (self.type is int and int(number) != number):
            return message
        low_open, high_open = self.open in ("low", "both"), self.open in ("high", "both")
        if self.low is not None and (number < self.low or (low_open and number == self.low)):
            return message
        if self.high is not None and (number > self.high or (high_open and number == self.high)):
            return message
        if self.square and number > 0 and round(math.sqrt(number)) ** 2 != number:
            return message
        if self.even and number % 2:
            return message
        return None


KNOBS: tuple[Knob, ...] = (
    Knob("method", str, "raycast", "How form factors are computed: exact point-to-patch factors times ray-cast "
         "visibility (raycast), or the classic half-cube of pixels (hemicube)", choices=METHODS),
    Knob("solver", str, "progressive", "How B = E + rho F B is solved: shooting the brightest patch first, "
         "matrix-free (progressive), iterating on the full matrix (jacobi, gauss_seidel: small scenes), or "
         "gathering along links between clusters as fine as the light needs (hierarchical)", choices=SOLVERS),
    Knob("patch_size", float, None, "Longest patch edge: smaller patches integrate the light each surface "
         "receives more accurately, at a cost that grows with their number", "scene units", low=0, open="low",
         none="auto", none_means="the scene's extent / 8"),
    Knob("rays_per_form_factor", int, 16, "Visibility rays from a receiving point to each patch (one per "
         "stratum), and per piece of an area light (4 times as many for one of a spread); the vertices read lights "
         "and emitters by two sets of samples and more where a shadow crosses them; the sky gets 16 times as "
         "many directions at each vertex, 4 times at each patch", "rays", low=1,
         square=True),
    Knob("hemicube_resolution", int, 64, "Pixels across the hemicube's top face", "pixels", low=2, even=True),
    Knob("tolerance", float, 1e-3, "Stop when this share of the light is still to be distributed (progressive), "
         "or at this bound on the error relative to the brightest patch (jacobi, gauss_seidel)", low=0, high=1,
         open="both"),
    Knob("max_shots", int, None, "Progressive: stop after this many shots; the light not yet shot goes by Monte "
         "Carlo or as the ambient term, and the error estimate says how much it was", "shots", low=0,
         none="none", none_means="no limit: shoot until the tolerance is met (with Monte Carlo, until every emitter "
         "has shot)"),
    Knob("monte_carlo_rays", int, None, "Progressive: when the shots stop, carry the light not yet shot, with all "
         "its bounces, by particles from the patches and a final gather of this many rays at each vertex, "
         "four times as many (up to 256) where it is noisiest (0: off, the ambient term instead); the "
         "emitters always shoot first", "rays", low=0, square=True,
         none="auto", none_means="64 where shooting to the tolerance would take minutes (patches x (patches + "
         "vertices) from 50 million on; for patches finer than the scene's extent / 8, from that times the "
         "square of their refinement, up to 4 times; for a tolerance below 1e-3, times 1e-3 / tolerance, if "
         "more), else 0"),
    Knob("link_tolerance", float, 0.01, "Hierarchical: a link is split while the light it carries is above this "
         "share of the mean radiosity of the surfaces that do not emit", low=0, high=1, open="both"),
    Knob("denoise", float, 3.0, "Monte Carlo: average each vertex's light with its neighbours' where they lie "
         "close for what they see and differ by no more than about this many standard errors of their noise (0: "
         "off); higher is smoother, but blurs more light that truly changes", low=0),
    Knob("ambient", bool, True, "Progressive: add an estimate of the light not yet shot as a uniform ambient term"),
    Knob("merge_flat", bool, True, "Solve flat regions of triangles smaller than the patch size on panels up to "
         "it, not triangle by triangle; colours are still evaluated at every vertex"),
    Knob("crease_angle", float, 30.0, "Faces meeting at a sharper angle, or of different materials, do not share "
         "a vertex colour (where the scene gives no shading normals)", "degrees", low=0, high=180),
    Knob("refinement_levels", int, 0, "Times the patches where radiosity jumps are split in four and the solve "
         "goes on", "levels", low=0, high=8),
    Knob("refinement_threshold", float, 0.25, "A patch is split when its radiosity differs from a neighbour's by "
         "more than this share of the mean radiosity of the surfaces that do not emit", low=0, open="low",
         exposed=False),
    Knob("near_field", bool, True, "Read the patches next to each vertex from their linear interpolants, not "
         "their means (the vertices along concave edges and contact lines); with Monte Carlo the final gather "
         "reads them where its rays land instead (but under an environment, area lights or more than 8 lights)",
         exposed=False),
    Knob("probe_rays", bool, True, "Ray casting: cast a quarter of each form factor's rays first and the rest only "
         "where they disagree: about half the time, shadows a little less exact", exposed=False),
    Knob("max_iterations", int, 100_000, "Jacobi and Gauss-Seidel stop after this many sweeps", "sweeps", low=0,
         exposed=False),
    Knob("memory_budget", int, 2 << 30, "Bytes the explicit matrix of Jacobi and Gauss-Seidel may take", "bytes",
         low=0, exposed=False),
    Knob("column_cache", int, 1 << 30, "Bytes of form-factor columns progressive refinement may keep for "
         "reshooting", "bytes", low=0, exposed=False),
    Knob("split_direct", bool, False, "Also return the direct light at every corner (from the lights, the sky "
         "and the emitters' first bounce), to write direct and indirect light apart", exposed=False),
    Knob("seed", int, 0, "Fixes the positions of every ray sample: the same seed gives the same bake", low=0),
)
KNOB = {knob.name: knob for knob in KNOBS}


def _validate(settings) -> None:
    for knob in KNOBS:
        problem = knob.problem(getattr(settings, knob.name))
        if problem:
            raise ValueError(problem)


def _docstring() -> str:
    lines = ["The knobs of a bake (``KNOBS``), validated on construction: ValueError names the first bad one.", ""]
    for knob in KNOBS:
        default = f"{knob.default!r}" + (f" ({knob.none}: {knob.none_means})" if knob.default is None else "")
        lines.append(f"{knob.name} : {knob.type.__name__}, {knob.rule()}{' or None' if knob.none else ''}; "
                     f"default {default}. {knob.description}.")
    return "\n".join(lines)


BakeSettings = dataclasses.make_dataclass(
    "BakeSettings",
    [(knob.name, knob.type | None if knob.none else knob.type, dataclasses.field(default=knob.default))
     for knob in KNOBS],
    frozen=True,
    namespace={"__post_init__": _validate, "__doc__": _docstring(), "__module__": __name__},
)

# The patch size when None: the scene's extent (the diagonal of its bounding box) over this.
AUTO_PATCH_DIVISIONS = 8
# From this many point-patch form factors per round of shots on, P (P + N) for P patches and N
# nodes, Monte Carlo's Auto carries the light left after the emitters' shots with
# LARGE_SCENE_MONTE_CARLO_RAYS gather rays: progressive refinement needs a few shots per patch to
# converge, and a shot costs a form factor at every patch and node. The Cornell box tiled 2 x 2
# (2.2e7) shoots to the tolerance in 13 s, 4 x 4 (3.5e8) in 511 s, where Monte Carlo takes 5-7 s
# (docs/results/growth.md); the sample Cornell box is about 1e6. That line is for the default
# patches and tolerance. A bake that asks for more, finer patches than the scene's extent over
# AUTO_PATCH_DIVISIONS or a tighter tolerance than LINE_TOLERANCE, accepts a longer wait, and Monte
# Carlo's 64 rays leave about 2 % of noise however fine the patches or tight the tolerance: at one
# line for all, the finer presets went by Monte Carlo where the coarser shot, and read worse. So the
# line moves up with the square of the patches' refinement, up to MAX_REFINEMENT times (the Reference
# preset's (16 / 8)^2), or with LINE_TOLERANCE / tolerance (Reference's 1e-4: 10 times), whichever
# is more (``auto_monte_carlo_rays``). The Cornell box with 40 x 40 walls (5.8e7 at Reference) read
# 2.10 % off by Monte Carlo in 3.4 s, against 0.22 % shot in 19 to 33 s and Preview's 0.97 %; its
# 46 faces split 36 x 36 (59,616 triangles; 6.1e7 at Production) 0.251 % in 6.5 s, against 0.060 %
# shot in 20.5 s and Preview's 0.133 % (docs/notes/experiments.md, "Reference worse than Preview").
LARGE_SCENE_SHOOTING = 50_000_000
LINE_TOLERANCE = 1e-3
MAX_REFINEMENT = 4.0
LARGE_SCENE_MONTE_CARLO_RAYS = 64


def resolved(settings, extent: float):
    """``settings`` with the patch size decided for a scene of bounding-box diagonal ``extent``
    (the Monte Carlo rays wait for the patches: ``with_monte_carlo``)."""
    auto_patch_size = extent / AUTO_PATCH_DIVISIONS if extent > 0 else None  # None: no area, refused later
    return dataclasses.replace(settings, patch_size=auto_patch_size if settings.patch_size is None
                               else settings.patch_size)


def with_monte_carlo(settings, patches: int, nodes: int, extent: float):
    """``settings`` with the Monte Carlo rays decided for ``patches`` patches and ``nodes``
    nodes of a scene of bounding-box diagonal ``extent`` (``auto_monte_carlo_rays``) unless given."""
    if settings.monte_carlo_rays is not None:
        return settings
    refinement = (extent / AUTO_PATCH_DIVISIONS / settings.patch_size) ** 2 if settings.patch_size else 1.0
    return dataclasses.replace(settings, monte_carlo_rays=auto_monte_carlo_rays(patches, nodes, refinement,
                                                                                settings.tolerance))


def auto_monte_carlo_rays(patches: int, nodes: int, refinement: float = 1.0, tolerance: float = LINE_TOLERANCE) -> int:
    """``monte_carlo_rays`` for a discretisation of ``patches`` patches and ``nodes`` nodes,
    ``refinement`` times as many patches per area as the default patch size makes, shot to
    ``tolerance``: LARGE_SCENE_MONTE_CARLO_RAYS where a round of shots, patches x (patches +
    nodes), costs LARGE_SCENE_SHOOTING x max(1, min(MAX_REFINEMENT, refinement), LINE_TOLERANCE /
    tolerance) form factors or more; else 0 (shoot to the tolerance)."""
    line = LARGE_SCENE_SHOOTING * max(1.0, min(MAX_REFINEMENT, refinement), LINE_TOLERANCE / tolerance)
    return LARGE_SCENE_MONTE_CARLO_RAYS if patches * (patches + nodes) >= line else 0


class Preset(NamedTuple):
    label: str
    description: str
    patch_divisions: int  # patch size = scene extent / this
    rays_per_form_factor: int
    tolerance: float
    refinement_levels: int = 0
    hemicube_resolution: int = 64


# Chosen from the Pareto fronts of docs/results/tradeoffs.md (bench sweep): the patch size is what
# buys accuracy; beyond 16 rays (the probe rays make 16 cost about what 4 do) and a tolerance of
# 1e-3 the error hardly moves; refinement levels cost more than finer uniform patches for the same
# error, so no preset uses them. Their times and errors are published there.
PRESETS: dict[str, Preset] = {
    "DRAFT": Preset("Draft", "Patches a quarter of the scene, 16 rays, 1 % of the light unshot", 4, 16, 1e-2),
    "PREVIEW": Preset("Preview", "The defaults: patches an eighth of the scene, 16 rays, 0.1 % unshot", 8, 16, 1e-3),
    "PRODUCTION": Preset("Production", "Patches a twelfth of the scene, 16 rays, 0.1 % unshot", 12, 16, 1e-3),
    "REFERENCE": Preset("Reference", "Patches a sixteenth of the scene, 16 rays, 0.01 % unshot: to check other "
                        "bakes against", 16, 16, 1e-4),
}
# The knobs a preset sets (the others keep their own values).
PRESET_KNOBS = ("patch_size", "rays_per_form_factor", "hemicube_resolution", "tolerance", "refinement_levels")


def preset_knobs(name: str, extent: float) -> dict:
    """The ``bake`` knobs of preset ``name`` for a scene of bounding-box diagonal ``extent``."""
    if name not in PRESETS:
        raise ValueError(f"preset must be one of {tuple(PRESETS)}, got {name!r}")
    preset = PRESETS[name]
    return {
        "patch_size": extent / preset.patch_divisions,
        "rays_per_form_factor": preset.rays_per_form_factor,
        "hemicube_resolution": preset.hemicube_resolution,
        "tolerance": preset.tolerance,
        "refinement_levels": preset.refinement_levels,
    }


def add_knob_options(parser: argparse.ArgumentParser) -> None:
    """One option per command-line knob, named by ``Knob.flag``; a knob left out stays None in
    the parsed namespace (the caller's own setting stands). ``auto`` or ``none`` (the knob's
    word for None) passes None on purpose, as ``NONE``."""
    group = parser.add_argument_group("knobs (docs: README, 'Knobs')")
    for knob in KNOBS:
        if not knob.exposed:
            continue
        help_text = f"{knob.description}; {knob.rule()}"
        if knob.none:
            help_text += f", or {knob.none} ({knob.none_means})"
        if knob.type is bool:
            group.add_argument(knob.flag, action=argparse.BooleanOptionalAction, default=None, help=help_text)
        else:
            metavar = None if knob.choices else "LENGTH" if knob.unit == "scene units" else \
                "N" if knob.type is int else "VALUE"
            group.add_argument(knob.flag, type=_parser_of(knob), choices=knob.choices or None, default=None,
                               metavar=metavar, help=help_text)


class _NoneGiven:
    """A knob set to None on purpose on the command line (``auto``, ``none``)."""

    def __repr__(self) -> str:
        return "NONE"


NONE = _NoneGiven()


def _parser_of(knob: Knob):
    """argparse's ``type`` for ``knob``: its word for None, or a number of its type, checked."""
    word = knob.none or None

    def parse(text: str):
        if word is not None and text == word:
            return NONE
        if knob.type is str:
            return text
        try:
            value = knob.type(text)
        except ValueError:
            expected = f"{knob.type.__name__}" + (f" or {word}" if word else "")
            raise argparse.ArgumentTypeError(f"expected {expected}, got {text!r}") from None
        problem = knob.problem(value)
        if problem:
            raise argparse.ArgumentTypeError(problem)
        return value

    return parse


def given_knobs(arguments: argparse.Namespace) -> dict:
    """The knobs given on a command line parsed with ``add_knob_options``: {name: value}, None
    where the option said ``auto`` or ``none``."""
    given = {}
    for knob in KNOBS:
        value = getattr(arguments, knob.name, None)
        if knob.exposed and value is not None:
            given[knob.name] = None if value is NONE else value
    return given


def knob_table() -> str:
    """The README's knob table, in Markdown."""
    rows = ["| knob | default | values | what it buys |", "|---|---|---|---|"]
    for knob in KNOBS:
        default = f"None ({knob.none})" if knob.default is None else f"`{knob.default!r}`"
        values = knob.rule() + (f" ({knob.unit})" if knob.unit and knob.unit != "degrees" else "")
        if knob.none:
            values += f"; None ({knob.none} on command lines): {knob.none_means}"
        rows.append(f"| `{knob.name}` | {default} | {values} | {knob.description}. |")
    return "\n".join(rows)
