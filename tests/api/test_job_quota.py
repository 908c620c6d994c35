"""The per-user limit of active jobs holds under concurrent submissions (issue 28: 20 at once with a
limit of 4 accepted 7-8). Runs on SQLite, and on PostgreSQL when ``LDVSURVEY_TEST_DATABASE_URL``
names one (``scripts/test.sh`` runs ``tests/api`` again that way under CI)."""

import concurrent.futures as cf
import threading

import pytest
from fastapi.testclient import TestClient
from sqlalchemy import func, select

from ldvsurvey.api.app import create_app
from ldvsurvey.store.db import session_scope
from ldvsurvey.store.models import Job
from ldvsurvey.store.users import create_user, new_api_token
from tests.bundles import make_bundle

LIMIT = 4
SUBMISSIONS = 20


@pytest.fixture
def quota_app(settings):
    st = settings.model_copy(
        update={
            "auth_enabled": True,
            "max_active_jobs_per_user": LIMIT,
            "run_consumer": False,  # the jobs stay queued: only the count at submit is under test
        }
    )
    app = create_app(st)
    with session_scope(app.state.database_url) as s:
        token = new_api_token(s, create_user(s, "alice", "alice-password", project="Project A"), "t")
    with TestClient(app) as c:
        h = {"Authorization": f"Bearer {token}"}
        r = c.post("/api/logs", headers=h, files=[("files", (n, d, "x")) for n, d in make_bundle(seed=31).items()])
        assert r.status_code == 201, r.text
        yield c, h, r.json()["id"]


def _active(url: str) -> int:
    with session_scope(url) as s:
        return s.scalar(select(func.count()).select_from(Job).where(Job.status.in_(("queued", "running"))))


def test_concurrent_submissions_accept_exactly_the_limit(quota_app):
    c, h, log_id = quota_app
    start = threading.Barrier(SUBMISSIONS)

    def submit(_):
        start.wait()  # all at once
        return c.post(f"/api/logs/{log_id}/jobs", headers=h, json={"pipeline": "height"})

    with cf.ThreadPoolExecutor(SUBMISSIONS) as pool:
        answers = list(pool.map(submit, range(SUBMISSIONS)))
    codes = sorted(r.status_code for r in answers)
    assert codes == [201] * LIMIT + [429] * (SUBMISSIONS - LIMIT), [(r.status_code, r.text[:200]) for r in answers]
    assert _active(c.app.state.database_url) == LIMIT
    for r in answers:
        if r.status_code == 429:
            assert f"{LIMIT} jobs already queued or running (limit {LIMIT})" in r.json()["detail"]
            assert int(r.headers["retry-after"]) >= 1


def test_retry_counts_against_the_limit(quota_app):
    """A cancelled job run again is an active job like a new one."""
    c, h, log_id = quota_app
    first = c.post(f"/api/logs/{log_id}/jobs", headers=h, json={"pipeline": "height"}).json()["id"]
    assert c.post(f"/api/jobs/{first}/cancel", headers=h).status_code == 200
    for _ in range(LIMIT):
        assert c.post(f"/api/logs/{log_id}/jobs", headers=h, json={"pipeline": "height"}).status_code == 201
    r = c.post(f"/api/jobs/{first}/retry", headers=h)
    assert r.status_code == 429, r.text
    assert _active(c.app.state.database_url) == LIMIT
