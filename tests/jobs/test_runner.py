"""The job runner: one :class:`JobRunner` per app (no module state), and the worker checks again,
before running, that the pipeline applies to the logs as they are now."""

import pytest
from fastapi.testclient import TestClient

from ldvsurvey.store.db import session_scope
from ldvsurvey.store.models import Job, Log
from tests.bundles import make_bundle


def _app(settings, name):
    from ldvsurvey.api.app import create_app

    # no consumer: jobs stay in the queue until the test runs them
    return create_app(settings.model_copy(update={"data_dir": settings.data_dir / name, "run_consumer": False}))


def _upload(c, **kw) -> int:
    r = c.post("/api/logs", files=[("files", (n, d, "x")) for n, d in make_bundle(n_imu=1000, **kw).items()])
    assert r.status_code == 201, r.text
    return r.json()["id"]


@pytest.fixture
def quiet(settings):
    if settings.database_url:
        pytest.skip("uses its own SQLite databases")
    return settings


def test_two_apps_queue_into_their_own_queues(quiet):
    """Each app's jobs go to its own queue: with one module-wide task the first app's job would land
    in the queue of the app created last."""
    a, b = _app(quiet, "a"), _app(quiet, "b")
    with TestClient(a) as ca, TestClient(b):
        log_id = _upload(ca, rotating=True, seed=3)
        r = ca.post(f"/api/logs/{log_id}/jobs", json={"pipeline": "tilt"})
        assert r.status_code == 201, r.text
        assert a.state.runner.huey.pending_count() == 1
        assert b.state.runner.huey.pending_count() == 0
        assert a.state.runner.database_url != b.state.runner.database_url


def test_worker_rechecks_applicability(quiet):
    """A job queued while its log suited the pipeline fails, before running, with the reason the
    submit would now give, when the stored log changed meanwhile."""
    app = _app(quiet, "c")
    with TestClient(app) as c:
        log_id = _upload(c, rotating=True, seed=4)
        r = c.post(f"/api/logs/{log_id}/jobs", json={"pipeline": "tilt", "parameters": {"output_rate_hz": 1}})
        assert r.status_code == 201, r.text
        job_id = r.json()["id"]
        with session_scope(app.state.database_url) as s:  # the log is no longer from a rotating IMU
            row = s.get(Log, log_id)
            m = dict(row.manifest)
            m["imu"] = {**m["imu"], "rotating": False}
            row.manifest = m
        refused = c.post(f"/api/logs/{log_id}/jobs", json={"pipeline": "tilt", "parameters": {"output_rate_hz": 1}})
        assert refused.status_code == 422
        assert app.state.runner.execute(job_id) == "failed"
        j = c.get(f"/api/jobs/{job_id}").json()
        assert j["status"] == "failed"
        assert j["error"] == refused.json()["detail"]
        assert "rotating IMU" in j["error"]
        assert c.get(f"/api/jobs/{job_id}/files").json() == []  # nothing ran, nothing written
        with session_scope(app.state.database_url) as s:
            assert s.get(Job, job_id).stage_log[-1]["stage"] == f"failed: {j['error']}"
