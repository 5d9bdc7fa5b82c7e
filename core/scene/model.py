"""The scene model: triangles with diffuse reflectance and emission, validated on construction."""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from ..util.rows import sorted_labels
from .lights import Environment, check_lights


# Areas and form-factor kernels take squares and fourth powers of lengths: beyond these, float64
# over- or underflows (1e50 ** 4 = 1e200; at 1e-75 units every bake still matched to 1e-15).
MAX_COORDINATE = 1e50
MIN_EXTENT = 1e-50


def _unit_corner_normals(normals, count: int) -> np.ndarray:
    """(T, 3, 3) float64 unit normals; ValueError unless finite and of non-zero length."""
    array = np.array(normals, dtype=np.float64)
    if array.shape != (count, 3, 3):
        raise ValueError(f"corner_normals must have shape ({count}, 3, 3), got {array.shape}")
    length = np.linalg.norm(array, axis=2, keepdims=True)
    if not np.isfinite(array).all() or (length <= 0).any():
        raise ValueError("corner_normals must be finite vectors of non-zero length")
    return array / length


def _first_bad(mask: np.ndarray) -> int:
    """Index of the first row where ``mask`` is True (mask reduced over trailing axes)."""
    rows = mask.reshape(mask.shape[0], -1).any(axis=1)
    return int(np.flatnonzero(rows)[0])


def _as_float_array(name: str, value, shape_tail: tuple[int, ...]) -> np.ndarray:
    array = np.asarray(value)
    if array.dtype.kind not in "fiu":
        raise ValueError(f"{name} must be a numeric array, got dtype {array.dtype}")
    array = np.array(array, dtype=np.float64, order="C")  # a copy: the scene freezes its arrays
    if array.ndim != 1 + len(shape_tail) or array.shape[1:] != shape_tail:
        expected = "(n, " + ", ".join(map(str, shape_tail)) + ")" if shape_tail else "(n,)"
        raise ValueError(f"{name} must have shape {expected}, got {array.shape}")
    if not np.isfinite(array).all():
        bad = _first_bad(~np.isfinite(array))
        raise ValueError(f"{name}[{bad}] is not finite: {array[bad]}")
    return array


