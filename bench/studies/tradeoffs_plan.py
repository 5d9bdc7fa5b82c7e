"""What the trade-off sweep bakes: per scene, each knob's values varied one at a time around the
defaults, for each method with each solver, plus the presets of core.settings (``Sweep``, FULL and
QUICK); what each benchmark scene's bakes are measured against (REFERENCES); and the plan of
cases those make, each bake once."""

from __future__ import annotations

from dataclasses import dataclass, field

from bench import exact, scenes
from bench.studies.tradeoffs_records import COMBOS, Case, Record
from core import BakeSettings, Scene
from core.mesh.discretize import discretize
from core.settings import (
    AUTO_PATCH_DIVISIONS, LARGE_SCENE_MONTE_CARLO_RAYS, LARGE_SCENE_SHOOTING, PRESETS, preset_knobs,
)

ONLY_FOR = {"hemicube_resolution": "hemicube", "rays_per_form_factor": "raycast"}  # knobs of one method
# knobs of some solvers: the hierarchical one splits links by link_tolerance and refines no levels
SOLVERS_OF = {"link_tolerance": ("hierarchical",), "refinement_levels": ("progressive", "jacobi", "gauss_seidel")}
EXPLICIT = ("jacobi", "gauss_seidel")  # the solvers of a P x P matrix
LINK_TOLERANCES = (0.1, 0.03, 0.003, 0.001)  # about the default 0.01


@dataclass(frozen=True)
class Sweep:
    """How one scene is swept: the values of each knob (``divisions``: patch size = extent / d),
    each varied alone from the defaults; the method/solver pairs; the solvers that only sweep the
    tolerance (Gauss-Seidel's form factors are Jacobi's, so its other curves would repeat
    Jacobi's); the presets; knobs every bake of the scene gets (``base``); the most patches an
    explicit solver (a P x P matrix) is given; the seconds after which a bake is stopped; and what
    the report should say about the choices."""

    divisions: tuple[int, ...] = (4, 8, 12, 16)
    values: dict = field(default_factory=lambda: {
        "hemicube_resolution": (16, 32, 64, 128),
        "rays_per_form_factor": (1, 4, 16, 64),
        "tolerance": (1e-1, 1e-2, 1e-3, 1e-4),
        "refinement_levels": (1, 2, 3),
        "merge_flat": (False,),
        "link_tolerance": LINK_TOLERANCES,
    })
    combos: tuple[tuple[str, str], ...] = COMBOS
    tolerance_only: tuple[str, ...] = ("gauss_seidel",)
    presets: tuple[str, ...] = ("DRAFT", "PREVIEW", "PRODUCTION", "REFERENCE")
    base: tuple[tuple[str, float], ...] = ()
    explicit_patches: int = 4000
    timeout: float = 300.0
    note: str = ""


@dataclass(frozen=True)
class Reference:
    """The converged reference of a benchmark scene: the project itself at extreme settings."""

    method: str
    solver: str
    divisions: int
    knobs: tuple[tuple[str, float], ...]
    timeout: float = 1200.0


@dataclass(frozen=True)
class PathTraced:
    """The answer of a benchmark scene where no bake of ours converges in minutes: path tracing at
    ``corners`` random corners, ``paths`` paths each (bench/corner_answer.py)."""

    corners: int
    paths: int
    timeout: float = 1200.0


