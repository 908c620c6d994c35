"""Compile once: the warm-up covers every registered pipeline, and a later process compiles nothing.

Both checks run ``ldv-survey warmup`` in fresh processes on the installation's own cache (the one
``scripts/setup.sh`` warms), so they are quick when the installation is warm and pay the one
compilation otherwise.
"""

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

BACKEND = Path(__file__).resolve().parents[2] / "backend"


def _warmup(*args: str) -> dict:
    env = {**os.environ, "PYTHONPATH": str(BACKEND) + os.pathsep + os.environ.get("PYTHONPATH", "")}
    proc = subprocess.run(
        [sys.executable, "-m", "ldvsurvey.cli", "warmup", "--json", "--no-variants", *args],
        capture_output=True,
        text=True,
        env=env,
        timeout=900,
    )
    assert proc.returncode == 0, proc.stderr[-3000:]
    return json.loads(proc.stdout)


@pytest.fixture(scope="module")
def first():
    return _warmup()


def test_warmup_runs_every_registered_pipeline(first):
    from ldvsurvey.pipelines.registry import PIPELINES

    ok = {r["pipeline"] for r in first["runs"] if r["ok"]}
    assert ok == set(PIPELINES), f"not warmed: {set(PIPELINES) - ok}"
    assert first["not_cached"] == []  # every compiled function is cached on disk
    index_files = list(Path(first["cache_dir"]).rglob("*.nbi"))
    assert index_files, "numba wrote no cache index"


def test_a_second_process_loads_instead_of_compiling(first):
    second = _warmup("--pipeline", "navigate", "--pipeline", "gravity")
    assert second["cache_dir"] == first["cache_dir"]
    assert second["compiled"] == 0
    assert second["cache_hits"] > 0
