"""Warm the compiled-code cache: run every registered pipeline once on a tiny simulated log.

``ldv-survey warmup`` (called by ``scripts/setup.sh``) and the huey worker at start call
:func:`warmup`. Each pipeline of :data:`ldvsurvey.pipelines.registry.PIPELINES` is run on each
of :data:`CANDIDATES` it accepts (a log it refuses with an input or parameter error is skipped),
and on the first of them once more for every non-default choice of its choice parameters
(e.g. ``aiding=gnss``), so the compiled code paths a job can reach are compiled and
written to numba's on-disk cache (see :mod:`ldvsurvey.compilecache`). A new pipeline needs no
change here unless no candidate log suits it.

The logs are short (a few minutes at 100 Hz) and the run's results are discarded.
"""

from __future__ import annotations

import hashlib
import sys
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path

from ldvsurvey.errors import InputError

#: tiny simulated logs, tried in this order: (scenario name, scenario keyword arguments)
CANDIDATES: tuple[tuple[str, dict], ...] = (
    ("height", dict(minutes=8.0, length_m=1500.0)),  # static 300 s: a full turntable cycle for tilt
    ("gravity", dict(n_lines=2, line_km=1.0)),
    ("drive", dict(minutes=3.0, static_s=60.0)),
    ("vessel", dict(hours=0.02)),
    ("dov", dict(km=2.0, degree=360, step_arcmin=2.5)),
)

#: parameters that only fit a full-size survey, relaxed on the tiny logs (they select no other compiled
#: code): gravity trims half its 150-s FIR from each end of a line, more than a 1-km line lasts
TINY_LOG_PARAMS: dict[str, dict] = {"gravity": {"line_end_trim_s": 0.0}}


@dataclass
class WarmupRun:
    """One pipeline run of the warm-up."""

    pipeline: str
    scenario: str | None
    parameters: dict
    ok: bool
    elapsed_s: float
    error: str = ""


@dataclass
class WarmupReport:
    """What the warm-up ran and what numba compiled (cache misses) or loaded (cache hits)."""

    runs: list[WarmupRun] = field(default_factory=list)
    compiled: int = 0  #: signatures compiled in this process (not found in the cache)
    cache_hits: int = 0  #: signatures loaded from the on-disk cache
    not_cached: list[str] = field(default_factory=list)  #: compiled functions without cache=True
    cache_dir: str = ""
    elapsed_s: float = 0.0

    @property
    def covered(self) -> set[str]:
        """The pipelines that ran at least once without error."""
        return {r.pipeline for r in self.runs if r.ok}

    def as_dict(self) -> dict:
        """The report as JSON-ready values (elapsed times in s)."""
        return {
            "cache_dir": self.cache_dir,
            "compiled": self.compiled,
            "cache_hits": self.cache_hits,
            "not_cached": self.not_cached,
            "elapsed_s": round(self.elapsed_s, 2),
            "runs": [r.__dict__ for r in self.runs],
        }


def dispatchers() -> list:
    """Every numba dispatcher defined in a loaded ``ldvsurvey`` module."""
    from numba.core.registry import CPUDispatcher

    seen, out = set(), []
    for name, mod in list(sys.modules.items()):
        if not name.startswith("ldvsurvey") or mod is None:
            continue
        for obj in list(vars(mod).values()):
            if isinstance(obj, CPUDispatcher) and id(obj) not in seen:
                seen.add(id(obj))
                out.append(obj)
    return out


def compile_stats() -> tuple[int, int, list[str]]:
    """(signatures compiled, signatures loaded from cache, names compiled without cache=True)."""
    compiled = hits = 0
    uncached = []
    for d in dispatchers():
        st = d.stats
        compiled += sum(st.cache_misses.values())
        hits += sum(st.cache_hits.values())
        if d.signatures and not d._cache.__class__.__name__.endswith("FunctionCache"):
            uncached.append(f"{d.py_func.__module__}.{d.py_func.__qualname__}")
    return compiled, hits, sorted(uncached)


STAMP = "ldvsurvey-warmup.stamp"


def fingerprint() -> str:
    """Identity of the installed code: Python and numba versions and every ``ldvsurvey`` source file's
    size and modification time (numba's own cache is invalidated by the same things)."""
    import numba

    import ldvsurvey

    h = hashlib.sha256(f"{sys.version}|{numba.__version__}".encode())
    root = Path(ldvsurvey.__file__).parent
    for f in sorted(root.rglob("*.py")):
        st = f.stat()
        h.update(f"{f.relative_to(root)}|{st.st_size}|{st.st_mtime_ns}\n".encode())
    return h.hexdigest()