@dataclass(frozen=True, eq=False)
class Scene:
    """Triangles that reflect diffusely and may emit, per colour channel (linear RGB).

    vertices : (V, 3) float, world space.
    triangles : (T, 3) int, indices into ``vertices``; the front side follows the right-hand
        rule (counter-clockwise seen from the front).
    reflectance : (T, 3) float in [0, 1), diffuse albedo rho per channel.
    emission : (T, 3) float >= 0, emitted radiosity E (Blender: emission colour x strength).
    material : (T,) int, optional; triangles of different materials never share a receiver
        node, so colour may jump at a material border. Default: one material per distinct
        (reflectance, emission).
    two_sided : (T,) bool, optional; a two-sided triangle reflects and emits on both sides
        (as Cycles' Diffuse BSDF and Emission do); the back side is its own surface.
        Default: all one-sided.
    casts_shadows : (T,) bool, optional; a triangle that does not cast shadows hides nothing
        (light passes it on its way to anything behind) but still receives, reflects and emits,
        as Cycles' Shadow ray visibility off (with the hemicube it still hides what is behind it).
        Default: every triangle casts.
    opacity : (T,) float in [0, 1], optional; the share of the light arriving at a triangle that it
        stops (Blender: a Principled BSDF's Alpha, a Transparent BSDF mixed in); the rest passes
        straight through it to what lies behind (1: opaque, the default). ``reflectance`` and
        ``emission`` are the triangle's as a whole: a leaf card of opacity 0.5 reflects half what
        its opaque part would (Cycles' Mix of Transparent and the surface by alpha).
    corner_normals : (T, 3, 3) float, optional; the shading normal at each corner (Blender's
        corner normals: a flat face's own normal, a smooth face's vertex normal, split at sharp
        edges). Given, corners share a receiver node only where their normals agree, and the node
        faces that way, as Cycles shades each corner; the bake's crease angle is then not used.
        Default: nodes joined across edges below the crease angle.
    lights : point, spot, sun and area lights (``core.lights``); they light the surfaces but
        are not surfaces themselves.
    sky : (3,) float >= 0, the colour x strength of a uniform sky around the scene (Blender's
        world colour): it lights every surface that sees it.
    environment : ``lights.Environment``, optional; sky light that varies with direction (an
        HDRI), added to ``sky``.
    """

    vertices: np.ndarray
    triangles: np.ndarray
    reflectance: np.ndarray
    emission: np.ndarray
    material: np.ndarray | None = None
    two_sided: np.ndarray | None = field(default=None)
    corner_normals: np.ndarray | None = field(default=None)
    lights: tuple = ()
    casts_shadows: np.ndarray | None = field(default=None)
    environment: Environment | None = None
    sky: np.ndarray | None = None
    opacity: np.ndarray | None = None

    def __post_init__(self) -> None:
        vertices = _as_float_array("vertices", self.vertices, (3,))
        triangles = np.asarray(self.triangles)
        if triangles.dtype.kind not in "iu":
            raise ValueError(f"triangles must be an integer array, got dtype {triangles.dtype}")
        if triangles.ndim != 2 or triangles.shape[1] != 3:
            raise ValueError(f"triangles must have shape (T, 3), got {triangles.shape}")
        if len(triangles) == 0:
            raise ValueError("the scene has no triangles")
        triangles = np.array(triangles, dtype=np.int64, order="C")
        out_of_range = (triangles < 0) | (triangles >= len(vertices))
        if out_of_range.any():
            bad = _first_bad(out_of_range)
            raise ValueError(
                f"triangles[{bad}] = {triangles[bad].tolist()} indexes outside vertices "
                f"(there are {len(vertices)})"
            )
        used = vertices[np.unique(triangles)]
        size = float(np.abs(used).max()) if len(used) else 0.0
        if size > MAX_COORDINATE or 0 < float(np.ptp(used, axis=0).max()) < MIN_EXTENT:
            raise ValueError(
                f"the vertices span {float(np.ptp(used, axis=0).max()):.3g} units with coordinates up to {size:.3g}: "
                f"areas would leave the range of float64; scale the scene into [{MIN_EXTENT:g}, {MAX_COORDINATE:g}]"
            )
        count = len(triangles)
        reflectance = _per_triangle("reflectance", self.reflectance, count)
        if (reflectance < 0).any():
            bad = _first_bad(reflectance < 0)
            raise ValueError(f"reflectance[{bad}] = {reflectance[bad].tolist()} is negative")
        if (reflectance >= 1).any():
            bad = _first_bad(reflectance >= 1)
            raise ValueError(
                f"reflectance[{bad}] = {reflectance[bad].tolist()} is >= 1: a surface must absorb "
                "some light, or a closed scene has no finite solution"
            )
        emission = _per_triangle("emission", self.emission, count)
        if (emission < 0).any():
            bad = _first_bad(emission < 0)
            raise ValueError(f"emission[{bad}] = {emission[bad].tolist()} is negative")
        material = self.material
        if material is None:
            material = sorted_labels(np.hstack([reflectance, emission]))[1]
        material = np.asarray(material)
        if material.dtype.kind not in "iu" or material.shape != (count,):
            raise ValueError(f"material must be an integer array of shape ({count},)")
        two_sided = np.zeros(count, bool) if self.two_sided is None else np.array(self.two_sided)
        if two_sided.dtype != bool or two_sided.shape != (count,):
            raise ValueError(f"two_sided must be a bool array of shape ({count},)")
        casts_shadows = np.ones(count, bool) if self.casts_shadows is None else np.array(self.casts_shadows)
        if casts_shadows.dtype != bool or casts_shadows.shape != (count,):
            raise ValueError(f"casts_shadows must be a bool array of shape ({count},)")
        opacity = np.ones(count) if self.opacity is None else _as_float_array("opacity", self.opacity, ())
        if opacity.shape != (count,) or not ((opacity >= 0) & (opacity <= 1)).all():
            raise ValueError(f"opacity must be {count} numbers in [0, 1]")
        if (reflectance > opacity[:, None]).any():
            bad = _first_bad(reflectance > opacity[:, None])
            raise ValueError(f"reflectance[{bad}] = {reflectance[bad].tolist()} is above its opacity {opacity[bad]:g}: "
                             "a surface reflects at most the light it stops (scale it by the opacity)")
        corner_normals = None if self.corner_normals is None else _unit_corner_normals(self.corner_normals, count)
        sky = np.zeros(3) if self.sky is None else np.array(self.sky, dtype=np.float64).reshape(-1)
        if sky.shape != (3,) or not np.isfinite(sky).all() or (sky < 0).any():
            raise ValueError(f"sky must be 3 finite numbers >= 0, got {self.sky!r}")
        object.__setattr__(self, "lights", check_lights(self.lights))
        if self.environment is not None and not isinstance(self.environment, Environment):
            raise TypeError(f"environment must be a core Environment, got {type(self.environment).__name__}")
        for name, value in (
            ("sky", sky),
            ("vertices", vertices),
            ("triangles", triangles),
            ("reflectance", reflectance),
            ("emission", emission),
            ("material", np.array(material, dtype=np.int64)),
            ("two_sided", two_sided),
            ("casts_shadows", casts_shadows),
            ("opacity", opacity),
            *([("corner_normals", corner_normals)] if corner_normals is not None else []),
        ):
            value.setflags(write=False)
            object.__setattr__(self, name, value)

    @cached_property
    def extent(self) -> float:
        """Length of the bounding-box diagonal of the triangles' vertices."""
        used = self.vertices[self.triangles.ravel()]
        return float(np.linalg.norm(used.max(axis=0) - used.min(axis=0)))

    @property
    def is_grey(self) -> bool:
        """True when every reflectance, emission, light and the sky have equal R, G and B."""
        colours = [self.reflectance, self.emission, self.sky[None]]
        if self.environment is not None:
            colours.append(self.environment.radiance.reshape(-1, 3))
        colours += [getattr(light, "power", getattr(light, "strength", None))[None] for light in self.lights]
        return all(bool((colour == colour[:, :1]).all()) for colour in colours)


def _per_triangle(name: str, value, count: int) -> np.ndarray:
    array = _as_float_array(name, value, (3,))
    if len(array) != count:
        raise ValueError(f"{name} must have one row per triangle ({count}), got {len(array)}")
    return array
