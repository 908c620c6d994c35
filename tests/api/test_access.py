"""Access control: project A's user can not read, download, start jobs on, or delete project B's logs."""

import pytest
from fastapi.testclient import TestClient

from ldvsurvey.api.app import create_app
from ldvsurvey.store.db import session_scope
from ldvsurvey.store.models import Job
from ldvsurvey.store.users import create_user, new_api_token
from tests.bundles import make_bundle


@pytest.fixture
def secured(settings):
    st = settings.model_copy(
        update={
            "auth_enabled": True,
            "admin_user": "admin",
            "admin_password": "s3cret-admin",
            "max_active_jobs_per_user": 2,
        }
    )
    app = create_app(st)
    url = app.state.database_url
    with session_scope(url) as s:
        a = create_user(s, "alice", "alice-pw", project="Project A")
        b = create_user(s, "bob", "bob-pw", project="Project B")
        ta, tb = new_api_token(s, a, "t"), new_api_token(s, b, "t")
    with TestClient(app) as c:
        ha, hb = {"Authorization": f"Bearer {ta}"}, {"Authorization": f"Bearer {tb}"}
        r = c.post("/api/logs", headers=ha, files=[("files", (n, d, "x")) for n, d in make_bundle(seed=31).items()])
        assert r.status_code == 201, r.text
        log_a = r.json()["id"]
        with session_scope(url) as s:  # a finished job of A's log with a result file
            j = Job(pipeline="height", log_ids=[log_a], parameters={}, status="failed", stage="failed", progress=0)
            s.add(j)
            s.flush()
            job_a = j.id
        yield c, ha, hb, log_a, job_a


def test_other_project_sees_nothing(secured):
    c, ha, hb, log_a, job_a = secured
    assert [lg["id"] for lg in c.get("/api/logs", headers=ha).json()] == [log_a]
    assert c.get("/api/logs", headers=hb).json() == []
    for path in (
        f"/api/logs/{log_a}",
        f"/api/logs/{log_a}/files/imu.csv",
        f"/api/jobs/{job_a}",
        f"/api/jobs/{job_a}/files",
        f"/api/jobs/{job_a}/files/summary.json",
        f"/api/jobs/{job_a}/views/height",
    ):
        assert c.get(path, headers=hb).status_code == 404, path
        assert c.get(path, headers=ha).status_code in (200, 404, 409), path  # A may (file may not exist yet)
    assert c.get(f"/api/logs/{log_a}/files/imu.csv", headers=ha).status_code == 200
    assert c.get("/api/jobs", headers=hb).json() == []
    assert c.post(f"/api/logs/{log_a}/jobs", headers=hb, json={"pipeline": "height"}).status_code == 404
    assert c.post(f"/api/jobs/{job_a}/retry", headers=hb).status_code == 404
    assert c.post(f"/api/jobs/{job_a}/cancel", headers=hb).status_code == 404
    assert c.delete(f"/api/logs/{log_a}", headers=hb).status_code == 404
    assert c.get(f"/api/logs/{log_a}", headers=ha).status_code == 200  # still there
    # uploading into somebody else's project is refused
    r = c.post(
        "/api/logs",
        headers=hb,
        data={"project_id": "1"},
        files=[("files", (n, d, "x")) for n, d in make_bundle(seed=32).items()],
    )
    assert r.status_code == 404


def test_same_bundle_in_two_projects_does_not_leak(secured):
    c, ha, hb, log_a, _ = secured
    r = c.post("/api/logs", headers=hb, files=[("files", (n, d, "x")) for n, d in make_bundle(seed=31).items()])
    assert r.status_code == 201 and r.json()["id"] != log_a and r.json()["duplicate"] is False


def test_unauthenticated_refused(secured):
    c, ha, hb, log_a, job_a = secured
    files = [("files", (n, d, "x")) for n, d in make_bundle(seed=33).items()]
    assert c.post("/api/logs", files=files).status_code == 401
    assert c.delete(f"/api/logs/{log_a}").status_code == 401
    assert c.post(f"/api/logs/{log_a}/jobs", json={"pipeline": "height"}).status_code == 401
    assert c.get("/api/logs").status_code == 401
    assert c.get("/api/logs", headers={"Authorization": "Bearer nope"}).status_code == 401
    assert c.get("/api/health").status_code == 200


def test_session_cookie_needs_csrf_on_writes(secured):
    c, ha, hb, log_a, _ = secured
    assert c.post("/api/login", json={"username": "alice", "password": "wrong"}).status_code == 401
    r = c.post("/api/login", json={"username": "alice", "password": "alice-pw"})
    assert r.status_code == 200
    csrf = r.json()["csrf"]
    assert "httponly" in r.headers["set-cookie"].lower()
    assert c.get("/api/logs").status_code == 200  # the cookie reads
    files = [("files", (n, d, "x")) for n, d in make_bundle(seed=34).items()]
    assert c.post("/api/logs", files=files).status_code == 403  # no CSRF header
    assert c.post("/api/logs", files=files, headers={"X-CSRF-Token": csrf}).status_code == 201
    assert c.get("/api/me").json()["user"] == "alice"
    c.post("/api/logout", headers={"X-CSRF-Token": csrf})
    assert c.get("/api/logs").status_code == 401


def test_admin_from_environment_sees_all(secured):
    c, *_ = secured
    r = c.post("/api/login", json={"username": "admin", "password": "s3cret-admin"})
    assert r.status_code == 200
    assert len(c.get("/api/logs").json()) >= 1


def test_job_quota_per_user(secured):
    c, ha, hb, log_a, _ = secured
    codes = [
        c.post(
            f"/api/logs/{log_a}/jobs", headers=ha, json={"pipeline": "height", "parameters": {"output_rate_hz": 1}}
        ).status_code
        for _ in range(4)
    ]
    assert 429 in codes  # at most 2 queued or running per user here
