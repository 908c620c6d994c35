"""Helpers of the browser tests."""

from pathlib import Path

ARTIFACTS = Path(__file__).resolve().parents[2] / "test-artifacts"

#: the first admin the ``auth_server`` fixture starts with (user, password)
ADMIN = ("admin", "first-admin-password")


def shot(page, name):
    """A full-page screenshot into test-artifacts/<name>.png."""
    ARTIFACTS.mkdir(exist_ok=True)
    page.screenshot(path=str(ARTIFACTS / f"{name}.png"), full_page=True)


def start_server(data: Path, env_extra: dict):
    """A server process on ``data`` with the given LDVSURVEY_* settings (and no others from the
    environment but the compile cache and the background warm-up switch); returns (process, base URL).
    Stop it with terminate()."""
    import os
    import subprocess
    import sys

    from tests.helpers.server import free_port, wait_healthy

    keep = ("LDVSURVEY_NUMBA_CACHE_DIR", "LDVSURVEY_BACKGROUND_WARMUP")
    env = {k: v for k, v in os.environ.items() if not k.startswith("LDVSURVEY_") or k in keep}
    env.update({"LDVSURVEY_DATA_DIR": str(data), **env_extra})
    port = free_port()
    base = f"http://127.0.0.1:{port}"
    with open(data / "server.log", "w") as log:
        proc = subprocess.Popen(
            [sys.executable, "-m", "ldvsurvey.cli", "serve", "--host", "127.0.0.1", "--port", str(port)],
            env=env,
            stdout=log,
            stderr=subprocess.STDOUT,
        )
    if not wait_healthy(base, proc=proc):
        proc.kill()
        raise RuntimeError((data / "server.log").read_text())
    return proc, base