def is_warm() -> bool:
    """True when a complete warm-up of this very code has filled the cache in use."""
    from ldvsurvey.compilecache import cache_dir

    stamp = cache_dir() / STAMP
    try:
        return stamp.read_text().strip() == fingerprint()
    except OSError:
        return False


_background: threading.Thread | None = None
_background_lock = threading.Lock()


def start_background_warmup(log=None) -> threading.Thread | None:
    """Warm the cache in a daemon thread unless :func:`is_warm` (the worker and the API's in-process
    consumer call this at start). At most one such thread runs per process, however many apps start.

    ``LDVSURVEY_BACKGROUND_WARMUP=0`` turns it off (the test suite: its many short-lived servers would
    each start compiling, and a warm-up that completes prunes the compiled code of other versions from
    a cache folder that other checkouts may share).

    Returns the thread, or None when the cache is already warm (or the warm-up is turned off).
    """
    import os

    global _background
    if os.environ.get("LDVSURVEY_BACKGROUND_WARMUP", "1").strip() == "0":
        return None
    with _background_lock:
        if _background is not None and _background.is_alive():
            return _background
        if is_warm():
            return None

        def run():
            t0 = time.perf_counter()
            warmup(log=log)
            if log:
                log(f"done in {time.perf_counter() - t0:.0f} s; jobs run now")

        _background = threading.Thread(target=run, name="ldvsurvey-warmup", daemon=True)
        _background.start()
        return _background


#: the stage a job shows while it waits for the background warm-up (the job page shows stages)
WAITING_STAGE = (
    "waiting for the numerical core to compile (first start after installing or upgrading, about "
    "2 minutes on 2 cores); the job starts by itself when it is done"
)


def wait_for_warmup(on_wait=None, cancelled=None, poll_s: float = 0.5) -> float:
    """Block a job until this process's background warm-up (:func:`start_background_warmup`) ends,
    so that the first jobs do not compile the same code beside it (each on the same cores, slower
    for both); ``on_wait()`` is called once when there is something to wait for, and ``cancelled()``
    is polled (a true answer raises :class:`~ldvsurvey.pipelines.base.Cancelled`).

    Returns
    -------
    float
        Seconds waited (0 when no warm-up runs).
    """
    th = _background
    if th is None or not th.is_alive() or th is threading.current_thread():
        return 0.0
    from ldvsurvey.pipelines.base import Cancelled

    t0 = time.monotonic()
    if on_wait is not None:
        on_wait()
    while th.is_alive():
        th.join(poll_s)
        if cancelled is not None and th.is_alive() and cancelled():
            raise Cancelled()
    return time.monotonic() - t0


#: libraries the pipelines import only inside the functions that use them (so that a CLI run pays only
#: for what it uses); a worker imports them at start instead of in its first job
RUN_TIME_IMPORTS = (
    "scipy.ndimage",
    "scipy.signal",
    "scipy.interpolate",
    "scipy.spatial",
    "pyarrow.compute",
    "ldvsurvey.nav.egm",
    "ldvsurvey.io.leapseconds",  # the GPS week and seconds of week beside t_s in every table
)


def preload(log=None) -> float:
    """Import every registered pipeline's module and :data:`RUN_TIME_IMPORTS`, so that the first job
    of a worker whose numba cache is already warm pays no imports (about 1–1.6 s of CPU otherwise).

    Returns
    -------
    float
        Seconds taken.
    """
    import importlib

    from ldvsurvey.pipelines.registry import PIPELINES

    t0 = time.perf_counter()
    for name in PIPELINES:
        PIPELINES[name]  # noqa: B018  (the lookup imports the module)
    for mod in RUN_TIME_IMPORTS:
        importlib.import_module(mod)
    elapsed = time.perf_counter() - t0
    if log:
        log(f"pipelines and their libraries imported in {elapsed:.1f} s")
    return elapsed


def ready_for_jobs(log=None, wait: bool = False) -> threading.Thread | None:
    """Get a process that runs jobs (a worker, the API's in-process consumer) ready for its first job:
    warm numba's cache in a background thread when it is not warm for this code
    (:func:`start_background_warmup`), else import the pipelines and their libraries (:func:`preload`),
    now when ``wait``, else in a daemon thread (a job arriving meanwhile waits only for the module it
    needs: Python's import locks are per module).

    Returns
    -------
    threading.Thread or None
        The warm-up's thread, or the preload's when it runs in the background; None when done.
    """
    th = start_background_warmup(log=log)
    if th is not None:
        return th
    if wait:
        preload(log=log)
        return None
    th = threading.Thread(target=preload, kwargs={"log": log}, name="ldvsurvey-preload", daemon=True)
    th.start()
    return th


