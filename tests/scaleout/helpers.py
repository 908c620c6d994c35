"""The scale-out stack: an API process and huey workers sharing one database."""

import os
import signal
import subprocess
import sys
import time

from tests.helpers.server import free_port, wait_healthy


class Stack:
    """An API process (several uvicorn workers) and huey worker processes sharing one database."""

    def __init__(self, tmp, db_url, redis_url=None, api_workers=2, **env):
        self.tmp = tmp
        self.port = free_port()
        self.base = f"http://127.0.0.1:{self.port}"
        self.env = {
            **os.environ,
            "LDVSURVEY_DATA_DIR": str(tmp),
            "LDVSURVEY_DATABASE_URL": db_url,
            "LDVSURVEY_AUTH_ENABLED": "false",
            "LDVSURVEY_UPLOADS_PER_MINUTE": "1000",
            "LDVSURVEY_MAX_ACTIVE_JOBS_PER_USER": "1000",
            **env,
        }
        if redis_url:
            self.env["LDVSURVEY_REDIS_URL"] = redis_url
            self.env["LDVSURVEY_RUN_CONSUMER"] = "false"
        self.api_workers = api_workers
        self.api = None
        self.workers = []

    def start_api(self):
        log = open(self.tmp / f"api-{time.time():.0f}.log", "w")
        self.api = subprocess.Popen(
            [
                sys.executable,
                "-m",
                "uvicorn",
                "ldvsurvey.api.asgi:app",
                "--host",
                "127.0.0.1",
                "--port",
                str(self.port),
                "--workers",
                str(self.api_workers),
            ],
            env=self.env,
            stdout=log,
            stderr=subprocess.STDOUT,
            start_new_session=True,
        )
        if not wait_healthy(self.base, pause_s=0.25):
            raise RuntimeError("API did not come up")

    def kill_api(self):
        os.killpg(self.api.pid, signal.SIGKILL)
        self.api.wait()

    def start_worker(self, **env):
        """A huey worker process; ``env`` overrides variables (e.g. its own LDVSURVEY_DATA_DIR)."""
        log = open(self.tmp / f"worker-{len(self.workers)}.log", "w")
        p = subprocess.Popen(
            [sys.executable, "-m", "huey.bin.huey_consumer", "ldvsurvey.jobs.worker.huey", "-w", "1", "-k", "thread"],
            env={**self.env, "LDVSURVEY_WORKER": "1", **env},
            stdout=log,
            stderr=subprocess.STDOUT,
            start_new_session=True,
        )
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
