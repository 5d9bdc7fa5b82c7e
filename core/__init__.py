"""radiosity core: diffuse global illumination by the radiosity method, in NumPy; no bpy.

    from core import Scene, bake, form_factor_matrix, BakeCancelled
"""

from .bake import BakeResult, BakeSettings, bake
from .formfactors import form_factor_matrix
from .progress import BakeCancelled
from .scene import Scene

__all__ = ["Scene", "bake", "form_factor_matrix", "BakeCancelled", "BakeResult", "BakeSettings"]
