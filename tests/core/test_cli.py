"""``python -m core bake``: an OBJ/MTL scene in, what the bake did on the terminal and a PLY of its
corner colours out; exit code 2 with a one-line message for bad arguments or input."""

from __future__ import annotations

import re

import numpy as np
import pytest

from core.cli import main
from core.scene.plyfile import linear_to_srgb_bytes

EMISSION, REFLECTANCE = 0.2, 0.5
FURNACE_RADIOSITY = EMISSION / (1 - REFLECTANCE)  # B = E + rho B where every face of a closed box emits
CUBE_FACES = ((1, 2, 3, 4), (5, 8, 7, 6), (1, 5, 6, 2), (2, 6, 7, 3), (3, 7, 8, 4), (5, 1, 4, 8))  # facing in


def _box_obj(folder, emitting_faces: int):
    """A closed unit cube, faces facing in, every face reflecting rho, the first ``emitting_faces``
    of its six emitting E too; its OBJ and MTL written into ``folder``."""
    (folder / "box.mtl").write_text(f"newmtl wall\nKd {REFLECTANCE} {REFLECTANCE} {REFLECTANCE}\n"
                                    f"newmtl light\nKd {REFLECTANCE} {REFLECTANCE} {REFLECTANCE}\n"
                                    f"Ke {EMISSION} {EMISSION} {EMISSION}\n")
    corners = [(x, y, z) for z in (0, 1) for (x, y) in ((0, 0), (1, 0), (1, 1), (0, 1))]
    lines = ["mtllib box.mtl", *(f"v {x} {y} {z}" for x, y, z in corners)]
    for number, face in enumerate(CUBE_FACES):
        lines += [f"usemtl {'light' if number < emitting_faces else 'wall'}",
                  "f " + " ".join(str(v) for v in face)]
    path = folder / "box.obj"
    path.write_text("\n".join(lines) + "\n")
    return path


@pytest.fixture
def furnace_obj(tmp_path):
    """Every face emits: B = E / (1 - rho) everywhere."""
    return _box_obj(tmp_path, 6)


def _mean_radiosity(output: str) -> np.ndarray:
    return np.array(re.search(r"mean radiosity \(area-weighted, linear RGB\): (\S+) (\S+) (\S+)", output).groups(),
                    dtype=float)


def _ply_colours(path) -> np.ndarray:
    """(n, 3) the sRGB bytes of every vertex of a PLY that core.scene.plyfile wrote."""
    data = path.read_bytes()
    header, body = data.split(b"end_header\n", 1)
    count = int(re.search(rb"element vertex (\d+)", header).group(1))
    vertex = np.frombuffer(body[: count * 15], dtype=[("xyz", "<f4", (3,)), ("rgb", "u1", (3,))])
    return vertex["rgb"]


def test_the_furnace_bakes_to_its_closed_form_on_the_terminal_and_in_the_ply(furnace_obj, tmp_path, capsys):
    ply = tmp_path / "out" / "furnace.ply"
    assert main(["bake", str(furnace_obj), "--subdivide", "2", "--output", str(ply)]) == 0
    output = capsys.readouterr().out
    assert "48 triangles" in output  # 12 split 2 x 2
    assert "progressive solver" in output and "Monte Carlo" not in output  # auto: a small scene shoots
    np.testing.assert_allclose(_mean_radiosity(output), FURNACE_RADIOSITY, rtol=1e-4)  # printed to 4 digits
    assert re.search(r"estimated error \S+%", output)
    colours = _ply_colours(ply)
    assert colours.shape == (48 * 3, 3)
    assert (colours == linear_to_srgb_bytes(np.array(FURNACE_RADIOSITY))).all()


def test_monte_carlo_and_max_shots_reach_the_bake(tmp_path, capsys):
    # one face emits; in a closed box of one reflectance the light that leaves the faces, sum A B,
    # is sum A E / (1 - rho) (the rows of F sum to 1): the mean radiosity E / 6 / (1 - rho)
    assert main(["bake", str(_box_obj(tmp_path, 1)), "--monte-carlo-rays", "16", "--max-shots", "0"]) == 0
    output = capsys.readouterr().out
    assert "then Monte Carlo (16 rays per vertex)" in output
    # the emitter shoots, what it leaves goes by particles, which carry power unbiased (Russian
    # roulette keeps it in the mean): 2 % for this box's 588 particles (one per patch) with the
    # bake's fixed seed, measured 0.25 % (0.8 % with 0.3 m patches), within the printed 4 digits
    np.testing.assert_allclose(_mean_radiosity(output), FURNACE_RADIOSITY / 6, rtol=0.02)


@pytest.mark.parametrize("arguments, message", [
    (["--monte-carlo-rays", "many"], "expected int or auto, got 'many'"),
    (["--monte-carlo-rays", "15"], "monte_carlo_rays must be 0 or a perfect square"),
    (["--max-shots", "-1"], "max_shots must be a non-negative integer or None"),
    (["--max-shots", "all"], "expected int or none, got 'all'"),
    (["--patch-size", "0"], "patch_size must be a positive length or None"),
    (["--subdivide", "0"], "--subdivide must be at least 1"),
    (["--rays-per-form-factor", "10"], "rays_per_form_factor must be a perfect square"),
    (["--method", "photon"], "invalid choice: 'photon'"),
])
def test_bad_arguments_exit_2_with_the_reason(furnace_obj, capsys, arguments, message):
    assert main(["bake", str(furnace_obj), *arguments]) == 2
    assert message in capsys.readouterr().err


def test_a_missing_scene_exits_2_with_the_reason(tmp_path, capsys):
    assert main(["bake", str(tmp_path / "nowhere.obj")]) == 2
    error = capsys.readouterr().err
    assert error.startswith("error: ") and "nowhere.obj" in error and len(error.strip().splitlines()) == 1
