"""What the report says about the machine and the moment: date, processors, versions, load, and
how many cores a run can actually get (the machine is shared)."""

from __future__ import annotations

import datetime
import hashlib
import importlib.metadata
import multiprocessing
import os
import platform
import subprocess
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

PROBE_WORK = 30_000_000  # integers summed by each probe job (~0.5 s of one core)


def machine() -> dict[str, str]:
    """Date, processors, CPU model, versions and commit, as printed in the report's header."""
    model = next(
        (line.split(":", 1)[1].strip() for line in Path("/proc/cpuinfo").read_text().splitlines()
         if line.startswith("model name")),
        platform.processor() or "unknown",
    )
    return {
        "date": datetime.datetime.now().astimezone().isoformat(timespec="seconds"),
        "nproc": str(len(os.sched_getaffinity(0))),
        "cpu": model,
        "python": platform.python_version(),
        "numpy": importlib.metadata.version("numpy"),
        "embreex": importlib.metadata.version("embreex"),
        "commit": _commit(),
    }


def core_digest() -> str:
    """The first 12 hex digits of a SHA-1 over the names and contents of core/*.py: which core a
    bake ran (the repository may change while the benchmark runs)."""
    digest = hashlib.sha1()
    for path in sorted((Path(__file__).resolve().parent.parent / "core").glob("*.py")):
        digest.update(path.name.encode() + b"\0" + path.read_bytes())
    return digest.hexdigest()[:12]


def load_average() -> str:
    """The system's load averages over 1, 5 and 15 minutes."""
    return " ".join(f"{load:.2f}" for load in os.getloadavg())


def load(moment: str) -> dict[str, str]:
    """The load average and the cores free, at ``moment`` ("start" or "end"), for a report's header."""
    return {
        f"load average (1, 5, 15 min) at the {moment}": load_average(),
        f"cores free at the {moment} (CPU-bound probe, see bench/machine.py)": f"{free_cores():.1f}",
    }


def free_cores() -> float:
    """Cores this run can get now: nproc x (seconds of one fixed CPU-bound job alone) / (seconds of
    nproc such jobs in nproc processes at once). About nproc on an idle machine, less when other
    work holds cores."""
    count = len(os.sched_getaffinity(0))
    with ProcessPoolExecutor(count, mp_context=multiprocessing.get_context("spawn")) as pool:
        list(pool.map(_probe_job, range(count)))  # start the processes
        start = time.perf_counter()
        pool.submit(_probe_job, 0).result()
        alone = time.perf_counter() - start
        start = time.perf_counter()
        list(pool.map(_probe_job, range(count)))
        together = time.perf_counter() - start
    return count * alone / together


def _probe_job(_index: int) -> int:
    """A fixed amount of single-threaded CPU work that needs little memory."""
    return sum(range(PROBE_WORK))


def _commit() -> str:
    """The repository's HEAD, and the tracked files that differ from it."""
    repo = Path(__file__).resolve().parent.parent
    try:
        head = _git(repo, "rev-parse", "--short", "HEAD").strip()
        changed = [line[3:] for line in _git(repo, "status", "--porcelain", "--untracked-files=no").splitlines()]
    except (OSError, subprocess.CalledProcessError):
        return "unknown"
    return head + (f", with local changes to {', '.join(changed)}" if changed else "")


def _git(repo: Path, *arguments: str) -> str:
    """The standard output of a git command run in ``repo``."""
    return subprocess.run(["git", *arguments], cwd=repo, capture_output=True, text=True, check=True).stdout
