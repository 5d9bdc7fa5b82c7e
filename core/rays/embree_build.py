"""An embreex scene of triangles whose geometry and BVH are made with the GIL released.

embreex's ``TriangleMesh`` copies triangles into Embree's buffers in a loop that holds the GIL
(0.41 s for 316,000 triangles), and embreex builds the BVH (commits the scene) at its first query,
holding it too (0.2 to 0.4 s); meanwhile no other Python thread runs, so a bake's progress reports
stop (docs/notes/experiments.md). ``triangle_scene`` makes the ``EmbreeScene`` as embreex does
(its device and ``RTCScene``), so that embreex traces it as any other, and fills and commits it
through Embree's C API by ctypes, which releases the GIL around each call (NumPy's copy into
Embree's vertex buffer releases it too): one triangle geometry, its vertices the triangles'
corners in order (as ``TriangleMesh`` lays them out), so hits name the same triangles. embreex
reports the device's errors through a Python function, which Embree would call inside those calls,
without the GIL: the scene's device reports none, and the errors are read after the calls.

That needs the ``RTCScene`` pointer embreex keeps in a C field of its ``EmbreeScene``
(rtcore_scene.pxd: ``scene_i``, then ``is_committed``, right after the object's header). The
layout is checked on each scene through the one field Python can write (``is_committed``); where
it, Embree's library or a call is not what is expected, ``triangle_scene`` returns None and the
caller builds the scene with embreex alone.

Robust or not: embreex's scenes are robust (``RTC_SCENE_FLAG_ROBUST``): watertight, a ray through
an edge or vertex shared by two triangles meets one of them. Without it, and with spatial splits
(``RTC_BUILD_QUALITY_HIGH``, no faster in robust mode), Embree traced Sponza's random
rays 1.4 (nearest hits) and 1.3 (occlusion) times as fast, but rays aimed at the shared vertices of
a closed mesh went through it one time in eight, and a ray that starts exactly in a triangle's
plane never meets it: only rays jittered at random, lifted off the surface they leave, may use it
(``visibility``).
"""

from __future__ import annotations

import ctypes
import functools
from pathlib import Path

import numpy as np

_HEADER = object.__basicsize__  # reference count and type of every object
_POINTER = ctypes.sizeof(ctypes.c_void_p)
_PROBE = 0x5EED  # written to ``is_committed`` to find it in the object's memory
# Embree 4's enums (rtcore_buffer.h, rtcore_common.h, rtcore_geometry.h)
_INDEX_BUFFER, _VERTEX_BUFFER = 0, 1
_UINT3, _FLOAT3 = 0x5003, 0x9003
_TRIANGLE = 0
_SCENE_FLAG_NONE, _SCENE_FLAG_ROBUST = 0, 4
_BUILD_QUALITY_MEDIUM, _BUILD_QUALITY_HIGH = 1, 2


def triangle_scene(triangles: np.ndarray, robust: bool = True):
    """A committed embreex ``EmbreeScene`` of float32 triangles (n, 3, 3), n > 0, triangle i
    hit as primitive i, built with the GIL released; watertight if ``robust``, else faster for
    rays in general position (above); None where that cannot be done here."""
    api = _api()
    if api is None or len(triangles) == 0:
        return None
    from embreex.rtcore_scene import EmbreeScene

    scene = EmbreeScene()
    pointer = _scene_pointer(scene)
    if pointer is None:
        return None
    device = api.rtcGetSceneDevice(pointer)  # a reference of our own, released below
    try:
        api.rtcSetDeviceErrorFunction(device, None, None)
        return _filled(api, scene, pointer, device, triangles, robust)
    finally:
        api.rtcReleaseDevice(device)