FULL = {
    "furnace": Sweep(
        divisions=(2, 4, 8), values={"hemicube_resolution": (16, 32, 64, 128), "tolerance": (1e-1, 1e-2, 1e-3, 1e-4),
                                     "link_tolerance": LINK_TOLERANCES},
        presets=("DRAFT", "PREVIEW", "PRODUCTION"),
        note="Not swept: the rays (nothing occludes, so every visibility is 1 whatever the rays) and refinement "
        "(the radiosity is uniform, so no patch is split); the REFERENCE preset (tens of seconds a bake) is left out."),
    "parallel_squares": Sweep(
        divisions=(2, 4, 8, 16),
        values={"hemicube_resolution": (16, 32, 64, 128), "tolerance": (1e-1, 1e-2, 1e-3, 1e-4),
                "link_tolerance": LINK_TOLERANCES},
        note="Not swept: the rays (nothing occludes) and refinement."),
    "cie_room": Sweep(
        divisions=(2, 4, 8), values={"hemicube_resolution": (16, 32, 64, 128), "refinement_levels": (1, 2),
                                     "link_tolerance": LINK_TOLERANCES},
        presets=("DRAFT", "PREVIEW", "PRODUCTION"),
        note="Not swept: the rays (nothing occludes) and the tolerance (black walls: all light is shot in the "
        "source's first shots); the REFERENCE preset (a minute a bake) is left out."),
    "cornell": Sweep(presets=("DRAFT", "PREVIEW", "PRODUCTION"), explicit_patches=2500,
                     note="The REFERENCE preset (patches of extent / 16) is the `patch extent / 16` bake with a "
                     "tolerance of 1e-4 instead of 1e-3 (which the tolerance rows show does not matter here), so it "
                     "is not baked again. Explicit "
                     "solvers stop at patch size extent / 12 (2,318 patches before refinement)."),
    "sponza": Sweep(
        divisions=(4, 16), values={"monte_carlo_rays": (16, 256, 1024), "rays_per_form_factor": (1, 16),
                                   "max_shots": (300,), "near_field": (False,), "denoise": (0.0, 1.0, 6.0)},
        combos=(("raycast", "progressive"),), presets=(),
        base=(("monte_carlo_rays", LARGE_SCENE_MONTE_CARLO_RAYS), ("rays_per_form_factor", 4)), timeout=900.0,
        note="Sponza is large for these methods: shooting to convergence takes about a shot per patch, each to "
        "every patch and vertex, hours here. So every bake is what the add-on does by default where a round of "
        f"shots costs {LARGE_SCENE_SHOOTING:,} form factors or more (Monte Carlo \"Auto\", core/settings.py): the "
        "emitters shoot, "
        "and the light they leave goes on by Monte Carlo (particles from the patches, then a final gather at the "
        f"vertices: core/solve/montecarlo.py, core/solve/gather.py) with {LARGE_SCENE_MONTE_CARLO_RAYS} gather rays "
        "per vertex unless swept, and 4 rays per form factor unless swept (as docs/results/sponza.md). `max_shots`: "
        "the brightest patches shoot too, this many shots in all, before Monte Carlo takes the rest. `near_field` off: "
        "every patch is read as its mean, also where the gather's rays land close. The patch size changes only the "
        "largest triangles (patches are never larger than the input triangles and their pieces). Left out: Jacobi and "
        "Gauss-Seidel (a P x P matrix, hundreds of GB); the hemicube, whose gather at the vertices alone takes minutes "
        "here (dense rows, O(vertices x patches)); the presets, whose tolerances no bake reaches in minutes. The "
        "yardstick is not a bake of ours but path tracing at random corners (above), so these errors are against the "
        "scene's light, as docs/results/path_traced.md measures Cycles' bakes and ours."),
}
QUICK = {
    "parallel_squares": Sweep(divisions=(2, 4), values={"hemicube_resolution": (16,), "rays_per_form_factor": (4,),
                                                        "tolerance": (1e-2,)},
                              combos=(("raycast", "progressive"), ("hemicube", "jacobi")), presets=("DRAFT",)),
    "furnace": Sweep(divisions=(4,), values={"tolerance": (1e-2,)},
                     combos=(("raycast", "progressive"), ("raycast", "jacobi")), presets=()),
    "cornell": Sweep(divisions=(4,), values={"tolerance": (1e-2,), "link_tolerance": (0.03,)},
                     combos=(("raycast", "progressive"), ("raycast", "hierarchical")), presets=("DRAFT",)),
}
REFERENCES = {
    "cornell": Reference("raycast", "jacobi", 24, (("probe_rays", False), ("rays_per_form_factor", 16),
                                                   ("tolerance", 1e-6))),
    # no bake of ours converges on Sponza: 32,000 paths at 1,000 corners, 0.8 of the path_traced
    # study's 40,000 there, for sqrt(40 / 32) times its noise
    "sponza": PathTraced(corners=1000, paths=32_000),
}
QUICK_REFERENCES = {
    "cornell": Reference("raycast", "jacobi", 4, (("rays_per_form_factor", 16), ("tolerance", 1e-6))),
}


