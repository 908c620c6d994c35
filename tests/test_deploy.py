"""The compose file parses without an engine, fails fast without secrets, and the image installs the README's way."""

import os
import re
import shutil
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def _compose(env):
    exe = shutil.which("docker-compose")
    if exe is None:
        pytest.fail("Debian's docker-compose is not installed (scripts/setup.sh installs it)")
    return subprocess.run(
        [exe, "-f", str(ROOT / "docker-compose.yml"), "config"],
        capture_output=True,
        text=True,
        env={**os.environ, **env},
        cwd=ROOT,
    )


def test_compose_file_validates_and_scales_workers():
    r = _compose({"POSTGRES_PASSWORD": "pw", "LDVSURVEY_ADMIN_PASSWORD": "admin-pw"})
    assert r.returncode == 0, r.stderr
    out = r.stdout
    for svc in ("db:", "redis:", "migrate:", "api:", "worker:"):
        assert svc in out
    assert "service_completed_successfully" in out and "huey_consumer" in out and "healthcheck" in out


def test_compose_runs_two_workers_without_a_shared_volume():
    """The workers need only PostgreSQL and Redis (the logs' files are in the database): no volume of
    the API's, so they may run on other machines."""
    import yaml

    r = _compose({"POSTGRES_PASSWORD": "pw", "LDVSURVEY_ADMIN_PASSWORD": "admin-pw"})
    assert r.returncode == 0, r.stderr
    services = yaml.safe_load(r.stdout)["services"]
    worker = services["worker"]
    assert worker.get("scale", 1) >= 2 or worker.get("deploy", {}).get("replicas", 1) >= 2
    assert not worker.get("volumes")
    assert worker["environment"]["LDVSURVEY_DATABASE_URL"].startswith("postgresql")


def test_compose_fails_fast_without_secrets():
    env = {k: v for k, v in os.environ.items() if k not in ("POSTGRES_PASSWORD", "LDVSURVEY_ADMIN_PASSWORD")}
    r = subprocess.run(
        [shutil.which("docker-compose") or "docker-compose", "-f", str(ROOT / "docker-compose.yml"), "config"],
        capture_output=True,
        text=True,
        env=env,
        cwd=ROOT,
    )
    assert r.returncode != 0 and "POSTGRES_PASSWORD" in (r.stderr + r.stdout)


def test_dockerfile_installs_with_the_readme_setup():
    docker = (ROOT / "Dockerfile").read_text()
    readme = (ROOT / "README.md").read_text()
    assert "RUN ./scripts/setup.sh" in docker
    assert "scripts/setup.sh" in readme


def test_uvicorn_in_the_image_and_compose_does_not_believe_proxy_headers():
    """The app reads X-Forwarded-For itself, from LDVSURVEY_TRUSTED_PROXIES only; uvicorn's default
    (believe it from 127.0.0.1) would hand it a forged client address (issue 28)."""
    r = _compose({"POSTGRES_PASSWORD": "pw", "LDVSURVEY_ADMIN_PASSWORD": "admin-pw"})
    assert r.returncode == 0, r.stderr
    lines = r.stdout.split("\n  api:\n", 1)[1].splitlines()
    api = lines[: next((i for i, ln in enumerate(lines) if re.match(r"^ {0,2}\S", ln)), len(lines))]
    assert "    - --no-proxy-headers" in api
    cmd = [ln for ln in (ROOT / "Dockerfile").read_text().splitlines() if ln.startswith("CMD")]
    assert cmd and "--no-proxy-headers" in cmd[0]
