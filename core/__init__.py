"""radiosity core: diffuse global illumination by the radiosity method, in NumPy; no bpy.

    from core import Scene, PointLight, bake, BakeCancelled
    result = bake(scene, progress=print)  # result.corner_colors: (T, 3, 3) linear RGB
    session = BakeSession(); session.bake(scene); session.bake(recoloured)  # the second re-solves

The pipeline, one package per stage: ``scene`` (the model) -> ``mesh`` (panels, patches,
receiver nodes) -> ``transport`` (form factors, direct light) -> ``solve`` -> ``reconstruct``
(per-corner colours, the error estimate); ``rays`` traces every ray, ``util`` holds the rest.
"""

from .bake import BakeResult, BakeSession, bake
from .job import BakeJob
from .scene import AreaLight, Environment, PointLight, Scene, SpotLight, SunLight, area_light, read_obj
from .settings import KNOBS, PRESETS, BakeSettings
from .transport.formfactors import form_factor_matrix
from .util.progress import BakeCancelled

__all__ = ["Scene", "Environment", "PointLight", "SpotLight", "SunLight", "AreaLight", "area_light", "read_obj", "bake",
           "BakeResult", "BakeSession", "BakeSettings", "BakeCancelled", "BakeJob", "KNOBS", "PRESETS",
           "form_factor_matrix"]
