"""Run a function in a fresh Python interpreter and measure that process: the one way every study
runs a case, so that its memory, thread pool and Embree scenes are its own, and bpy (which can be
imported once per process) starts afresh.

    outcome = in_fresh_process(function, *args, timeout=600.0)
    outcome.status, outcome.value, outcome.wall, outcome.cpu, outcome.peak

``function`` is named by its module and name (a module-level function), so the child imports it;
it and ``args`` go to ``python -m bench.runner JOB ANSWER`` as a pickle, and its value (or the last
line of its traceback) comes back the same way. The child's output is shown only if it fails.
Also here: what a process has used so far (CPU time, resident and peak resident set), for the
studies that time a part of a case themselves.
"""

from __future__ import annotations

import pickle
import re
import resource
import subprocess
import sys
import tempfile
import time
import traceback
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable

from bench.paths import REPO

SHOWN_OUTPUT = 5000  # characters of a failed child's output shown


@dataclass(frozen=True)
class Outcome:
    """What a function did in a fresh process. ``status``: "ok", "failed: <the error>" or "timed
    out"; ``value``: what it returned (None unless ok); ``wall``: seconds from starting the
    interpreter to its end; ``cpu``: user plus system seconds of the child, all threads, and
    ``peak``: its peak resident set size (VmHWM) in bytes, both 0 if it died or was killed."""

    status: str
    value: Any = None
    wall: float = 0.0
    cpu: float = 0.0
    peak: int = 0

    @property
    def ok(self) -> bool:
        return self.status == "ok"


def in_fresh_process(function: Callable, *args, timeout: float | None = None) -> Outcome:
    """``function(*args)`` in a new interpreter started from the repository root; killed after
    ``timeout`` seconds."""
    with tempfile.TemporaryDirectory(prefix="radiosity-bench-") as scratch:
        job, answer = Path(scratch, "job.pkl"), Path(scratch, "answer.pkl")
        job.write_bytes(pickle.dumps((function, args)))
        start = time.perf_counter()
        try:
            process = subprocess.run([sys.executable, "-m", "bench.runner", str(job), str(answer)], cwd=REPO,
                                     capture_output=True, text=True, timeout=timeout, check=False)
        except subprocess.TimeoutExpired:
            return Outcome("timed out", wall=time.perf_counter() - start)
        wall = time.perf_counter() - start
        if not answer.exists():
            _show(process)
            return Outcome(f"failed: the process died (exit code {process.returncode})", wall=wall)
        status, value, cpu, peak = pickle.loads(answer.read_bytes())
    if status != "ok":
        _show(process)
    return Outcome(status, value, wall, cpu, peak)


def value_in_fresh_process(function: Callable, *args) -> Any:
    """What ``function(*args)`` returns in a new interpreter; RuntimeError if it fails."""
    outcome = in_fresh_process(function, *args)
    if not outcome.ok:
        raise RuntimeError(f"{function.__module__}.{function.__qualname__}: {outcome.status}")
    return outcome.value


def cpu_seconds() -> float:
    """User plus system CPU seconds of this process so far, all threads."""
    usage = resource.getrusage(resource.RUSAGE_SELF)
    return usage.ru_utime + usage.ru_stime


def resident() -> int:
    """This process's resident set size now, in bytes."""
    return _status_kib("VmRSS") * 1024


def peak_resident() -> int:
    """This process's peak resident set size (since it started or since ``reset_peak``), in bytes."""
    return _status_kib("VmHWM") * 1024


def reset_peak() -> None:
    """Start this process's peak resident set size again from its size now (Linux's clear_refs)."""
    Path("/proc/self/clear_refs").write_text("5")


def _status_kib(field: str) -> int:
    return int(re.search(rf"^{field}:\s+(\d+) kB", Path("/proc/self/status").read_text(), re.MULTILINE).group(1))


def _show(process: subprocess.CompletedProcess) -> None:
    """The end of a failed child's output, on stderr."""
    sys.stderr.write((process.stdout + process.stderr)[-SHOWN_OUTPUT:])


def _child(job: str, answer: str) -> None:
    """Run the pickled job and pickle (status, value, CPU seconds, peak bytes) to ``answer``."""
    function, args = pickle.loads(Path(job).read_bytes())
    try:
        status, value = "ok", function(*args)
    except BaseException:  # noqa: BLE001 (reported to the parent, which decides)
        traceback.print_exc()
        status, value = "failed: " + traceback.format_exc().strip().splitlines()[-1], None
    Path(answer).write_bytes(pickle.dumps((status, value, cpu_seconds(), peak_resident())))


if __name__ == "__main__":
    _child(*sys.argv[1:3])
