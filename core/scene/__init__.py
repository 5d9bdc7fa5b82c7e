"""The scene model: triangles that reflect and emit, the lights and the sky that light them,
validated on construction; OBJ/MTL in, PLY out."""

from .lights import AreaLight, Environment, PointLight, SpotLight, SunLight, area_light
from .model import Scene
from .objfile import read_obj, subdivide
from .plyfile import write_ply

__all__ = ["Scene", "Environment", "PointLight", "SpotLight", "SunLight", "AreaLight", "area_light", "read_obj",
           "subdivide", "write_ply"]
