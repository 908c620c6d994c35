"""The facts a log's applicability is checked on are kept when it is stored; a row stored before
migration 0007 (``facts`` NULL) gets them from its stored arrays on first use, and keeps them."""

import copy

import numpy as np

from ldvsurvey.io.drivelog import parse_files
from ldvsurvey.io.quality import quality_report
from ldvsurvey.io.writers import imu_csv, ldv_csv, manifest_json
from ldvsurvey.jobs.runner import log_facts
from ldvsurvey.store.db import session_scope, upgrade_head
from ldvsurvey.store.logs import store_log
from ldvsurvey.store.models import Log
from tests.bundles import MANIFEST, make_bundle


def _two_passes() -> dict[str, bytes]:
    """10 Hz, the LDV speed showing two 1.5-km passes between stops; no GNSS, no manifest lines."""
    speed = np.r_[np.zeros(200), np.full(1000, 15.0), np.zeros(200), np.full(1000, 15.0), np.zeros(200)]
    n = len(speed)
    t = 30000.0 + np.arange(1, n + 1) / 10.0
    m = copy.deepcopy(MANIFEST)
    m["imu"]["rate_hz"] = m["ldv"]["rate_hz"] = 10.0
    rng = np.random.default_rng(1)
    return {
        "manifest.json": manifest_json(m),
        "imu.csv": imu_csv(t, rng.normal(0, 1e-5, (n, 3)), rng.normal(0, 1e-3, (n, 3)) + [0, 0, 0.98], None),
        "ldv.csv": ldv_csv(t, v_fwd_mps=speed, v_up_mps=np.zeros(n), quality=np.full(n, 200.0)),
    }


def test_facts_stored_and_computed_for_old_rows(tmp_path):
    url = f"sqlite:///{tmp_path / 'f.db'}"
    upgrade_head(url)
    with session_scope(url) as s:
        log = parse_files(_two_passes())
        row, _ = store_log(s, log, quality_report(log))
        noldv = parse_files(make_bundle(seed=5, n_imu=500, ldv=False))
        row2, _ = store_log(s, noldv, quality_report(noldv))
        ids = row.id, row2.id
        assert row.facts["repeated_lines"] == 2 and row.facts["repeated_lines_from"] == "ldv"
        assert row2.facts["has_ldv"] is False and row2.ldv_kind == "none"
        row.facts = None  # as a row stored before the facts were kept
    with session_scope(url) as s:
        row = s.get(Log, ids[0])
        assert row.facts is None
        f = log_facts(row)
        assert f.repeated_lines == 2 and f.has_ldv
        f2 = log_facts(s.get(Log, ids[1]))
        assert not f2.has_ldv and f2.ldv_kind == "none" and f2.has_gnss
    with session_scope(url) as s:  # kept
        assert s.get(Log, ids[0]).facts["repeated_lines"] == 2
