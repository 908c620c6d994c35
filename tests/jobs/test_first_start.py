"""First start: the server listens while the numerical core compiles in the background, and the
first jobs wait for that compile, saying so in their stage (the job page shows it)."""

import threading
import time

import pytest
from fastapi.testclient import TestClient

from ldvsurvey.pipelines import warmup as W
from ldvsurvey.pipelines.base import Cancelled
from ldvsurvey.store.db import session_scope
from ldvsurvey.store.models import Job
from tests.jobs.test_runner import _app, _upload


@pytest.fixture
def quiet(settings):
    if settings.database_url:
        pytest.skip("uses its own SQLite databases")
    return settings


@pytest.fixture
def fake_warmup(monkeypatch):
    """A background 'warm-up' that runs until the test releases it."""
    release = threading.Event()
    th = threading.Thread(target=release.wait, kwargs={"timeout": 60}, daemon=True)
    th.start()
    monkeypatch.setattr(W, "_background", th)
    yield release
    release.set()
    th.join(5)


def test_wait_for_warmup_blocks_until_it_ends(fake_warmup):
    said = []
    threading.Timer(0.6, fake_warmup.set).start()
    t0 = time.monotonic()
    waited = W.wait_for_warmup(lambda: said.append(1), poll_s=0.05)
    assert said == [1] and 0.5 < waited and time.monotonic() - t0 < 5
    assert W.wait_for_warmup(lambda: said.append(2)) == 0.0 and said == [1]  # nothing to wait for now


def test_wait_for_warmup_stops_when_cancelled(fake_warmup):
    with pytest.raises(Cancelled):
        W.wait_for_warmup(cancelled=lambda: True, poll_s=0.05)


def test_a_job_waits_for_the_compile_and_says_so(quiet, fake_warmup):
    app = _app(quiet, "first")
    with TestClient(app) as c:
        log_id = _upload(c, rotating=True, seed=5)
        job_id = c.post(f"/api/logs/{log_id}/jobs", json={"pipeline": "tilt"}).json()["id"]
        out = {}
        th = threading.Thread(target=lambda: out.update(status=app.state.runner.execute(job_id)), daemon=True)
        th.start()
        for _ in range(100):
            j = c.get(f"/api/jobs/{job_id}").json()
            if j["stage"] == W.WAITING_STAGE:
                break
            time.sleep(0.1)
        assert j["status"] == "running" and j["stage"] == W.WAITING_STAGE
        assert "compile" in j["stage"]
        time.sleep(1.0)
        assert th.is_alive()  # still waiting: nothing ran beside the compile
        assert c.post(f"/api/jobs/{job_id}/cancel").status_code == 200
        th.join(10)
        assert out["status"] == "cancelled"
        with session_scope(app.state.database_url) as s:
            stages = [e["stage"] for e in s.get(Job, job_id).stage_log]
        assert W.WAITING_STAGE in stages


def test_background_warmup_can_be_turned_off(monkeypatch):
    monkeypatch.setattr(W, "_background", None)
    monkeypatch.setattr(W, "is_warm", lambda: False)  # a cold cache: it would start compiling
    started = []
    monkeypatch.setattr(W, "warmup", lambda **kw: started.append(kw))
    monkeypatch.setenv("LDVSURVEY_BACKGROUND_WARMUP", "0")
    assert W.start_background_warmup() is None and W._background is None
    monkeypatch.setenv("LDVSURVEY_BACKGROUND_WARMUP", "1")
    th = W.start_background_warmup()
    th.join(5)
    assert th is not None and len(started) == 1
