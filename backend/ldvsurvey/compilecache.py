"""Where numba keeps its compiled machine code, so the numerical core is compiled once per installation.

Every ``@nb.njit(cache=True)`` function of :mod:`ldvsurvey.nav` is written to numba's on-disk cache
the first time it is compiled and loaded from there by every later process. The cache place must
be writable and must be chosen *before* numba is imported, which is why :mod:`ldvsurvey` calls
:func:`configure` when the package is first imported (the CLI, the API server and the huey worker
all import it first).

The place is, in this order:

1. ``LDVSURVEY_NUMBA_CACHE_DIR`` (the setting ``numba_cache_dir``);
2. ``NUMBA_CACHE_DIR`` when the environment already sets it;
3. ``<venv>/var/cache/ldvsurvey-numba`` when running in a virtual environment that is writable
   (``scripts/setup.sh`` warms it there, and a Docker image built with it ships it warm);
4. ``<LDVSURVEY_DATA_DIR or ./data>/numba-cache``.

This module imports nothing heavy (no numba, no pydantic): it runs on every start.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

ENV = "LDVSURVEY_NUMBA_CACHE_DIR"


def _writable(p: Path) -> bool:
    try:
        p.mkdir(parents=True, exist_ok=True)
    except OSError:
        return False
    return os.access(p, os.W_OK | os.X_OK)


def default_cache_dir() -> Path:
    """The cache place used when neither ``LDVSURVEY_NUMBA_CACHE_DIR`` nor ``NUMBA_CACHE_DIR`` is set."""
    if sys.prefix != sys.base_prefix:  # a virtual environment: the cache lives and dies with it
        venv = Path(sys.prefix) / "var" / "cache" / "ldvsurvey-numba"
        if _writable(venv):
            return venv
    return Path(os.environ.get("LDVSURVEY_DATA_DIR") or "data").resolve() / "numba-cache"


def cache_dir() -> Path:
    """The cache place this process uses (see the module docstring for the order)."""
    if os.environ.get(ENV):
        return Path(os.environ[ENV]).expanduser().resolve()
    if os.environ.get("NUMBA_CACHE_DIR"):
        return Path(os.environ["NUMBA_CACHE_DIR"]).expanduser().resolve()
    return default_cache_dir()


def configure() -> Path:
    """Point numba's cache at :func:`cache_dir` (sets ``NUMBA_CACHE_DIR``); returns the place.

    Idempotent. If numba is already imported its configuration is updated too, which still
    takes effect as long as no ``cache=True`` function has been defined yet.
    """
    place = cache_dir()
    os.environ["NUMBA_CACHE_DIR"] = str(place)
    nb_config = sys.modules.get("numba.core.config")
    if nb_config is not None:
        nb_config.CACHE_DIR = str(place)
    return place
