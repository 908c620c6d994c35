"""Servers the tests start as separate processes."""

import socket
import time

import httpx


def free_port() -> int:
    """A TCP port on loopback that is free now."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def wait_healthy(base: str, tries: int = 120, pause_s: float = 0.5, proc=None) -> bool:
    """Poll ``<base>/api/health`` until it answers 200; False after ``tries`` polls or when ``proc`` exits."""
    for _ in range(tries):
        try:
            if httpx.get(base + "/api/health", timeout=1).status_code == 200:
                return True
        except httpx.HTTPError:
            pass
        if proc is not None and proc.poll() is not None:
            return False
        time.sleep(pause_s)
    return False
