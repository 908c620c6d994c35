"""The survey report over REST: one self-contained HTML file per job and per project, carrying its
figures as SVG, its tables, warnings and provenance (the printing to PDF is checked in Chromium:
tests/browser/test_report_pages.py)."""

import datetime as dt
import re

import pytest

from ldvsurvey.api import views as V
from ldvsurvey.api.report import label_unit, nice_length
from tests.api.helpers import SUMMARIES, provenance, store_job, tables
from tests.bundles import make_bundle

SHA = "0123456789abcdef" * 4


@pytest.fixture
def stored(client):
    from ldvsurvey.store.db import session_scope
    from ldvsurvey.store.models import Log
    from ldvsurvey.store.users import create_project

    files = make_bundle(seed=71, n_imu=300)
    log_id = client.post("/api/logs", files=[("files", (n, d, "x")) for n, d in files.items()]).json()["id"]
    url = client.app_state.database_url
    with session_scope(url) as s:
        pid = create_project(s, "Survey Nord 2026").id
        s.get(Log, log_id).project_id = pid
    tabs, _ = tables()
    grav = store_job(
        url,
        [log_id],
        "gravity",
        {k: tabs[k] for k in ("gravity.csv", "coincidence.csv")},
        {**provenance("gravity", SHA), **SUMMARIES["gravity"], "lines": [{"name": "L1", "rms_mgal": 0.21}]},
    )
    hgt = store_job(
        url,
        [log_id],
        "height",
        {"height.csv": tabs["height.csv"]},
        {**provenance("height", SHA), **SUMMARIES["height"]},
    )
    return log_id, pid, grav, hgt


def _self_contained(text: str):
    assert text.startswith("<!DOCTYPE html>") and "<style>" in text
    assert "<script" not in text.lower()
    assert not re.search(r"""\b(src|href)\s*=\s*["']?(https?:|//|/)""", text), "the report fetches something"
    assert not re.search(r"url\((?!#)", text) and "@import" not in text  # only references inside the file


def test_job_report_is_one_file_with_figures_tables_and_provenance(client, stored):
    log_id, _, grav, _ = stored
    r = client.get(f"/api/jobs/{grav}/report")
    assert r.status_code == 200, r.text
    assert r.headers["content-type"].startswith("text/html")
    assert re.search(
        rf'attachment; filename="ldv-survey-job-{grav}-gravity-report\.html"', r.headers["content-disposition"]
    )
    text = r.text
    _self_contained(text)
    # the map and every view of the pipeline, as inline SVG
    plots = [
        v.name for v in V.views_of("gravity", SUMMARIES["gravity"]) if not v.name.endswith("_map")
    ]  # maps: the report draws its own
    assert text.count("<svg") == 1 + len(plots)
    assert f'id="map-{grav}"' in text and all(f'id="figure-{grav}-{name}"' in text for name in plots)
    # provenance: each input's SHA-256, every parameter, the software version, the dates, the log
    for h in (SHA, SHA[::-1]):
        assert f"<code>{h}</code>" in text
    bundle = client.get(f"/api/logs/{log_id}").json()["sha256"]
    assert bundle in text
    for k, v in provenance("gravity", SHA)["parameters"].items():
        assert f"<code>{k}</code>" in text and str(v) in text
    assert "9.8.7-test" in text and "2026-01-02T03:04:05+00:00" in text
    assert f"Report generated {dt.datetime.now(dt.UTC):%Y-%m-%d}" in text and "Survey Nord 2026" in text
    # headline figures with units, the per-line table, the warnings
    assert "0.2000 mGal" in text and "0.1500 mGal" in text and "L1" in text
    assert "line L2: 30 s of IMU gap bridged" in text


def test_project_report_holds_its_logs_map_and_jobs(client, stored):
    log_id, pid, grav, hgt = stored
    r = client.get(f"/api/projects/{pid}/report")
    assert r.status_code == 200, r.text
    text = r.text
    _self_contained(text)
    assert 'id="map-project"' in text and f'id="job-{grav}"' in text and f'id="job-{hgt}"' in text
    assert client.get(f"/api/logs/{log_id}").json()["sha256"] in text
    assert "against RTK fixed (fix 4)" in text.replace("&#x27;", "'") or "RTK fixed (fix 4)" in text
    assert "Survey report: project Survey Nord 2026" in text


def test_report_refusals(client, stored):
    _, pid, grav, _ = stored
    from ldvsurvey.store.db import session_scope
    from ldvsurvey.store.models import Job

    with session_scope(client.app_state.database_url) as s:
        s.get(Job, grav).status = "running"
    r = client.get(f"/api/jobs/{grav}/report")
    assert r.status_code == 409 and "only a succeeded job" in r.json()["detail"]
    assert client.get("/api/jobs/999999/report").status_code == 404
    assert client.get(f"/api/projects/{pid + 1000}/report").status_code == 404


def test_labels_units_and_the_scale_bar_length():
    assert label_unit("total_mgal") == ("total", "mGal")
    assert label_unit("max_error_m_fix4") == ("max error (fix4)", "m")
    assert label_unit("n_lines_compared") == ("n lines compared", "")
    # a round length near a fifth of the map's extent
    assert [nice_length(s) for s in (4000.0, 900.0, 12.0, 70000.0)] == [1000.0, 200.0, 2.0, 10000.0]
