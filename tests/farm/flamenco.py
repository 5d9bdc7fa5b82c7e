"""The Flamenco job type (farm/flamenco/radiosity_bake.js) compiled under Node with a stand-in
for the Manager's ``author`` and ``path`` (tests/farm/flamenco_stand_in.js)."""

from __future__ import annotations

import json
import shutil
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
JOB_TYPE_SCRIPT = ROOT / "farm" / "flamenco" / "radiosity_bake.js"
STAND_IN = Path(__file__).with_name("flamenco_stand_in.js")


def compile_job(settings: dict) -> dict:
    """``{"tasks": [...], "jobType": {...}}``, or ``{"error": ..., "jobType": ...}`` when
    compileJob refused the job. Skips the test where Node is not installed."""
    node = shutil.which("node")
    if node is None:
        pytest.skip("Node.js is not installed: the Flamenco job type cannot be compiled here")
    job = json.dumps({"name": "bake levels", "settings": settings})
    done = subprocess.run([node, str(STAND_IN), str(JOB_TYPE_SCRIPT), job], capture_output=True, text=True,
                          check=True, timeout=60)
    return json.loads(done.stdout)
