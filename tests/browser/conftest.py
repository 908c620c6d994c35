"""A real server process and Debian's Chromium driven by Playwright (never a downloaded browser)."""

import os
import subprocess
import sys
from pathlib import Path

import pytest

from tests.browser.helpers import ADMIN
from tests.helpers.server import free_port, wait_healthy

CHROMIUM = "/usr/bin/chromium"


def _serve(tmp_path_factory, extra: dict):
    port = free_port()
    data = tmp_path_factory.mktemp("srv")
    env = {**os.environ, "LDVSURVEY_DATA_DIR": str(data), "LDVSURVEY_MAX_UPLOAD_BYTES": str(200 * 1024 * 1024), **extra}
    for k in ("LDVSURVEY_DATABASE_URL", "LDVSURVEY_REDIS_URL", "LDVSURVEY_DEMO_MODE", "LDVSURVEY_AUTH_ENABLED"):
        if k not in extra:
            env.pop(k, None)
    log = open(data / "server.log", "w")
    proc = subprocess.Popen(
        [sys.executable, "-m", "ldvsurvey.cli", "serve", "--host", "127.0.0.1", "--port", str(port)],
        env=env,
        stdout=log,
        stderr=subprocess.STDOUT,
    )
    base = f"http://127.0.0.1:{port}"
    if not wait_healthy(base, proc=proc):
        proc.kill()
        raise RuntimeError((data / "server.log").read_text())
    return proc, base


@pytest.fixture(scope="session")
def server(tmp_path_factory):
    # the page acts as the demo account (as after ./scripts/run.sh)
    proc, base = _serve(tmp_path_factory, {"LDVSURVEY_DEMO_MODE": "1"})
    yield base
    proc.terminate()
    proc.wait(timeout=20)


@pytest.fixture(scope="session")
def auth_server(tmp_path_factory):
    """Authentication on, no demo account: the first admin comes from the environment (as in the README)."""
    proc, base = _serve(tmp_path_factory, {"LDVSURVEY_ADMIN_USER": ADMIN[0], "LDVSURVEY_ADMIN_PASSWORD": ADMIN[1]})
    yield base
    proc.terminate()
    proc.wait(timeout=20)


@pytest.fixture(scope="session")
def browser():
    if not Path(CHROMIUM).exists():
        pytest.fail("Debian's chromium is not installed (scripts/setup.sh --browser installs it)")
    from playwright.sync_api import sync_playwright

    with sync_playwright() as p:
        b = p.chromium.launch(
            executable_path=CHROMIUM,
            headless=True,
            args=[
                "--no-sandbox",
                "--disable-gpu",
                "--disable-quic",
                "--no-first-run",
                "--disable-background-networking",
                "--disable-component-update",
                "--disable-sync",
            ],
        )
        yield b
        b.close()


@pytest.fixture
def page(browser):
    ctx = browser.new_context(accept_downloads=True, viewport={"width": 1300, "height": 900})
    pg = ctx.new_page()
    yield pg
    ctx.close()
