"""Many files in one ``-c radiosity`` command: which files (paths and globs), where each baked
file and picture goes, and what became of each (printed, and as JSON for pipelines). Baking one
file is ``cli.run``; this module only plans and records."""

from __future__ import annotations

import glob
import json
import os
from dataclasses import asdict, dataclass, field

# What became of a file, and the exit code it stands for: bad input (refused, with the reason)
# is 2, as for bad arguments; an unexpected error is 1.
BAKED, REFUSED, FAILED = "baked", "refused", "failed"
EXIT_CODES = {BAKED: 0, REFUSED: 2, FAILED: 1}


class UsageError(ValueError):
    """Bad arguments or input: exit code 2."""


@dataclass
class Plan:
    """One file to bake: ``input`` None for the open file; ``output`` None when the baked file is
    not saved (a picture only); ``render`` None for no picture."""

    input: str | None
    output: str | None
    render: str | None


@dataclass
class FileResult:
    """What became of one file: ``status`` BAKED, REFUSED or FAILED, ``message`` the bake's
    report line or the error; ``stats`` a few of the bake's figures (empty unless baked)."""

    input: str | None
    output: str | None
    render: str | None
    status: str
    message: str
    seconds: float
    notes: list[str] = field(default_factory=list)
    stats: dict = field(default_factory=dict)


def expand_inputs(patterns: list[str]) -> list[str]:
    """Paths and glob patterns (``levels/*.blend``, ``**`` recursive) to files, in the order
    given, each pattern's matches sorted, every file once. A pattern that matches nothing stays
    as it is, so that its bake fails with "no such file" (and the others go on)."""
    files: list[str] = []
    for pattern in patterns:
        matches = sorted(glob.glob(pattern, recursive=True)) if glob.has_magic(pattern) else []
        for path in matches or [pattern]:
            if path not in files:
                files.append(path)
    return files


def plan(inputs: list[str | None], output: str | None, output_dir: str | None, suffix: str | None,
         overwrite: bool, render: str | None, open_file: str) -> list[Plan]:
    """Where each input's baked file and picture go (``open_file``: the path of the file open in
    Blender, "" if unsaved, for an input of None). Raises UsageError, before anything is baked,
    when the options contradict each other, when nothing would be kept, when a baked file would
    replace its input without ``overwrite``, or when two inputs would be saved to one file.

    ``render`` is a picture's path (one input), or "" for a picture beside each baked file (or
    beside its input when the baked file is not saved), named like it with ``.png``."""
    if overwrite and (output or output_dir or suffix):
        raise UsageError("give either --overwrite or where to save (--output, --output-dir, --suffix), not both")
    if output is not None and (output_dir or suffix):
        raise UsageError("--output names the baked file: leave out --output-dir and --suffix")
    if len(inputs) > 1 and output is not None:
        raise UsageError(f"--output names one file but {len(inputs)} are baked: use --output-dir or --suffix")
    if len(inputs) > 1 and render:
        raise UsageError(f"--render {render} names one picture but {len(inputs)} files are baked: give --render "
                         "alone for a picture beside each baked file")
    if output is not None and not output.endswith(".blend"):
        raise UsageError(f"--output must be a .blend file, got {output}")
    if render and not render.endswith(".png"):
        raise UsageError(f"--render must be a .png file, got {render}")
    plans = [_plan_one(path, open_file, output, output_dir, suffix, overwrite, render) for path in inputs]
    _refuse_collisions(plans)
    return plans


def _plan_one(input: str | None, open_file: str, output: str | None, output_dir: str | None, suffix: str | None,
              overwrite: bool, render: str | None) -> Plan:
    source = open_file if input is None else input
    if overwrite:
        if not source:
            raise UsageError("--overwrite needs a saved file to overwrite")
        target = source
    elif output is not None:
        target = output
    elif output_dir or suffix:
        if not source:
            raise UsageError("--output-dir and --suffix name the baked file after its input: save the file first "
                             "or give --output")
        stem = os.path.splitext(os.path.basename(source))[0]
        target = os.path.join(output_dir or os.path.dirname(source), f"{stem}{suffix or ''}.blend")
    elif render is None:
        raise UsageError("nothing would be kept: give --output FILE.blend, --output-dir DIR, --suffix TEXT, "
                         "--overwrite or --render")
    else:
        target = None
    if target is not None and not overwrite and source and _same(target, source):
        raise UsageError(f"the baked file would replace its input {source}: add --overwrite to replace it")
    picture = render or None
    if render == "":
        beside = target or source
        if not beside:
            raise UsageError("--render without a file name needs a saved file or --output: give --render FILE.png")
        picture = os.path.splitext(beside)[0] + ".png"
    return Plan(input, target, picture)


def _refuse_collisions(plans: list[Plan]) -> None:
    seen: dict[str, str | None] = {}
    for item in plans:
        for path in (item.output, item.render):
            if path is None:
                continue
            key = os.path.normcase(os.path.abspath(path))
            if key in seen:
                raise UsageError(f"{seen[key]} and {item.input} would both be saved to {path}: "
                                 "give --suffix, or bake them into different folders")
            seen[key] = item.input


def _same(a: str, b: str) -> bool:
    return os.path.normcase(os.path.abspath(a)) == os.path.normcase(os.path.abspath(b))


def exit_code(results: list[FileResult]) -> int:
    """0 when every file baked; 1 when any failed unexpectedly; else 2 (some refused)."""
    codes = {EXIT_CODES[result.status] for result in results}
    return 1 if 1 in codes else max(codes, default=0)


def summary_line(results: list[FileResult]) -> str:
    """``3 files: 2 baked, 1 failed (b.blend)``."""
    counts = [f"{sum(r.status == status for r in results)} {status}" for status in (BAKED, REFUSED, FAILED)
              if any(r.status == status for r in results)]
    failed = [os.path.basename(r.input or "") for r in results if r.status != BAKED]
    named = f" ({', '.join(failed)})" if failed else ""
    return f"{len(results)} file{'' if len(results) == 1 else 's'}: {', '.join(counts)}{named}"


def write_summary(path: str, results: list[FileResult], about: dict) -> None:
    """The results as JSON (``about``: the command's context, such as versions and arguments),
    replaced atomically after each file, so a killed job leaves the files done so far."""
    document = {**about, "exit_code": exit_code(results), "summary": summary_line(results),
                "files": [asdict(result) for result in results]}
    os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
    partial = f"{path}.partial"
    with open(partial, "w", encoding="utf-8") as stream:
        json.dump(document, stream, indent=2)
        stream.write("\n")
    os.replace(partial, path)
