"""``ldv-survey run`` as a process of its own (issue 25: its fixed cost beside KF-GINS): what it
imports for ``navigate`` on an INS/GNSS log, and that its garbage-collector handling (none while
the pipeline is imported, the objects frozen at exit) changes no byte of the result and stays out
of a caller's process (main() called with argv, as here)."""

from __future__ import annotations

import gc
import json

import pytest

from ldvsurvey.cli import main
from ldvsurvey.io.writers import write_bundle
from ldvsurvey.sim import catalog
from ldvsurvey.sim.scenario import bundle_files, simulate
from tests.cli.own_process import run_own_process


@pytest.fixture(scope="module")
def gnss_bundle(tmp_path_factory):
    """A 7-min INS/GNSS drive without an LDV (5 min static, then driving), as a bundle folder."""
    d = tmp_path_factory.mktemp("run-process")
    write_bundle(bundle_files(simulate(catalog.drive(minutes=7.0, with_ldv=False), seed=3)), d / "bundle")
    return d / "bundle"


def test_a_run_process_imports_only_what_navigate_needs_and_writes_what_main_writes(gnss_bundle, tmp_path):
    own, called = tmp_path / "own", tmp_path / "called"
    rc, mods = run_own_process(["run", "navigate", str(gnss_bundle), "--out", str(own)])
    assert rc == 0
    heavy = {
        m
        for m in mods
        if m.startswith(("scipy.ndimage", "scipy.signal", "scipy.interpolate", "pandas", "sqlalchemy", "fastapi"))
        or m.startswith(("ldvsurvey.api", "ldvsurvey.store", "ldvsurvey.jobs", "ldvsurvey.sim"))
        or (m.startswith("ldvsurvey.io.importers.") and m.split(".")[-1] in ("novatel", "ubx", "rtklib", "csvmap"))
        # numba's BLAS check and calls bind to scipy.linalg.cython_blas/cython_lapack, loaded alone
        # (compilecache.preload_blas): not the scipy.linalg package, which brings numpy.f2py (0.2 s)
        or m in ("scipy.linalg", "numpy.f2py", "numpy.testing")
        # the command line lists the import formats without the import machinery
        or m in ("ldvsurvey.io.importers.build", "ldvsurvey.io.importers.checks")
    }
    assert heavy == set()
    assert {"scipy.linalg.cython_blas", "numba"} <= mods
    other_pipelines = ("gravity", "dov", "height", "tilt", "damping", "calibrate", "warmup")
    names = {m.split(".")[2] for m in mods if m.startswith("ldvsurvey.pipelines.")}
    assert not {n for n in names if n in other_pipelines or n.startswith("gravity_")}

    freeze_before = gc.get_freeze_count()
    assert main(["run", "navigate", str(gnss_bundle), "--out", str(called)]) == 0
    assert gc.isenabled() and gc.get_freeze_count() == freeze_before  # a caller's process is left as it was
    assert (own / "trajectory.csv").read_bytes() == (called / "trajectory.csv").read_bytes()
    s_own, s_called = (json.loads((p / "summary.json").read_text()) for p in (own, called))
    for s in (s_own, s_called):
        s.pop("started_at", None)
        s.pop("elapsed_s", None)
    assert s_own == s_called
