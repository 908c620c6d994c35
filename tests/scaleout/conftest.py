"""Real engines: PostgreSQL and Redis on loopback (the API and huey worker processes: helpers.Stack).

Selected with LDVSURVEY_TEST_SCALEOUT=1 (CI sets it). When selected and an engine is unreachable
the tests fail; when not selected they are skipped (SQLite stays the default everywhere else).
"""

import os

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


@pytest.fixture
def pg_fresh(engines):
    from tests.helpers.db import reset_database

    reset_database(engines[0])
    import redis

    redis.Redis.from_url(engines[1]).flushdb()
    return engines