def _filled(api, scene, pointer: int, device: int, triangles: np.ndarray, robust: bool):
    """``scene`` (its ``RTCScene`` ``pointer`` on ``device``) holding ``triangles``, committed, or
    None where Embree reports an error."""
    api.rtcSetSceneFlags(pointer, _SCENE_FLAG_ROBUST if robust else _SCENE_FLAG_NONE)
    api.rtcSetSceneBuildQuality(pointer, _BUILD_QUALITY_MEDIUM if robust else _BUILD_QUALITY_HIGH)
    count = len(triangles)
    geometry = api.rtcNewGeometry(device, _TRIANGLE)
    if not geometry:
        return None
    vertices = api.rtcSetNewGeometryBuffer(geometry, _VERTEX_BUFFER, 0, _FLOAT3, 12, 3 * count)
    indices = api.rtcSetNewGeometryBuffer(geometry, _INDEX_BUFFER, 0, _UINT3, 12, count)
    if not vertices or not indices or api.rtcGetDeviceError(device):
        api.rtcReleaseGeometry(geometry)
        return None
    np.copyto(np.ctypeslib.as_array((ctypes.c_float * (9 * count)).from_address(vertices)), triangles.reshape(-1))
    np.copyto(np.ctypeslib.as_array((ctypes.c_uint32 * (3 * count)).from_address(indices)),
              np.arange(3 * count, dtype=np.uint32))
    api.rtcCommitGeometry(geometry)
    api.rtcAttachGeometry(pointer, geometry)
    api.rtcReleaseGeometry(geometry)
    api.rtcCommitScene(pointer)
    if api.rtcGetDeviceError(device):
        return None
    scene.is_committed = 1
    return scene


def _scene_pointer(scene) -> int | None:
    """The ``RTCScene`` of an uncommitted embreex ``scene``, or None where its layout is not the
    one expected."""
    flag = ctypes.c_int.from_address(id(scene) + _HEADER + _POINTER)
    scene.is_committed = _PROBE
    found = flag.value == _PROBE
    scene.is_committed = 0
    if not found or flag.value != 0:
        return None
    return ctypes.c_void_p.from_address(id(scene) + _HEADER).value or None


@functools.cache
def _api():
    """Embree's C functions from the library embreex loaded (its wheel's copy), or None."""
    try:
        import embreex
    except ImportError:
        return None
    libraries = sorted((Path(embreex.__file__).parent.parent / "embreex.libs").glob("libembree4*"))
    if len(libraries) != 1:
        return None
    try:
        library = ctypes.CDLL(str(libraries[0]))
        signatures = {
            "rtcGetSceneDevice": ([ctypes.c_void_p], ctypes.c_void_p),
            "rtcGetDeviceError": ([ctypes.c_void_p], ctypes.c_int),
            "rtcNewGeometry": ([ctypes.c_void_p, ctypes.c_int], ctypes.c_void_p),
            "rtcSetNewGeometryBuffer": ([ctypes.c_void_p, ctypes.c_int, ctypes.c_uint, ctypes.c_int, ctypes.c_size_t,
                                         ctypes.c_size_t], ctypes.c_void_p),
            "rtcCommitGeometry": ([ctypes.c_void_p], None),
            "rtcAttachGeometry": ([ctypes.c_void_p, ctypes.c_void_p], ctypes.c_uint),
            "rtcReleaseGeometry": ([ctypes.c_void_p], None),
            "rtcCommitScene": ([ctypes.c_void_p], None),
            "rtcSetSceneFlags": ([ctypes.c_void_p, ctypes.c_int], None),
            "rtcSetSceneBuildQuality": ([ctypes.c_void_p, ctypes.c_int], None),
            "rtcSetDeviceErrorFunction": ([ctypes.c_void_p, ctypes.c_void_p, ctypes.c_void_p], None),
            "rtcReleaseDevice": ([ctypes.c_void_p], None),
        }
        for name, (arguments, result) in signatures.items():
            function = getattr(library, name)
            function.argtypes, function.restype = arguments, result
    except (OSError, AttributeError):
        return None
    return library
