"""The DOV grid cache the runner offers every job: one context variable read by the ``dov`` pipeline and
the DOV options of the others, the store's database cache behind it, and imported only when a job
asks it for a grid (a job of another pipeline does not import the ``dov`` pipeline)."""

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from ldvsurvey.errors import ParameterError
from ldvsurvey.jobs.runner import LazyGridCache
from ldvsurvey.nav.dovgrid import DovGrid
from ldvsurvey.pipelines.stages import grid_cache as gridctx
from ldvsurvey.pipelines.stages import plumb_line as plumb
from ldvsurvey.store.db import upgrade_head
from ldvsurvey.store.gridcache import DbGridCache

ROOT = Path(__file__).resolve().parents[2]


def _grid(seed: int, dg: bool) -> DovGrid:
    rng = np.random.default_rng(seed)
    lat, lon = np.linspace(28.0, 28.5, 4), np.linspace(113.0, 113.6, 5)
    return DovGrid(
        lat,
        lon,
        rng.normal(0, 5, (4, 5)),
        rng.normal(0, 5, (4, 5)),
        rng.normal(0, 30, (4, 5)) if dg else None,
        source=f"test {seed}",
    )


def _same(a: DovGrid, b: DovGrid) -> None:
    for f in ("lat_deg", "lon_deg", "xi_arcsec", "eta_arcsec"):
        np.testing.assert_array_equal(getattr(a, f), getattr(b, f))
    assert (a.dg_mgal is None) == (b.dg_mgal is None)
    if a.dg_mgal is not None:
        np.testing.assert_array_equal(a.dg_mgal, b.dg_mgal)
    assert a.source == b.source


def test_dov_pipeline_reads_the_variable_the_runner_sets():
    """``dov.GRID_CACHE`` (kept for its callers) is the runner's variable, not a second one."""
    from ldvsurvey.pipelines import dov

    assert dov.GRID_CACHE is gridctx.GRID_CACHE


def test_uploaded_grid_comes_from_the_cache_the_runner_set():
    """A pipeline's ``dov_grid_id`` is looked up in the cache set in the variable (and refused without one)."""
    grid = _grid(1, dg=False)

    class Cache:
        def get(self, key):
            return grid if key == "upload:abc123" else None

    token = gridctx.GRID_CACHE.set(Cache())
    try:
        assert plumb._uploaded("abc123") is grid
        with pytest.raises(ParameterError, match="no uploaded grid"):
            plumb._uploaded("other1")
    finally:
        gridctx.GRID_CACHE.reset(token)
    with pytest.raises(ParameterError, match="run by the server only"):
        plumb._uploaded("abc123")


def test_lazy_cache_is_the_database_cache(tmp_path):
    """What the runner's lazy cache stores, the store's cache reads back, bit for bit, and the reverse."""
    url = f"sqlite:///{tmp_path / 'g.db'}"
    upgrade_head(url)
    lazy, db = LazyGridCache(url), DbGridCache(url)
    assert lazy.get("egm2008:none") is None
    a, b = _grid(2, dg=True), _grid(3, dg=False)
    lazy.put("k:a", a)
    db.put("k:b", b)
    _same(db.get("k:a"), a)
    _same(lazy.get("k:b"), b)
    _same(lazy.get("k:a"), a)


JOB = r"""
import json, sys
from ldvsurvey.io.drivelog import parse_files
from ldvsurvey.io.quality import quality_report
from ldvsurvey.jobs.runner import JobRunner
from ldvsurvey.settings import Settings
from ldvsurvey.store.db import session_scope, upgrade_head
from ldvsurvey.store.logs import store_log
from ldvsurvey.store.models import Job
from tests.bundles import make_bundle

settings = Settings(data_dir=sys.argv[1])
url = settings.resolved_database_url()
upgrade_head(url)
log = parse_files(make_bundle(n_imu=1000, rotating=True, seed=3))
with session_scope(url) as s:
    row, _ = store_log(s, log, quality_report(log))
    job = Job(pipeline="tilt", log_ids=[row.id], parameters={"output_rate_hz": 1}, status="queued", stage="queued",
              progress=0.0)
    s.add(job)
    s.flush()
    job_id = job.id
status = JobRunner(url, settings).execute(job_id)
print(json.dumps({"status": status, "modules": sorted(m for m in sys.modules if m.startswith("ldvsurvey"))}))
"""


def test_a_job_that_uses_no_grid_imports_neither_the_dov_pipeline_nor_the_grid_store(tmp_path):
    """A worker's ``tilt`` job runs to success without importing the ``dov`` pipeline or the grid store
    (a fresh process: this test session has imported them already)."""
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT / "backend"), str(ROOT)])}
    env.pop("LDVSURVEY_DATABASE_URL", None)
    out = subprocess.run(
        [sys.executable, "-c", JOB, str(tmp_path / "data")], env=env, capture_output=True, text=True, timeout=600
    )
    assert out.returncode == 0, out.stderr[-2000:]
    got = json.loads(out.stdout.strip().splitlines()[-1])
    assert got["status"] == "succeeded"
    assert "ldvsurvey.pipelines.tilt" in got["modules"]  # the job did run its pipeline in this process
    assert "ldvsurvey.pipelines.dov" not in got["modules"]
    assert "ldvsurvey.store.gridcache" not in got["modules"]
