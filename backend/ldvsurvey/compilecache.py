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

Inside that place the code lives in a folder named after the compiled core's source
(``core-<12 hex digits>``, :func:`code_key`). numba invalidates a cached function only when *its
own* file changes, not when a function it inlines from another file does (``q_to_c_into`` of
``nav/attitude.py`` is compiled into ``nav/kfloop.py``'s filter loop, for one): without the key an
upgrade that changed only the inlined function would keep running the old machine code. A new
key starts from an empty folder, so every change of ``nav/`` or ``units.py`` is compiled afresh.

This module imports nothing heavy (no numba, no pydantic): it runs on every start.

:func:`preload_blas` spares a fresh process the import of the whole ``scipy.linalg`` package that
numba makes only to find the two modules its compiled BLAS and LAPACK calls bind to.
"""

from __future__ import annotations

import hashlib
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


def base_dir() -> Path:
    """The cache place chosen by the settings (see the module docstring for the order)."""
    if os.environ.get(ENV):
        return Path(os.environ[ENV]).expanduser().resolve()
    if os.environ.get("NUMBA_CACHE_DIR"):
        place = Path(os.environ["NUMBA_CACHE_DIR"]).expanduser().resolve()
        # configure() set it to a core folder in a parent process: its base is one level up
        return place.parent if place.name.startswith("core-") else place
    return default_cache_dir()


def core_sources() -> list[Path]:
    """The source files whose code numba compiles (``nav/*.py``) and the constants they import."""
    root = Path(__file__).resolve().parent
    return sorted((root / "nav").glob("*.py")) + [root / "units.py"]


def code_key() -> str:
    """12 hex digits of the SHA-256 of the compiled core's source files (names and contents)."""
    h = hashlib.sha256()
    for f in core_sources():
        h.update(f.name.encode() + b"\0" + f.read_bytes() + b"\0")
    return h.hexdigest()[:12]


def cache_dir() -> Path:
    """The folder this process's numba cache lives in: ``<base_dir()>/core-<code_key()>``."""
    return base_dir() / f"core-{code_key()}"


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


def preload_blas() -> bool:
    """Load scipy's ``linalg.cython_blas`` and ``linalg.cython_lapack`` without the ``scipy.linalg`` package.

    numba's CPU target checks for a BLAS when it starts (the first compiled function of a process,
    cached or not) with ``import scipy.linalg.cython_blas``, and its compiled BLAS/LAPACK calls
    import those two modules to find their function pointers. Importing them the usual way runs
    ``scipy/linalg/__init__.py`` first, which imports all of ``scipy.linalg`` (with ``numpy.f2py``,
    ``numpy.testing`` and ``unittest``): about 0.2 s of CPU in a process that calls no scipy.linalg
    function. Loaded from their files under their own names, they are the same extension modules
    (the same function pointers, so the same numbers); ``scipy.linalg`` itself is still imported
    the usual way by whatever asks for it later, and finds them loaded.

    Returns
    -------
    bool
        True when both are loaded (now or before); False when scipy or the files are not there or
        numba has already looked (nothing is changed then, and numba imports them its own way).
    """
    import importlib.machinery
    import importlib.util

    names = ("scipy.linalg.cython_blas", "scipy.linalg.cython_lapack")
    if all(n in sys.modules for n in names):
        return True
    if "scipy.linalg" in sys.modules or "numba.np.linalg" in sys.modules:
        return False
    try:
        import scipy
    except ImportError:
        return False
    folder = Path(scipy.__file__).resolve().parent / "linalg"
    for name in names:
        if name in sys.modules:
            continue
        stem = name.rsplit(".", 1)[1]
        files = [folder / (stem + s) for s in importlib.machinery.EXTENSION_SUFFIXES]
        found = [f for f in files if f.is_file()]
        if not found:
            return False
        spec = importlib.util.spec_from_file_location(name, found[0])
        if spec is None or spec.loader is None:
            return False
        try:
            module = importlib.util.module_from_spec(spec)
            sys.modules[name] = module
            spec.loader.exec_module(module)
        except Exception:  # noqa: BLE001 - anything unexpected: leave it to numba's own import
            sys.modules.pop(name, None)
            return False
    return True