def scene_of(name: str) -> Scene:
    """The scene ``name``: a problem with an exact answer (bench/exact.py) or a benchmark scene."""
    return exact.PROBLEMS[name]().scene if name in exact.PROBLEMS else scenes.load(name)


def uses(method: str, solver: str, knob: str) -> bool:
    """Whether bakes by ``method`` and ``solver`` depend on ``knob`` (in scenes without lights or sky)."""
    return ONLY_FOR.get(knob, method) == method and solver in SOLVERS_OF.get(knob, (solver,))


def make_case(name: str, scene: Scene, method: str, solver: str, divisions: int, knobs: dict,
              sweep: Sweep, tag: str) -> Case:
    """A case with the patch size extent / ``divisions``, the scene's base knobs and ``knobs``,
    less those at bake()'s defaults (so that the same bake is one case, whatever it is called)."""
    settings = BakeSettings()
    chosen = {key: value for key, value in (dict(sweep.base) | knobs).items() if getattr(settings, key) != value}
    every = chosen | {"patch_size": scene.extent / divisions}
    return Case(name, method, solver, tuple(sorted(every.items())), divisions, (tag,))


def variations(method: str, solver: str, sweep: Sweep) -> list[tuple[str, int, dict]]:
    """(tag, divisions, knobs) of the defaults, of each knob varied alone, and of each preset."""
    tolerance_only = solver in sweep.tolerance_only
    result = [("default", AUTO_PATCH_DIVISIONS, {})]
    if not tolerance_only:
        result += [("patch_size", divisions, {}) for divisions in sweep.divisions]
    for knob, values in sweep.values.items():
        if uses(method, solver, knob) and (knob == "tolerance" or not tolerance_only):
            result += [(knob, AUTO_PATCH_DIVISIONS, {knob: value}) for value in values]
    for name in sweep.presets:
        knobs = {key: value for key, value in preset_knobs(name, 1.0).items()
                 if key != "patch_size" and uses(method, solver, key)}
        result.append((f"preset:{name}", PRESETS[name].patch_divisions, knobs))
    return result


def plan(name: str, scene: Scene, sweep: Sweep) -> tuple[list[Case], list[Record]]:
    """The scene's cases, each bake once with all its tags; and the explicit-solver cases left out
    because their matrix would have more than ``sweep.explicit_patches`` rows."""
    cases: dict[tuple, Case] = {}
    patches: dict[int, int] = {}
    skipped = []
    for method, solver in sweep.combos:
        for tag, divisions, knobs in variations(method, solver, sweep):
            case = make_case(name, scene, method, solver, divisions, knobs, sweep, tag)
            if case.key in cases:
                previous = cases[case.key]
                cases[case.key] = Case(*case.key, divisions, previous.tags + (tag,) * (tag not in previous.tags))
                continue
            if solver in EXPLICIT:
                count = patches.setdefault(divisions, discretize(scene, scene.extent / divisions).patch_count)
                if count > sweep.explicit_patches:
                    skipped.append(Record(case, status=f"skipped: a {count:,} x {count:,} matrix"))
                    continue
            cases[case.key] = case
    return list(cases.values()), skipped


def print_plan(sweeps: dict[str, Sweep], scenes_by_name: dict[str, Scene]) -> None:
    """The cases of every scene, and those left out."""
    for name, sweep in sweeps.items():
        cases, skipped = plan(name, scenes_by_name[name], sweep)
        print(f"{name}: {len(cases)} bakes, {len(skipped)} left out")
        for case in cases:
            knobs = ", ".join(f"{key} {value:g}" for key, value in case.knobs)
            print(f"  {case.combo}: {knobs} [{', '.join(case.tags)}]")
        for record in skipped:
            print(f"  {record.case.combo} {', '.join(record.case.tags)}: {record.status}")


