"""Every 429 says when to try again (``Retry-After``, RFC 9110 §10.2.3): the seconds until the
oldest counted attempt leaves its window."""

import time

from fastapi.testclient import TestClient

from ldvsurvey.api.app import create_app


def test_upload_rate_429_carries_retry_after(settings):
    st = settings.model_copy(update={"uploads_per_minute": 2, "run_consumer": False})
    with TestClient(create_app(st)) as c:
        t0 = time.monotonic()
        for _ in range(2):  # refused uploads count too: the rate is checked first
            assert c.post("/api/logs", files=[("files", ("x.zip", b"not a zip", "application/zip"))]).status_code == 422
        r = c.post("/api/logs", files=[("files", ("x.zip", b"not a zip", "application/zip"))])
        elapsed = time.monotonic() - t0
        assert r.status_code == 429, r.text
        assert 60 - elapsed - 1 <= int(r.headers["retry-after"]) <= 60


def test_login_429_carries_retry_after(settings):
    st = settings.model_copy(
        update={
            "auth_enabled": True,
            "login_failures_per_account": 3,
            "login_window_s": 900.0,
            "run_consumer": False,
        }
    )
    with TestClient(create_app(st)) as c:
        t0 = time.monotonic()
        for _ in range(3):
            assert c.post("/api/login", json={"username": "eve", "password": "x"}).status_code == 401
        r = c.post("/api/login", json={"username": "eve", "password": "x"})
        elapsed = time.monotonic() - t0
        assert r.status_code == 429, r.text
        assert 900 - elapsed - 1 <= int(r.headers["retry-after"]) <= 900
