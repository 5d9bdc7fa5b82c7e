"""Transport: form factors between points and patches (exact, hemicube, ray cast), the direct light
of lights and sky, and the light arriving at any point of the surfaces."""

from .arriving import ArrivingLight
from .formfactors import FormFactorEngine, form_factor_matrix

__all__ = ["ArrivingLight", "FormFactorEngine", "form_factor_matrix"]
