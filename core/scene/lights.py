"""Lights that are not surfaces (point, spot, sun, area), in Blender's units and with Cycles'
conventions (measured with Blender 5.0.1, ../shared/CYCLES.md); they light the surfaces but are
not surfaces themselves: they neither block nor reflect light. What each gives at a point is
``transport.direct``'s. Each has ``casts_shadow`` (Blender's Cast Shadow, ``Light.use_shadow``):
without it, its light reaches every point that faces it, through whatever lies between, as
Cycles renders such a light (no shadow rays).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Iterable

import numpy as np

from ..util.geometry import areas_and_normals

def _vector(name: str, value, nonnegative: bool = False) -> np.ndarray:
    array = np.array(value, dtype=np.float64).reshape(-1)
    if array.shape != (3,) or not np.isfinite(array).all():
        raise ValueError(f"{name} must be 3 finite numbers, got {value!r}")
    if nonnegative and (array < 0).any():
        raise ValueError(f"{name} must not be negative, got {array.tolist()}")
    array.setflags(write=False)
    return array


def _direction(name: str, value) -> np.ndarray:
    array = np.array(_vector(name, value))
    length = np.linalg.norm(array)
    if length == 0:
        raise ValueError(f"{name} must not be the zero vector")
    array /= length
    array.setflags(write=False)
    return array


def _check_size(name: str, value: float) -> None:
    if not (math.isfinite(value) and value >= 0):
        raise ValueError(f"{name} must be a finite number >= 0, got {value}")


@dataclass(frozen=True, eq=False)
class PointLight:
    """position (3,) world space; power (3,) W per channel (Blender: power x colour); radius
    (Blender's Radius): a sphere of that radius, which lights as its centre does but casts soft
    shadows; with ``soft_falloff`` (Blender's Soft Falloff, on by default there) Cycles lights by
    a disc of that radius facing each point instead, dimmer near the light: its irradiance is the
    centre's times d^2 / (d^2 + radius^2) at distance d."""

    position: np.ndarray
    power: np.ndarray
    radius: float = 0.0
    casts_shadow: bool = True
    soft_falloff: bool = False

    def __post_init__(self) -> None:
        object.__setattr__(self, "position", _vector("position", self.position))
        object.__setattr__(self, "power", _vector("power", self.power, nonnegative=True))
        _check_size("radius", self.radius)


@dataclass(frozen=True, eq=False)
class SpotLight:
    """A point light shining into a cone: direction (3,) its axis; spot_size the cone's full
    angle in radians, (0, pi]; spot_blend in [0, 1] the soft share of the edge; radius and
    soft_falloff as a PointLight's."""

    position: np.ndarray
    direction: np.ndarray
    power: np.ndarray
    spot_size: float
    spot_blend: float = 0.15
    radius: float = 0.0
    casts_shadow: bool = True
    soft_falloff: bool = False

    def __post_init__(self) -> None:
        object.__setattr__(self, "position", _vector("position", self.position))
        object.__setattr__(self, "direction", _direction("direction", self.direction))
        object.__setattr__(self, "power", _vector("power", self.power, nonnegative=True))
        _check_size("radius", self.radius)
        if not 0 < self.spot_size <= math.pi:
            raise ValueError(f"spot_size must be in (0, pi] radians, got {self.spot_size}")
        if not 0 <= self.spot_blend <= 1:
            raise ValueError(f"spot_blend must be in [0, 1], got {self.spot_blend}")

    def cone_mask(self, towards_points: np.ndarray) -> np.ndarray:
        """(...,) Cycles' spot attenuation for unit vectors (..., 3) from the light to the points."""
        cos_half = math.cos(self.spot_size / 2)
        cosine = towards_points @ self.direction
        smooth = (1 - cos_half) * self.spot_blend
        if smooth <= 0:
            return (cosine > cos_half).astype(np.float64)
        t = np.clip((cosine - cos_half) / smooth, 0.0, 1.0)
        return t * t * (3 - 2 * t)


@dataclass(frozen=True, eq=False)
class SunLight:
    """direction (3,) the way the light travels; strength (3,) W/m^2 per channel (Blender:
    strength x colour), the irradiance of a surface facing the sun; angle (Blender's Angle) the
    sun's angular diameter in radians, [0, pi), which softens its shadows."""

    direction: np.ndarray
    strength: np.ndarray
    angle: float = 0.0
    casts_shadow: bool = True

    def __post_init__(self) -> None:
        object.__setattr__(self, "direction", _direction("direction", self.direction))
        object.__setattr__(self, "strength", _vector("strength", self.strength, nonnegative=True))
        _check_size("angle", self.angle)
        if self.angle >= math.pi:
            raise ValueError(f"angle must be below pi radians, got {self.angle}")


@dataclass(frozen=True, eq=False)
class AreaLight:
    """A flat emitter shining from the front of its triangles (K, 3, 3) (right-hand rule);
    power (3,) W per channel over their total area A: radiance P / (pi A), times, with a
    ``spread`` s below pi (Blender's Spread, radians), Cycles' soft box
    ``spread_profile``: the same power, narrowed to the cone of half-angle s / 2 about its normal."""

    triangles: np.ndarray
    power: np.ndarray
    casts_shadow: bool = True
    spread: float = math.pi

    def __post_init__(self) -> None:
        triangles = np.array(self.triangles, dtype=np.float64)
        if triangles.ndim != 3 or triangles.shape[1:] != (3, 3) or len(triangles) == 0:
            raise ValueError(f"triangles must have shape (K, 3, 3) with K >= 1, got {triangles.shape}")
        if not np.isfinite(triangles).all():
            raise ValueError("triangles must be finite")
        if areas_and_normals(triangles)[0].sum() <= 0:
            raise ValueError("an area light must have a positive area")
        triangles.setflags(write=False)
        object.__setattr__(self, "triangles", triangles)
        object.__setattr__(self, "power", _vector("power", self.power, nonnegative=True))
        if not 0 < self.spread <= math.pi:
            raise ValueError(f"spread must be in (0, pi] radians, got {self.spread}")

    def spread_profile(self, cosines: np.ndarray) -> np.ndarray:
        """The radiance along directions at cosines (any shape) to the light's normal, over the
        unspread light's: max(tan(s / 2) - tan a, 0) / (tan(s / 2) - s / 2), s the spread, a the
        angle (Cycles' ``area_light_spread_attenuation``: the share a soft box's slats let
        through, scaled to keep the power: its integral with cos a over the hemisphere is pi);
        1 for a spread of pi."""
        if self.spread >= math.pi:
            return np.ones_like(cosines)
        half = self.spread / 2
        cosines = np.clip(cosines, 0.0, 1.0)
        tangents = np.sqrt(1.0 - cosines**2) / np.maximum(cosines, np.finfo(float).tiny)
        return np.maximum(math.tan(half) - tangents, 0.0) / (math.tan(half) - half)

    @property
    def radiance(self) -> np.ndarray:
        """(3,) P / (pi A)."""
        return self.power / (math.pi * areas_and_normals(self.triangles)[0].sum())


# Sides of the polygon that stands for a disk or ellipse light (same area as the ellipse): its
# form factors differ from the ellipse's by O(1/n^2) near the rim (tests/core/test_lights.py).
ELLIPSE_SEGMENTS = 32
AREA_SHAPES = ("SQUARE", "RECTANGLE", "DISK", "ELLIPSE")


def area_light(shape: str, size: float, size_y: float, matrix: np.ndarray, power, normalize: bool = True,
               casts_shadow: bool = True, spread: float = math.pi) -> AreaLight:
    """The AreaLight of a Blender area light: ``shape`` one of AREA_SHAPES, ``size`` (and
    ``size_y`` for RECTANGLE and ELLIPSE) its widths in its local XY plane, shining down its
    local -Z axis; ``matrix`` (4, 4) local to world (scale included). Without ``normalize``
    (a setting of newer Blender: 5.0 has it, 4.2 not), ``power`` is what each square unit of the
    light emits."""
    if shape not in AREA_SHAPES:
        raise ValueError(f"area light shape must be one of {AREA_SHAPES}, got {shape!r}")
    width = size
    height = size if shape in ("SQUARE", "DISK") else size_y
    if not (width > 0 and height > 0):
        raise ValueError(f"an area light needs positive sizes, got {width} x {height}")
    if shape in ("SQUARE", "RECTANGLE"):
        outline = np.array([[1, 1], [1, -1], [-1, -1], [-1, 1]]) / 2  # clockwise from +Z
    else:
        n = ELLIPSE_SEGMENTS
        angle = -2 * np.pi * np.arange(n) / n
        stretch = np.sqrt(2 * np.pi / (n * np.sin(2 * np.pi / n)))  # same area as the ellipse
        outline = stretch * np.stack([np.cos(angle), np.sin(angle)], axis=1) / 2
    matrix = np.asarray(matrix, dtype=np.float64)
    local = np.column_stack([outline * [width, height], np.zeros(len(outline)), np.ones(len(outline))])
    world = (local @ matrix.T)[:, :3]
    fan = np.stack([np.zeros(len(world) - 2, int), np.arange(1, len(world) - 1), np.arange(2, len(world))], axis=1)
    triangles = world[fan]
    # a mirroring matrix keeps the winding but turns local -Z around: face where -Z points
    if np.cross(triangles[0, 1] - triangles[0, 0], triangles[0, 2] - triangles[0, 0]) @ matrix[:3, 2] > 0:
        triangles = triangles[:, ::-1]
    if not normalize:
        power = np.asarray(power, dtype=np.float64) * areas_and_normals(triangles)[0].sum()
    return AreaLight(triangles, power, casts_shadow, spread)


LIGHT_TYPES = (PointLight, SpotLight, SunLight, AreaLight)


def check_lights(lights: Iterable) -> tuple:
    """The lights as a tuple; TypeError naming the first item that is not a light."""
    lights = tuple(lights)
    for index, light in enumerate(lights):
        if not isinstance(light, LIGHT_TYPES):
            raise TypeError(f"lights[{index}] is a {type(light).__name__}, not one of "
                            f"{', '.join(t.__name__ for t in LIGHT_TYPES)}")
    return lights


@dataclass(frozen=True)
class Environment:
    """Sky light that varies with direction: an equirectangular image of radiance, as Blender's
    Environment Texture in the world (times the Background's strength), in W/(m^2 sr) per unit of
    G, so that a uniform image of value c gives the same light as ``Scene.sky`` = c.

    radiance : (H, W, 3) float >= 0, linear; row 0 at the bottom (v = 0), as Blender stores images.
    rotation : (3, 3), turns a world direction into the image's frame (a Mapping node's rotation).

    The direction d (in the image's frame) reads u = 1/2 - atan2(d_y, d_x) / (2 pi) and
    v = 1 - acos(d_z) / pi (Cycles' direction_to_equirectangular), the nearest pixel."""

    radiance: np.ndarray
    rotation: np.ndarray | None = None  # None: the identity

    def __post_init__(self) -> None:
        radiance = np.array(self.radiance, dtype=np.float64)
        if radiance.ndim != 3 or radiance.shape[2] != 3 or min(radiance.shape[:2]) < 1:
            raise ValueError(f"the environment's radiance must have shape (H, W, 3), got {radiance.shape}")
        if not np.isfinite(radiance).all() or (radiance < 0).any():
            raise ValueError("the environment's radiance must be finite and not negative")
        rotation = np.eye(3) if self.rotation is None else np.array(self.rotation, dtype=np.float64)
        if rotation.shape != (3, 3) or not np.allclose(rotation @ rotation.T, np.eye(3), atol=1e-6):
            raise ValueError("the environment's rotation must be a 3 x 3 rotation matrix")
        for name, value in (("radiance", radiance), ("rotation", rotation)):
            value.setflags(write=False)
            object.__setattr__(self, name, value)

    def at(self, directions: np.ndarray) -> np.ndarray:
        """(..., 3) radiance arriving from unit world ``directions`` (..., 3)."""
        local = directions @ self.rotation.T
        height, width = self.radiance.shape[:2]
        u = 0.5 - np.arctan2(local[..., 1], local[..., 0]) / (2 * math.pi)
        v = 1.0 - np.arccos(np.clip(local[..., 2], -1.0, 1.0)) / math.pi
        column = np.floor(u * width).astype(np.int64) % width
        row = np.minimum(np.floor(v * height).astype(np.int64), height - 1)
        return self.radiance[row, column]


def source_intensities(lights: tuple, sky: np.ndarray | None, environment: float | None) -> np.ndarray:
    """(S, 3) the intensities of the light sources (``transport.direct``): each light's power (a sun's
    strength), then the sky's colour (None: no sky), then ``environment`` (a scale of its
    image; None: no environment) in every channel."""
    rows = [light.strength if isinstance(light, SunLight) else light.power for light in lights]
    if sky is not None:
        rows.append(np.asarray(sky, dtype=np.float64))
    if environment is not None:
        rows.append(np.full(3, float(environment)))
    return np.array(rows, dtype=np.float64).reshape(-1, 3)