def _variants(pipe) -> list[dict]:
    """The default parameters, then each non-default choice of every choice parameter."""
    out = [{}]
    for p in pipe.params:
        if p.choices:
            out += [{p.name: c} for c in p.choices if c != p.default]
    return out


def warmup(names: list[str] | None = None, variants: bool = True, log=None) -> WarmupReport:
    """Run the pipelines ``names`` (default: all registered) on tiny simulated logs.

    Parameters
    ----------
    names : list of str, optional
        Pipelines to warm (default: every pipeline of the registry).
    variants : bool
        Also run each non-default choice of the choice parameters.
    log : callable, optional
        Called with one line of progress text per run.

    Returns
    -------
    WarmupReport
        Runs, and the numba signatures compiled and loaded from the cache in this process.
    """
    from ldvsurvey.compilecache import cache_dir
    from ldvsurvey.io.drivelog import parse_files
    from ldvsurvey.pipelines.base import Progress, run_pipeline
    from ldvsurvey.pipelines.registry import PIPELINES
    from ldvsurvey.sim import catalog
    from ldvsurvey.sim.scenario import bundle_files, simulate

    t_start = time.perf_counter()
    log = log or (lambda s: None)
    report = WarmupReport(cache_dir=str(cache_dir()))
    bundles: dict[str, list] = {}

    def logs_of(scenario: str, kw: dict) -> list:
        if scenario not in bundles:
            bundles[scenario] = [parse_files(bundle_files(simulate(catalog.by_name(scenario, **kw), seed=1)))]
        return bundles[scenario]

    for name in names or list(PIPELINES):
        pipe = PIPELINES[name]
        base = TINY_LOG_PARAMS.get(name, {})
        accepted, errors = [], []
        for scenario, kw in CANDIDATES:  # every log it accepts: 1-D, 2-D and water LDV, fixed and rotating IMU
            t0 = time.perf_counter()
            try:
                run_pipeline(pipe, logs_of(scenario, kw), dict(base), Progress())
            except InputError as exc:  # this log does not suit the pipeline
                errors.append(f"{scenario}: {exc}")
                continue
            accepted.append(scenario)
            report.runs.append(WarmupRun(name, scenario, {}, True, time.perf_counter() - t0))
            log(f"{name} on a tiny '{scenario}' log: {time.perf_counter() - t0:.1f} s")
        if not accepted:
            report.runs.append(WarmupRun(name, None, {}, False, 0.0, "; ".join(errors)))
            log(f"{name}: no tiny log suits it ({'; '.join(errors)})")
            continue
        for params in _variants(pipe)[1:] if variants else []:
            t0 = time.perf_counter()
            try:
                run_pipeline(pipe, bundles[accepted[0]], {**base, **params}, Progress())
                ok, err = True, ""
            except InputError as exc:  # e.g. aiding=gnss on a log without GNSS: nothing to compile
                ok, err = False, str(exc)
            report.runs.append(WarmupRun(name, accepted[0], params, ok, time.perf_counter() - t0, err))
            log(f"{name} {params}: {'%.1f s' % (time.perf_counter() - t0) if ok else 'skipped: ' + err}")
    report.compiled, report.cache_hits, report.not_cached = compile_stats()
    report.elapsed_s = time.perf_counter() - t_start
    if names is None and all(r.ok for r in report.runs if not r.parameters):
        try:  # every pipeline warmed: later starts need not do it again
            (Path(report.cache_dir) / STAMP).write_text(fingerprint() + "\n")
        except OSError:
            pass
        _prune_other_cores(Path(report.cache_dir), log)
    return report


def _prune_other_cores(current: Path, log) -> None:
    """Remove the cache folders of other versions of the compiled core beside ``current`` (``core-*``,
    and the ``nav_*`` folders numba wrote directly into the cache place before the folders had a key):
    after an upgrade they are never read again. Only a complete warm-up prunes."""
    import shutil

    for old in current.parent.iterdir():
        if old != current and old.is_dir() and (old.name.startswith("core-") or old.name.startswith("nav_")):
            shutil.rmtree(old, ignore_errors=True)
            log(f"removed the compiled code of another version: {old}")
