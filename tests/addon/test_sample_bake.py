"""``make bake``'s colours are the ones it baked before, bit for bit on a machine of the kind
that stored them.

data/cornell_box_baked.npz holds the "Radiosity" attribute of every mesh of
sample_blends/cornell_box.blend as ``make bake`` wrote it (RGBA float32 per corner, read with
``foreach_get("color")``), and the machine it ran on: first at commit 7df635d, before the core was
split into stage packages (which left them bit-identical), then again when near pairs of form factor
below 1e-3 came to be read at their patch's centroid (nearfield.QUADRATURE_FLOOR), which moved them
by at most 2.8e-6 of the largest, and when patches pressed under a node's own surface came to keep
their constant (nearfield.PRESSED_ANGLE: the tall block's back facing the back wall), at most 1.2e-4
(against Cycles' converged answer, `python -m bench rescore`: 0.60 -> 0.58 %), and when a node's
near patches came to be those within one longest edge of their centroid, not 1.25
(nearfield.NEAR_REACH), at most 9.7e-5 (against a path-traced answer at the box's 768 corners: 0.91
-> 0.88 %; docs/notes/experiments.md), and when the core's random streams became one per use
(core/util/streams.py: the shots' samples drawn from other numbers), at most 1.2e-4 (against Cycles'
converged answer, `python -m bench rescore`: 0.54 -> 0.55 %), written on an AMD EPYC where the ones
before were written on an Intel Xeon, and when the nodes came to spend their rays to an emitter
where the first ones disagree (core/transport/raycast.py, CLOSE_MIXED_RAYS and EMITTER_MIXED_RAYS),
at most 1.3e-4 (0.55 -> 0.52 %), and when two first sets came to decide for each other
(``raycast.joined_shares``), at most 5.0e-5 (0.52 -> 0.53 %), and when the touching pairs' cells
came to read the emitters coarsely (``touching.read_touching``), at most 2.2e-5 (0.53 -> 0.53 %). On
a machine of the same kind the colours must be equal bit for bit. Elsewhere NumPy's SIMD kernels and
the BLAS may round differently: turning off AVX-512 and forcing OpenBLAS's Haswell kernels moved the
colours by at most 1e-10 of their largest, so other machines are held to 1e-6 of it, far below what
any change of the method moves (another seed moves them by percents).
"""

from __future__ import annotations

import platform
from pathlib import Path

import bpy
import numpy as np
import pytest

SAMPLE = Path(__file__).resolve().parents[2] / "sample_blends" / "cornell_box.blend"
STORED = Path(__file__).parent / "data" / "cornell_box_baked.npz"
OTHER_MACHINE = 1e-6  # of the largest colour


def machine() -> str:
    """What decides the rounding: the CPU, NumPy and the SIMD extensions it uses."""
    from numpy.core._multiarray_umath import __cpu_features__ as features

    cpu = next((line.split(":", 1)[1].strip() for line in open("/proc/cpuinfo") if line.startswith("model name")),
               platform.processor())
    simd = ",".join(sorted(name for name, found in features.items() if found))
    return f"{platform.machine()} | {cpu} | numpy {np.__version__} | {simd}"


def baked_colours() -> dict[str, np.ndarray]:
    """The "Radiosity" attribute of every mesh of the open file, flat RGBA float32."""
    colours = {}
    for obj in bpy.data.objects:
        if obj.type == "MESH" and "Radiosity" in obj.data.color_attributes:
            attribute = obj.data.color_attributes["Radiosity"]
            values = np.empty(4 * len(attribute.data), dtype=np.float32)
            attribute.data.foreach_get("color", values)
            colours[obj.name] = values
    return colours


def test_make_bake_bakes_the_colours_it_baked_before(addon, tmp_path):
    if not Path("/proc/cpuinfo").exists():
        pytest.skip("the machine check reads /proc/cpuinfo")
    output = tmp_path / "baked.blend"
    assert addon.radiosity_addon.cli.main(["--input", str(SAMPLE), "--output", str(output), "-q"]) == 0
    bpy.ops.wm.open_mainfile(filepath=str(output))
    colours = baked_colours()
    stored = np.load(STORED)
    assert sorted(colours) == sorted(name for name in stored.files if not name.startswith("_"))
    same_machine = str(stored["_machine"]) == machine()
    largest = max(float(np.abs(stored[name]).max()) for name in colours)
    for name, values in colours.items():
        if same_machine:
            np.testing.assert_array_equal(values, stored[name], err_msg=name)
        else:
            np.testing.assert_allclose(values, stored[name], rtol=0, atol=OTHER_MACHINE * largest, err_msg=name)
