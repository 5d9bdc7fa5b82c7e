"""NumPy's advice to the kernel to back its large arrays with huge pages, withheld while a bake
runs where the kernel would stall on it.

NumPy advises huge pages (``madvise(MADV_HUGEPAGE)``) for every array of 4 MiB or more. Where
the kernel's transparent huge pages compact memory at the fault for advised memory (the
``defrag`` setting ``always``, ``madvise``, its usual default, or ``defer+madvise``), the first
touch of each new large array waits for that compaction; a bake makes thousands of them. Without
the advice the bakes are the same to the bit and faster (docs/notes/experiments.md). The advice
is process-wide: it is withheld only while a bake runs and given back after the last one.
"""

from __future__ import annotations

import re
import threading
from contextlib import contextmanager
from pathlib import Path
from typing import Callable, Iterator

DEFRAG = Path("/sys/kernel/mm/transparent_hugepage/defrag")
STALLING = frozenset({"always", "madvise", "defer+madvise"})  # compaction at the fault, for advised memory

_lock = threading.Lock()
_bakes = 0  # bakes running without the advice
_advised = True  # the advice before the first of them


def compaction_stalls() -> bool:
    """Whether the kernel compacts memory at the fault for huge pages advised by madvise (the
    bracketed choice in DEFRAG); False where it cannot be read (not Linux)."""
    try:
        chosen = re.search(r"\[([^\]]+)\]", DEFRAG.read_text())
    except OSError:
        return False
    return chosen is not None and chosen.group(1) in STALLING


def _advice_setter() -> Callable[[bool], bool] | None:
    """NumPy's ``_set_madvise_hugepage`` (it returns the previous setting), or None."""
    try:
        from numpy._core.multiarray import _set_madvise_hugepage  # NumPy 2
    except ImportError:
        try:
            from numpy.core.multiarray import _set_madvise_hugepage  # NumPy 1
        except ImportError:
            return None
    return _set_madvise_hugepage


@contextmanager
def without_huge_page_advice() -> Iterator[None]:
    """Withhold NumPy's huge-page advice inside the block where ``compaction_stalls``; nested
    and concurrent blocks give it back when the last one ends."""
    global _bakes, _advised
    setter = _advice_setter()
    if setter is None or not compaction_stalls():
        yield
        return
    with _lock:
        if _bakes == 0:
            _advised = setter(False)
        _bakes += 1
    try:
        yield
    finally:
        with _lock:
            _bakes -= 1
            if _bakes == 0:
                setter(_advised)
