"""Real engines: PostgreSQL and Redis on loopback, the API and huey workers as separate processes.

Selected with LDVSURVEY_TEST_SCALEOUT=1 (CI sets it). When selected and an engine is unreachable
the tests fail; when not selected they are skipped (SQLite stays the default everywhere else).
"""

import os
import signal
import socket
import subprocess
import sys
import time

import httpx
import pytest

PG_URL = os.environ.get("LDVSURVEY_TEST_PG_URL", "postgresql+psycopg://root@127.0.0.1:5432/test")
REDIS_URL = os.environ.get("LDVSURVEY_TEST_REDIS_URL", "redis://127.0.0.1:6379/15")
SELECTED = os.environ.get("LDVSURVEY_TEST_SCALEOUT") == "1"


def pytest_collection_modifyitems(config, items):
    if SELECTED:
        return
    skip = pytest.mark.skip(reason="scale-out tests need LDVSURVEY_TEST_SCALEOUT=1 (PostgreSQL + Redis)")
    for item in items:
        if "scaleout" in str(item.fspath):
            item.add_marker(skip)


@pytest.fixture(scope="session")
def engines():
    """Reachable PostgreSQL and Redis, or a failure naming the one that is not."""
    import redis
    from sqlalchemy import create_engine, text

    try:
        with create_engine(PG_URL).connect() as c:
            c.execute(text("SELECT 1"))
    except Exception as exc:
        pytest.fail(f"PostgreSQL at {PG_URL} unreachable: {exc}")
    try:
        redis.Redis.from_url(REDIS_URL).ping()
    except Exception as exc:
        pytest.fail(f"Redis at {REDIS_URL} unreachable: {exc}")
    return PG_URL, REDIS_URL


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class Stack:
    """An API process (several uvicorn workers) and huey worker processes sharing one database."""

    def __init__(self, tmp, db_url, redis_url=None, api_workers=2, **env):
        self.tmp = tmp
        self.port = free_port()
        self.base = f"http://127.0.0.1:{self.port}"
        self.env = {**os.environ, "LDVSURVEY_DATA_DIR": str(tmp), "LDVSURVEY_DATABASE_URL": db_url,
                    "LDVSURVEY_AUTH_ENABLED": "false", "LDVSURVEY_UPLOADS_PER_MINUTE": "1000",
                    "LDVSURVEY_MAX_ACTIVE_JOBS_PER_USER": "1000", **env}
        if redis_url:
            self.env["LDVSURVEY_REDIS_URL"] = redis_url
            self.env["LDVSURVEY_RUN_CONSUMER"] = "false"
        self.api_workers = api_workers
        self.api = None
        self.workers = []

    def start_api(self):
        log = open(self.tmp / f"api-{time.time():.0f}.log", "w")
        self.api = subprocess.Popen(
            [sys.executable, "-m", "uvicorn", "ldvsurvey.api.asgi:app", "--host", "127.0.0.1",
             "--port", str(self.port), "--workers", str(self.api_workers)],
            env=self.env, stdout=log, stderr=subprocess.STDOUT, start_new_session=True)
        for _ in range(120):
            try:
                if httpx.get(self.base + "/api/health", timeout=1).status_code == 200:
                    return
            except httpx.HTTPError:
                pass
            time.sleep(0.25)
        raise RuntimeError("API did not come up")

    def kill_api(self):
        os.killpg(self.api.pid, signal.SIGKILL)
        self.api.wait()

    def start_worker(self):
        log = open(self.tmp / f"worker-{len(self.workers)}.log", "w")
        p = subprocess.Popen([sys.executable, "-m", "huey.bin.huey_consumer", "ldvsurvey.jobs.worker.huey",
                              "-w", "1", "-k", "thread"],
                             env={**self.env, "LDVSURVEY_WORKER": "1"}, stdout=log, stderr=subprocess.STDOUT,
                             start_new_session=True)
        self.workers.append(p)
        return p

    def stop(self):
        for p in [self.api] + self.workers:
            if p is not None and p.poll() is None:
                os.killpg(p.pid, signal.SIGTERM)
                try:
                    p.wait(timeout=15)
                except subprocess.TimeoutExpired:
                    os.killpg(p.pid, signal.SIGKILL)


@pytest.fixture
def pg_fresh(engines):
    from ldvsurvey.store.testing import reset_database

    reset_database(engines[0])
    import redis

    redis.Redis.from_url(engines[1]).flushdb()
    return engines
