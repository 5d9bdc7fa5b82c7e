"""The light arriving at points of the surfaces, G = irradiance / pi, by where it comes from: the
lights and the sky (``direct``), the emitting patches, and every patch's radiosity (``engine``).
Every stage that needs light at points asks one ``ArrivingLight``."""

from __future__ import annotations

import numpy as np

from ..mesh.discretize import Discretization
from ..util.progress import Report, quiet
from .direct import DirectLighting
from .formfactors import FormFactorEngine


class ArrivingLight:
    """G at points (m, 3) facing unit normals (m, 3), as (m, C) arrays of the bake's C channels."""

    def __init__(self, engine: FormFactorEngine, direct: DirectLighting, channels: int) -> None:
        self.engine, self.direct, self.channels = engine, direct, channels

    @property
    def mesh(self) -> Discretization:
        return self.engine.mesh

    @property
    def has_direct(self) -> bool:
        """Whether there are lights or a sky (else ``from_lights`` is zero everywhere)."""
        return not self.direct.empty

    def refined(self, engine: FormFactorEngine) -> ArrivingLight:
        """The same lights over ``engine``'s (refined) patches."""
        return ArrivingLight(engine, self.direct, self.channels)

    def from_lights(self, points: np.ndarray, normals: np.ndarray, report: Report = quiet) -> np.ndarray:
        """From the lights and the sky, with their shadows."""
        return self.direct.at_points(points, normals, report)[:, : self.channels]

    def on_patches(self, patches: np.ndarray | None = None, report: Report = quiet) -> np.ndarray:
        """(k, C) from the lights and the sky, averaged over the ``patches`` (indices; None: all)."""
        mesh = self.mesh
        chosen = slice(None) if patches is None else patches
        return self.direct.patch_means(mesh.patch_corners[chosen], mesh.patch_normals[chosen], report)[:, : self.channels]

    def sharp(self, points: np.ndarray, normals: np.ndarray) -> np.ndarray:
        """From the emitting patches' first shot and the lights, without the sky: the direct
        light whose shadows start at a contact (``touching``)."""
        lit = self.engine.emitted_light(points, normals) + self.direct.lights_at(points, normals)
        return lit[:, : self.channels]

    def gathered(self, points: np.ndarray, normals: np.ndarray, radiosity: np.ndarray,
                 report: Report = quiet) -> np.ndarray:
        """From the patches of ``radiosity`` (P, C): sum_q F(point -> q) B_q."""
        return self.engine.gather(points, normals, radiosity, report)

    def total(self, points: np.ndarray, normals: np.ndarray, radiosity: np.ndarray,
              report: Report = quiet) -> np.ndarray:
        """All of it: gathered from the patches of ``radiosity`` (P, C), plus the lights and sky."""
        gathered = self.gathered(points, normals, radiosity, lambda f: report(f / 2))
        return gathered + self.from_lights(points, normals, lambda f: report(0.5 + f / 2))
