"""util.hugepages: NumPy's huge-page advice is withheld during a bake only where the kernel's
transparent huge pages compact memory at the fault for advised memory, and given back after."""

import numpy as np
import pytest

from core import BakeSession, Scene
from core.util import hugepages
from tests.core.scenes import box

SETTINGS = {  # /sys/kernel/mm/transparent_hugepage/defrag as kernels write it, and whether it stalls
    "always defer defer+madvise [madvise] never\n": True,
    "[always] defer defer+madvise madvise never\n": True,
    "always defer [defer+madvise] madvise never\n": True,
    "always [defer] defer+madvise madvise never\n": False,
    "always defer defer+madvise madvise [never]\n": False,
}


@pytest.fixture(autouse=True)
def advice_given():
    """NumPy's advice on at the start of each test (as it is by default on Linux), as it was after."""
    setter = hugepages._advice_setter()
    previous = setter(True)
    yield
    setter(previous)


def advised() -> bool:
    """NumPy's current advice, left as it was."""
    setter = hugepages._advice_setter()
    previous = setter(True)
    setter(previous)
    return previous


@pytest.mark.parametrize("text, stalls", SETTINGS.items())
def test_the_kernel_setting_is_read(tmp_path, monkeypatch, text, stalls):
    (tmp_path / "defrag").write_text(text)
    monkeypatch.setattr(hugepages, "DEFRAG", tmp_path / "defrag")
    assert hugepages.compaction_stalls() is stalls


def test_no_setting_no_stall(tmp_path, monkeypatch):
    monkeypatch.setattr(hugepages, "DEFRAG", tmp_path / "absent")
    assert not hugepages.compaction_stalls()


@pytest.mark.parametrize("stalls", [True, False])
def test_the_advice_is_withheld_inside_nested_blocks_and_given_back(tmp_path, monkeypatch, stalls):
    (tmp_path / "defrag").write_text("always defer defer+madvise [madvise] never" if stalls else "[never]")
    monkeypatch.setattr(hugepages, "DEFRAG", tmp_path / "defrag")
    with hugepages.without_huge_page_advice():
        assert advised() is not stalls
        with hugepages.without_huge_page_advice():
            assert advised() is not stalls
        assert advised() is not stalls  # the outer block still runs
    assert advised()


def test_a_bake_runs_without_the_advice_and_gives_it_back(tmp_path, monkeypatch):
    """Seen from the progress calls, which come while the bake runs."""
    (tmp_path / "defrag").write_text("always defer defer+madvise [madvise] never")
    monkeypatch.setattr(hugepages, "DEFRAG", tmp_path / "defrag")
    vertices, triangles = box()
    emission = np.zeros((len(triangles), 3))
    emission[2:4] = 1.0  # the ceiling
    seen = []
    BakeSession().bake(Scene(vertices, triangles, np.full((len(triangles), 3), 0.5), emission),
                       lambda fraction, message: seen.append(advised()) or True)
    assert seen and not any(seen) and advised()
