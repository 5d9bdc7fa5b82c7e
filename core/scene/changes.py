"""What changed between two scenes: only colours and intensities (a re-solve can reuse the
geometry work of the first bake: ``bake.BakeSession``), or more (a new bake)."""

from __future__ import annotations

import dataclasses

import numpy as np

from ..util.rows import sorted_labels
from .lights import source_intensities
from .model import Scene

# The fields of each light that are not its intensity: a change in any of them changes where its
# light falls (its place, shape, shadows, falloff or spread).
INTENSITY_FIELDS = ("power", "strength")
# An environment image that is this close to a multiple of the first (its Background's strength
# changed) scales that one's light.
PROPORTIONAL = 1e-9


def geometry_change(first: Scene, now: Scene) -> str | None:
    """In words, what differs between ``first`` and ``now`` beyond the surfaces' reflectance
    and emission, the lights' power (a sun's strength), the sky's colour and the environment's
    strength; None if nothing. A triangle that starts to emit, a sky that was black and an
    environment image that is not a multiple of the first count as changes (their light was
    never traced)."""
    for name in ("vertices", "triangles", "two_sided", "casts_shadows", "opacity"):
        if not _same(getattr(first, name), getattr(now, name)):
            return f"the scene's {name.replace('_', ' ')} changed"
    if (first.corner_normals is None) != (now.corner_normals is None) or (
            first.corner_normals is not None and not _same(first.corner_normals, now.corner_normals)):
        return "the shading normals changed"
    pairs = sorted_labels(np.stack([first.material, now.material], axis=1))[0]
    if not len(pairs) == len(np.unique(first.material)) == len(np.unique(now.material)):
        return "the triangles' materials are grouped differently"
    if (now.emission.any(axis=1) & ~first.emission.any(axis=1)).any():
        return "a triangle that did not emit emits now"
    if len(first.lights) != len(now.lights):
        return "lights were added or removed"
    for index, (was, light) in enumerate(zip(first.lights, now.lights)):
        if type(was) is not type(light) or any(
                not _same(getattr(was, field.name), getattr(light, field.name))
                for field in dataclasses.fields(was) if field.name not in INTENSITY_FIELDS):
            return f"light {index} moved or changed its shape, shadows, falloff or spread"
    if now.sky.any() and not first.sky.any():
        return "the sky was black"
    if environment_scale(first, now) is None:
        return "the environment image changed"
    return None


def environment_scale(first: Scene, now: Scene) -> float | None:
    """The factor k with ``now``'s environment = k x ``first``'s (0 when ``now`` has none),
    1 when neither has one, None when it is no multiple of it."""
    if first.environment is None:
        return 1.0 if now.environment is None else None
    if now.environment is None:
        return 0.0
    was, image = first.environment.radiance, now.environment.radiance
    if was.shape != image.shape or not _same(first.environment.rotation, now.environment.rotation):
        return None
    scale = float(image.sum() / was.sum()) if was.sum() > 0 else 0.0
    if np.abs(image - scale * was).max() > PROPORTIONAL * max(float(np.abs(image).max()), 1e-300):
        return None
    return scale


def intensities(first: Scene, now: Scene) -> np.ndarray:
    """(S, 3) the intensities of the light sources of ``first`` (``transport.direct``'s order:
    the lights, the sky if ``first`` had one, its environment) as they are in ``now``, a scene
    without ``geometry_change``."""
    return source_intensities(now.lights, now.sky if first.sky.any() else None,
                              None if first.environment is None else environment_scale(first, now))


def _same(a, b) -> bool:
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        return np.shape(a) == np.shape(b) and bool(np.array_equal(a, b))
    return a == b
