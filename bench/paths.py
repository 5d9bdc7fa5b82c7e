"""Where the benchmarks read and write: the shared scenes beside the repository, the reports in
docs/results/, and build/ for everything else (raw results, built scenes, caches, quick runs)."""

from __future__ import annotations

from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
SCENES = REPO.parent / "shared" / "scenes"  # read in place, never copied into the repository
RESULTS = REPO / "docs" / "results"  # the committed reports and their figures
BUILD = REPO / "build" / "bench"  # raw results of full runs, the scenes built from others, caches
QUICK = REPO / "build" / "bench-quick"  # everything a --quick run writes: its reports are not to quote


def reports(quick: bool) -> Path:
    """The folder a run's reports and figures go to (made if missing)."""
    folder = QUICK if quick else RESULTS
    folder.mkdir(parents=True, exist_ok=True)
    return folder


def raw_results(study: str, quick: bool) -> Path:
    """Where a study's run keeps its raw results (JSON), for reporting again without measuring."""
    return (QUICK if quick else BUILD) / f"{study}.json"


def shown(path: Path) -> str:
    """``path`` relative to the repository, as reports and messages show it."""
    return str(path.resolve().relative_to(REPO))
