"""Demo mode: every visitor acts as the one demo account, which is read-only for data it did not
create (issue 28: any visitor could delete the demo logs, DELETE -> 204)."""

import pytest
from fastapi.testclient import TestClient
from sqlalchemy import select

from ldvsurvey.api.app import create_app
from ldvsurvey.store.db import session_scope
from ldvsurvey.store.models import Job, Project, User
from ldvsurvey.store.users import new_api_token
from tests.bundles import make_bundle


@pytest.fixture
def demo(settings):
    st = settings.model_copy(
        update={
            "auth_enabled": True,
            "demo_mode": True,
            "admin_user": "admin",
            "admin_password": "s3cret-admin-pw",
            "run_consumer": False,  # jobs stay queued
        }
    )
    app = create_app(st)
    url = app.state.database_url
    with session_scope(url) as s:
        admin = s.scalar(select(User).where(User.username == "admin"))
        ha = {"Authorization": f"Bearer {new_api_token(s, admin, 't')}"}
        project = s.scalar(select(Project).where(Project.name == "Demo survey")).id
    with TestClient(app) as c:
        # the demo survey, loaded by the operator (here: the admin) into the demo's project
        r = c.post(
            "/api/logs",
            headers=ha,
            data={"project_id": str(project)},
            files=[("files", (n, d, "x")) for n, d in make_bundle(seed=51).items()],
        )
        assert r.status_code == 201, r.text
        log_id = r.json()["id"]
        admin_job = c.post(f"/api/logs/{log_id}/jobs", headers=ha, json={"pipeline": "height"}).json()["id"]
        yield c, url, log_id, admin_job


def test_visitor_cannot_delete_the_demo_logs(demo):
    c, _, log_id, _ = demo
    assert c.get("/api/me").json()["demo"] is True  # a visitor without a session is the demo account
    r = c.delete(f"/api/logs/{log_id}")
    assert r.status_code == 403, r.text
    assert "demo account" in r.json()["detail"] and "read-only" in r.json()["detail"]
    assert c.get(f"/api/logs/{log_id}").status_code == 200  # still there


def test_visitor_cannot_cancel_or_retry_jobs_it_did_not_start(demo):
    c, url, log_id, admin_job = demo
    r = c.post(f"/api/jobs/{admin_job}/cancel")
    assert r.status_code == 403 and "did not start" in r.json()["detail"], r.text
    with session_scope(url) as s:
        assert s.get(Job, admin_job).status == "queued" and not s.get(Job, admin_job).cancel_requested
        s.get(Job, admin_job).status = "failed"
    r = c.post(f"/api/jobs/{admin_job}/retry")
    assert r.status_code == 403 and "did not start" in r.json()["detail"], r.text
    with session_scope(url) as s:
        assert s.get(Job, admin_job).status == "failed"


def test_visitor_may_cancel_and_retry_the_jobs_it_started(demo):
    c, _, log_id, _ = demo
    mine = c.post(f"/api/logs/{log_id}/jobs", json={"pipeline": "height"})
    assert mine.status_code == 201, mine.text
    assert c.post(f"/api/jobs/{mine.json()['id']}/cancel").json()["status"] == "cancelled"
    assert c.post(f"/api/jobs/{mine.json()['id']}/retry").json()["status"] == "queued"
    # and it may still upload (creating is not changing what others made)
    up = c.post("/api/logs", files=[("files", (n, d, "x")) for n, d in make_bundle(seed=52).items()])
    assert up.status_code == 201, up.text


def test_visitor_cannot_take_tokens_or_the_password_of_the_shared_account(demo):
    c, *_ = demo
    assert c.post("/api/tokens", json={"name": "mine"}).status_code == 403
    assert c.delete("/api/tokens/1").status_code == 403
    r = c.post("/api/password", json={"old_password": "x", "new_password": "a new long password"})
    assert r.status_code == 403 and "demo account" in r.json()["detail"]
