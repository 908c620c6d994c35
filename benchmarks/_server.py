"""Start the app on a free loopback port for a benchmark and wait until it answers."""

import os
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import httpx


def start(args, env_extra: dict) -> tuple[subprocess.Popen, str, Path]:
    """``args``: the command after the Python executable, with ``{port}`` where the port goes."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    data = Path(tempfile.mkdtemp())
    env = {**os.environ, "LDVSURVEY_DATA_DIR": str(data), **env_extra}
    proc = subprocess.Popen(
        [sys.executable, *[a.format(port=port) for a in args]],
        env=env,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    base = f"http://127.0.0.1:{port}"
    for _ in range(150):
        try:
            if httpx.get(base + "/api/health").status_code == 200:
                break
        except httpx.HTTPError:
            time.sleep(0.2)
    return proc, base, data
