"""Simultaneous guesses at one account: the per-account limit holds (each attempt is counted before
its password is checked) and no request fails for want of a database connection (the throttle
took a second pooled connection while the request held one: 20 at once exhausted the pool, 500)."""

import concurrent.futures as cf
import os
import threading

import pytest
from fastapi.testclient import TestClient

from ldvsurvey.api.app import create_app

LIMIT = 5
AT_ONCE = 20


def _redis_url():
    import redis

    url = os.environ.get("LDVSURVEY_TEST_REDIS_URL", "redis://127.0.0.1:6379/15")
    try:
        redis.Redis.from_url(url, socket_connect_timeout=1).ping()
    except redis.RedisError:
        pytest.skip(f"no Redis at {url}")
    return url


@pytest.mark.parametrize("counters", ["database", "redis"])
def test_simultaneous_guesses_check_at_most_the_limit(settings, counters):
    st = settings.model_copy(
        update={
            "auth_enabled": True,
            "admin_user": "root",
            "admin_password": "the-right-password",
            "login_failures_per_account": LIMIT,
            "run_consumer": False,
            "redis_url": _redis_url() if counters == "redis" else None,
        }
    )
    with TestClient(create_app(st)) as c:
        start = threading.Barrier(AT_ONCE)

        def guess(k):
            start.wait()
            return c.post("/api/login", json={"username": "root", "password": f"guess{k}"})

        with cf.ThreadPoolExecutor(AT_ONCE) as pool:
            answers = list(pool.map(guess, range(AT_ONCE)))
        codes = [r.status_code for r in answers]
        assert set(codes) <= {401, 429}, [(r.status_code, r.text[:200]) for r in answers]
        assert codes.count(401) <= LIMIT, codes  # passwords checked: never more than the limit
        refused = c.post("/api/login", json={"username": "root", "password": "the-right-password"})
        if codes.count(401) == LIMIT:
            assert refused.status_code == 429  # the account waits
        else:  # fewer got through: their attempts were not counted, the right password still works
            assert refused.status_code == 200
