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
    """G at points (m, 3) facing unit normals (m, 3), as (m, C) arrays of the bake's C channels.

    ``intensities`` (S, 3): the light sources' (``DirectLighting``; default: their own). ``kept``:
    a dict in which the form factors to the emitters and the lights' shadows at the points asked
    for ``sharp`` are kept, point by point, to be found again by a re-solve asking there."""

    def __init__(self, engine: FormFactorEngine, direct: DirectLighting, channels: int,
                 intensities: np.ndarray | None = None, kept: dict | None = None) -> None:
        self.engine, self.direct, self.channels = engine, direct, channels
        self.intensities = direct.intensities() if intensities is None else intensities
        self.kept = kept

    @property
    def mesh(self) -> Discretization:
        return self.engine.mesh

    @property
    def has_direct(self) -> bool:
        """Whether there are lights or a sky (else ``from_lights`` is zero everywhere)."""
        return not self.direct.empty

    def refined(self, engine: FormFactorEngine) -> ArrivingLight:
        """The same lights over ``engine``'s (refined) patches."""
        return ArrivingLight(engine, self.direct, self.channels, self.intensities, self.kept)

    def from_lights(self, points: np.ndarray, normals: np.ndarray, report: Report = quiet) -> np.ndarray:
        """From the lights and the sky, with their shadows."""
        return self.combined(self.direct.factors_at(points, normals, report))

    def factors_on_patches(self, patches: np.ndarray | None = None, report: Report = quiet) -> np.ndarray:
        """(k, S, 3) the lights' and the sky's light averaged over the ``patches`` (indices; None:
        all), per source and unit of its intensity (``DirectLighting``; ``combined`` sums them)."""
        mesh = self.mesh
        chosen = slice(None) if patches is None else patches
        return self.direct.patch_factors(mesh.patch_corners[chosen], mesh.patch_normals[chosen], report)

    def combined(self, factors: np.ndarray) -> np.ndarray:
        """(m, C) the light of the sources' ``factors`` (m, S, 3) at this light's intensities."""
        return self.direct.combine(factors, self.intensities)[:, : self.channels]

    def light_parts(self, factors: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The L lights' part (m, C) of the light of ``factors`` (m, S, 3) (``combined``), and their
        intensities (L, C) (the sky and an environment come after them)."""
        lights = len(self.direct.lights)
        return (self.direct.combine(factors[:, :lights], self.intensities[:lights])[:, : self.channels],
                self.intensities[:lights, : self.channels])

    def sky_parts(self, factors: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
        """The uniform sky's part (m, C) of the light of ``factors`` (m, S, 3) (``combined``), and
        the light G (C,) it gives a point open to all of it; None without a sky."""
        if not self.direct.sky.any():
            return None
        index = len(self.direct.lights)  # the sky comes after the lights
        intensity = self.intensities[index, : self.channels]
        return factors[:, index, : self.channels] * intensity, intensity

    def sharp(self, points: np.ndarray, normals: np.ndarray, finely: bool = True) -> np.ndarray:
        """From the emitting patches' first shot and the lights, without the sky: the direct
        light whose shadows start at a contact (``touching``); the emitters read ``finely`` as
        at the nodes, or with the bake's rays as at the patches
        (``FormFactorEngine.emitter_form_factors``)."""
        emitters, to_emitters, light_factors = self._sharp_factors(points, normals, finely)
        lights = len(self.direct.lights)
        lit = to_emitters @ self.mesh.patch_emission[emitters] + self.direct.combine(light_factors,
                                                                                   self.intensities[:lights])
        return lit[:, : self.channels]

    def _sharp_factors(self, points: np.ndarray, normals: np.ndarray, finely: bool) -> tuple:
        """The emitting patches (e,), the form factors (m, e) to them and the lights' ``factors``
        (m, L, 3) at points (m, 3) facing normals (m, 3). With ``kept``, they are kept per point
        (its position and normal, to the bit): a re-solve asks at many of the same points, but in
        other sets (the touching pairs read are those of the patches lit then), and measures only
        the points not asked at before, while the emitting patches are the same (those read
        coarsely apart, in ``kept["coarse"]``)."""
        if self.kept is None or len(points) == 0:
            return (*self.engine.emitter_form_factors(points, normals, finely),
                    self.direct.light_factors_at(points, normals))
        emitters = np.flatnonzero(self.mesh.patch_emission.any(axis=1))
        if not np.array_equal(self.kept.get("emitters", emitters), emitters):
            self.kept.clear()
        kept = self.kept if finely else self.kept.setdefault("coarse", {})
        keys = np.ascontiguousarray(np.concatenate([points, normals], axis=1), dtype=np.float64)
        keys = keys.view(f"V{keys.shape[1] * keys.itemsize}").ravel()
        known = kept.get("points", keys[:0])
        place = np.searchsorted(known, keys)
        new = place >= len(known)
        new[~new] = known[place[~new]] != keys[~new]
        if new.any():
            added, first = np.unique(keys[new], return_index=True)
            rows = np.flatnonzero(new)[first]
            _, to_emitters = self.engine.emitter_form_factors(points[rows], normals[rows], finely)
            light_factors = self.direct.light_factors_at(points[rows], normals[rows])
            merged = np.concatenate([known, added])
            order = np.argsort(merged, kind="stable")
            kept["points"] = merged[order]
            for name, values in (("to_emitters", to_emitters), ("light_factors", light_factors)):
                kept[name] = np.concatenate([kept[name], values])[order] if name in kept else values
            self.kept["emitters"] = emitters
            place = np.searchsorted(kept["points"], keys)
        return emitters, kept["to_emitters"][place], kept["light_factors"][place]

    def gathered(self, points: np.ndarray, normals: np.ndarray, radiosity: np.ndarray,
                 report: Report = quiet) -> np.ndarray:
        """From the patches of ``radiosity`` (P, C): sum_q F(point -> q) B_q."""
        return self.engine.gather(points, normals, radiosity, report)

    def total(self, points: np.ndarray, normals: np.ndarray, radiosity: np.ndarray,
              report: Report = quiet) -> np.ndarray:
        """All of it: gathered from the patches of ``radiosity`` (P, C), plus the lights and sky."""
        gathered = self.gathered(points, normals, radiosity, lambda f: report(f / 2))
        return gathered + self.from_lights(points, normals, lambda f: report(0.5 + f / 2))
