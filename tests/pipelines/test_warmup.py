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


PRELOAD_THEN_JOBS = r"""
import json, sys
from ldvsurvey.io.drivelog import parse_files
from ldvsurvey.sim import catalog
from ldvsurvey.sim.scenario import bundle_files, simulate
from ldvsurvey.pipelines.base import Progress, run_pipeline
from ldvsurvey.pipelines.warmup import TINY_LOG_PARAMS, preload
from ldvsurvey.pipelines.registry import PIPELINES
logs = {s: [parse_files(bundle_files(simulate(catalog.by_name(s, **kw), seed=1)))]
        for s, kw in [("gravity", dict(n_lines=2, line_km=1.0)), ("height", dict(minutes=8.0, length_m=1500.0))]}
preload()
before = set(sys.modules)
for name, scenario in [("navigate", "height"), ("height", "height"), ("gravity", "gravity")]:
    run_pipeline(PIPELINES[name], logs[scenario], dict(TINY_LOG_PARAMS.get(name, {})), Progress())
new = sorted(m for m in set(sys.modules) - before if m.split(".")[0] in ("ldvsurvey", "scipy", "pyarrow"))
print(json.dumps(new))
"""


def test_after_preload_a_job_imports_nothing_more():
    """A worker with a warm cache imports the pipelines and their libraries at start (``preload``), so
    its first job pays none of it: running navigate, height and gravity afterwards imports no module of
    ldvsurvey, scipy or pyarrow (fails when a pipeline imports a library ``preload`` does not know)."""
    env = {**os.environ, "PYTHONPATH": str(BACKEND) + os.pathsep + os.environ.get("PYTHONPATH", "")}
    proc = subprocess.run(
        [sys.executable, "-c", PRELOAD_THEN_JOBS], capture_output=True, text=True, env=env, timeout=900
    )
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert json.loads(proc.stdout.strip().splitlines()[-1]) == []
