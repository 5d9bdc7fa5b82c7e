"""What a report says about the machine and the moment, the header of every report: date,
processors, versions, the commit and the core that ran, the load, and how many cores a run could
actually get (the machine is shared)."""

from __future__ import annotations

import datetime
import hashlib
import importlib.metadata
import os
import platform
import statistics
import subprocess
import sys
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Iterable

from bench.paths import REPO
from bench.runner import value_in_fresh_process

PROBE_WORK = 30_000_000  # integers summed by each probe (about half a second of one core)
PACKAGES = ("numpy", "embreex", "bpy")
CORE_LINE = "core (SHA-1 of core/**/*.py) at the {moment}"


def opening() -> dict[str, str]:
    """The header at the start of a run: date, processors, CPU model, versions, commit, the core,
    the load and the cores free."""
    model = next((line.split(":", 1)[1].strip() for line in Path("/proc/cpuinfo").read_text().splitlines()
                  if line.startswith("model name")), platform.processor() or "unknown")
    return {
        "date": datetime.datetime.now().astimezone().isoformat(timespec="seconds"),
        "nproc": str(len(os.sched_getaffinity(0))),
        "cpu": model,
        "python": platform.python_version(),
        **{package: _version(package) for package in PACKAGES},
        "commit": _commit(),
    } | _moment("start")


def closing(header: dict[str, str]) -> dict[str, str]:
    """The lines the header of a run that began with ``header`` gets at its end: the load, the
    cores free and the core, with a warning (also on stderr) if core/ changed meanwhile."""
    end = _moment("end")
    if end[CORE_LINE.format(moment="end")] != header[CORE_LINE.format(moment="start")]:
        end["WARNING"] = "core/ changed during the run: its bakes may mix two cores; run again"
        print(f"warning: {end['WARNING']}", file=sys.stderr)
    return end


def sources_digest(paths: Iterable[Path], root: Path) -> str:
    """The first 12 hex digits of a SHA-1 over the ``paths`` (relative to ``root``) and contents of
    source files: which code a result came from."""
    digest = hashlib.sha1()
    for path in paths:
        digest.update(str(path.relative_to(root)).encode() + b"\0" + path.read_bytes())
    return digest.hexdigest()[:12]


def core_digest() -> str:
    """``sources_digest`` of core/**/*.py: which core a bake ran (the repository may change while a
    study runs)."""
    core = REPO / "core"
    return sources_digest(sorted(core.rglob("*.py")), core)


def free_cores() -> float:
    """Cores a run can get now: nproc x (seconds of one fixed CPU-bound probe alone) / (its mean
    seconds when nproc of them run at once, each in a process of its own). About nproc on an
    idle machine, less when other work holds cores."""
    count = len(os.sched_getaffinity(0))
    alone = value_in_fresh_process(probe)
    with ThreadPoolExecutor(count) as threads:
        together = list(threads.map(lambda _index: value_in_fresh_process(probe), range(count)))
    return count * alone / statistics.mean(together)


def probe() -> float:
    """Seconds of a fixed amount of single-threaded CPU work that needs little memory."""
    start = time.perf_counter()
    sum(range(PROBE_WORK))
    return time.perf_counter() - start


def _moment(moment: str) -> dict[str, str]:
    """The load averages, the cores free and the core, at ``moment`` ("start" or "end")."""
    return {
        f"load average (1, 5, 15 min) at the {moment}": " ".join(f"{load:.2f}" for load in os.getloadavg()),
        f"cores free at the {moment} (CPU-bound probe, bench/machine.py)": f"{free_cores():.1f}",
        CORE_LINE.format(moment=moment): core_digest(),
    }


def _version(package: str) -> str:
    try:
        return importlib.metadata.version(package)
    except importlib.metadata.PackageNotFoundError:
        return "not installed"


def _commit() -> str:
    """The repository's HEAD, and the tracked files that differ from it."""
    try:
        head = _git("rev-parse", "--short", "HEAD").strip()
        changed = [line[3:] for line in _git("status", "--porcelain", "--untracked-files=no").splitlines()]
    except (OSError, subprocess.CalledProcessError):
        return "unknown"
    return head + (f", with local changes to {', '.join(changed)}" if changed else "")


def _git(*arguments: str) -> str:
    """The standard output of a git command run in the repository."""
    return subprocess.run(["git", *arguments], cwd=REPO, capture_output=True, text=True, check=True).stdout
