"""Login throttling per client address through a real server process: a forged ``X-Forwarded-For``
sent from loopback must not give each attempt a new address (issue 28), whichever way the server is
started (``ldv-survey serve``, or ``uvicorn ldvsurvey.api.asgi:app`` with uvicorn's own defaults,
which believe proxy headers from 127.0.0.1)."""

import os
import signal
import subprocess
import sys
from pathlib import Path

import httpx
import pytest

from tests.helpers.server import free_port, wait_healthy

ROOT = Path(__file__).resolve().parents[2]
ADMIN = {"username": "root", "password": "first-admin-pw"}
PER_CLIENT = 4


def _start(how: str, tmp_path: Path, trusted: str = ""):
    port = free_port()
    env = {
        k: v
        for k, v in os.environ.items()
        if not k.startswith("LDVSURVEY_") and k != "FORWARDED_ALLOW_IPS" or k == "LDVSURVEY_NUMBA_CACHE_DIR"
    }
    env.update(
        PYTHONPATH=str(ROOT / "backend"),
        LDVSURVEY_DATA_DIR=str(tmp_path / "data"),
        LDVSURVEY_AUTH_ENABLED="true",
        LDVSURVEY_ADMIN_USER=ADMIN["username"],
        LDVSURVEY_ADMIN_PASSWORD=ADMIN["password"],
        LDVSURVEY_LOGIN_FAILURES_PER_CLIENT=str(PER_CLIENT),
        LDVSURVEY_LOGIN_FAILURES_PER_ACCOUNT="100",
        LDVSURVEY_RUN_CONSUMER="false",  # no job runs here: no compile of the numerical core
        LDVSURVEY_TRUSTED_PROXIES=trusted,
    )
    if how == "serve":
        cmd = [sys.executable, "-m", "ldvsurvey.cli", "serve", "--host", "127.0.0.1", "--port", str(port)]
    else:  # the ASGI entry under uvicorn with uvicorn's defaults (proxy headers from 127.0.0.1 believed)
        cmd = [sys.executable, "-m", "uvicorn", "ldvsurvey.api.asgi:app", "--host", "127.0.0.1", "--port", str(port)]
    proc = subprocess.Popen(
        cmd, env=env, cwd=tmp_path, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, start_new_session=True
    )
    base = f"http://127.0.0.1:{port}"
    if not wait_healthy(base, proc=proc):
        _stop(proc)
        pytest.fail(f"{how} did not start: {proc.stderr.read().decode()[-2000:]}")
    return proc, base


def _stop(proc) -> None:
    if proc.poll() is None:
        os.killpg(proc.pid, signal.SIGTERM)
        try:
            proc.wait(timeout=20)
        except subprocess.TimeoutExpired:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()


def _fail_from(base: str, n: int, forged) -> list[int]:
    """``n`` failed logins on as many accounts, each with its own forged address."""
    return [
        httpx.post(
            base + "/api/login",
            json={"username": f"nobody{k}", "password": "x"},
            headers={"X-Forwarded-For": forged(k)},
            timeout=10,
        ).status_code
        for k in range(n)
    ]


@pytest.mark.parametrize("how", ["serve", "uvicorn-asgi"])
def test_forged_forwarded_for_from_loopback_does_not_escape_the_per_address_limit(how, tmp_path):
    proc, base = _start(how, tmp_path)
    try:
        codes = _fail_from(base, PER_CLIENT + 2, lambda k: f"203.0.113.{k + 1}")
        assert codes[:PER_CLIENT] == [401] * PER_CLIENT, codes
        assert set(codes[PER_CLIENT:]) == {429}, codes  # rotating the header gives no new address
        # not even the right password gets through from here, whatever the header says
        r = httpx.post(base + "/api/login", json=ADMIN, headers={"X-Forwarded-For": "198.51.100.99"}, timeout=10)
        assert r.status_code == 429, r.text
        assert int(r.headers["retry-after"]) >= 1
        without = httpx.post(base + "/api/login", json=ADMIN, timeout=10).status_code
        if how == "serve":  # the app sees the peer itself: one count, header or not
            assert without == 429
        else:  # uvicorn replaced the peer: every such request shares one count, the peer has its own
            assert without == 200
    finally:
        _stop(proc)


def test_serve_believes_the_header_from_a_configured_proxy(tmp_path):
    """With loopback configured as the proxy, each forwarded client has its own count."""
    proc, base = _start("serve", tmp_path, trusted="127.0.0.1")
    try:
        codes = _fail_from(base, PER_CLIENT + 1, lambda k: "203.0.113.7")
        assert codes == [401] * PER_CLIENT + [429], codes
        other = httpx.post(base + "/api/login", json=ADMIN, headers={"X-Forwarded-For": "198.51.100.2"}, timeout=10)
        assert other.status_code == 200, other.text
    finally:
        _stop(proc)


def _app(settings, trusted: str):
    from ldvsurvey.api.app import create_app

    return create_app(
        settings.model_copy(
            update={
                "auth_enabled": True,
                "login_failures_per_client": PER_CLIENT,
                "login_failures_per_account": 100,
                "trusted_proxies": trusted,
                "run_consumer": False,
            }
        )
    )


def _as_rewritten(c, k: int, ip: str) -> int:
    """A failed login as a server in front delivers it after replacing the peer from the header:
    the peer is the header's hop (uvicorn gives it port 0)."""
    return c.post(
        "/api/login", json={"username": f"n{k}", "password": "x"}, headers={"X-Forwarded-For": ip}
    ).status_code


def test_a_peer_rewritten_by_the_server_is_not_believed_without_a_trusted_proxy(settings):
    from fastapi.testclient import TestClient

    app = _app(settings, "")
    codes = []
    for k in range(PER_CLIENT + 2):  # each attempt from a new forged address, as uvicorn would hand it over
        ip = f"203.0.113.{k + 1}"
        codes.append(_as_rewritten(TestClient(app, client=(ip, 0)), k, ip))
    assert codes == [401] * PER_CLIENT + [429, 429], codes
    c = TestClient(app, client=("198.51.100.5", 51000))  # a real peer without a header: its own count
    assert c.post("/api/login", json={"username": "m", "password": "x"}).status_code == 401


def test_a_peer_rewritten_by_the_rule_of_the_trusted_proxies_keeps_its_own_count(settings):
    """The server in front applied the same rule (given the same proxies): each client its own count."""
    from fastapi.testclient import TestClient

    app = _app(settings, "127.0.0.1")
    c = TestClient(app, client=("203.0.113.7", 0))  # (no lifespan: no job consumer needed)
    codes = [_as_rewritten(c, k, "203.0.113.7, 127.0.0.1") for k in range(PER_CLIENT + 1)]
    assert codes == [401] * PER_CLIENT + [429], codes
    assert _as_rewritten(TestClient(app, client=("198.51.100.2", 0)), 99, "198.51.100.2") == 401  # not blocked
