"""Building an embreex scene's BVH without holding the GIL.

Embree builds a scene's BVH when the scene is committed (``rtcCommitScene``). embreex commits at
the scene's first query, inside Cython code that holds the GIL: 0.4 to 0.5 s on the breakfast
room's 300,000 triangles, during which no other Python thread runs, so a bake's progress reports
stop (docs/notes/experiments.md). ``commit`` calls ``rtcCommitScene`` of the same Embree library
through ctypes, which releases the GIL around a foreign call, and marks the scene committed, so
that its first query does not build it again.

That needs the scene's ``RTCScene`` pointer, which embreex keeps in a C field of its
``EmbreeScene`` (rtcore_scene.pxd: ``scene_i``, then ``is_committed``, right after the object's
header). The layout is checked on each scene, through the one field Python can write
(``is_committed``); where it or the library is not what is expected, ``commit`` does nothing and
the first query builds the BVH, as before.
"""

from __future__ import annotations

import ctypes
import functools
from pathlib import Path

_HEADER = object.__basicsize__  # reference count and type of every object
_POINTER = ctypes.sizeof(ctypes.c_void_p)
_PROBE = 0x5EED  # written to ``is_committed`` to find it in the object's memory


@functools.cache
def _commit_function():
    """Embree's ``rtcCommitScene`` from the library embreex loaded (its wheel's copy), or None."""
    try:
        import embreex
    except ImportError:
        return None
    libraries = sorted((Path(embreex.__file__).parent.parent / "embreex.libs").glob("libembree4*"))
    if len(libraries) != 1:
        return None
    try:
        function = ctypes.CDLL(str(libraries[0])).rtcCommitScene
    except (OSError, AttributeError):
        return None
    function.argtypes, function.restype = [ctypes.c_void_p], None
    return function


def commit(scene) -> bool:
    """Build the BVH of the uncommitted embreex ``EmbreeScene`` ``scene`` with the GIL released;
    False (and nothing done) where its layout or Embree's library is not the one expected."""
    function = _commit_function()
    if function is None or scene.is_committed:
        return False
    address = id(scene)
    flag = ctypes.c_int.from_address(address + _HEADER + _POINTER)
    scene.is_committed = _PROBE
    found = flag.value == _PROBE
    scene.is_committed = 0
    if not found or flag.value != 0:
        return False
    pointer = ctypes.c_void_p.from_address(address + _HEADER).value
    if not pointer:
        return False
    function(pointer)
    scene.is_committed = 1
    return True
