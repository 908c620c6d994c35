"""Running a job: status, stage, progress and heartbeat in the ``jobs`` table; results written once."""

from __future__ import annotations

import datetime as dt
import threading
import time
import traceback

from sqlalchemy import delete, select, update

from ldvsurvey.errors import InputError
from ldvsurvey.jobs.queue import make_huey
from ldvsurvey.pipelines.base import Cancelled, Progress, result_files, run_pipeline
from ldvsurvey.store.db import session_scope
from ldvsurvey.store.models import Job, JobFile

HEARTBEAT_S = 5.0
STALE_S = 60.0
_db_url: str | None = None
_huey = None
_task = None


def configure(database_url: str, settings) -> object:
    """Bind the task functions to a database and a huey queue (the server's or a worker's settings)."""
    global _db_url, _huey, _task, HEARTBEAT_S, STALE_S
    _db_url = database_url
    HEARTBEAT_S, STALE_S = settings.heartbeat_s, settings.stale_s
    _huey = make_huey(settings)
    _task = _huey.task(retries=0, name="ldvsurvey.run_job")(execute)
    return _huey


def _url() -> str:
    if _db_url is None:
        raise RuntimeError("jobs not configured: call ldvsurvey.jobs.runner.configure first")
    return _db_url


def now() -> dt.datetime:
    return dt.datetime.now(dt.timezone.utc)


def _set(job_id: int, **values) -> None:
    with session_scope(_url()) as s:
        s.execute(update(Job).where(Job.id == job_id).values(**values))


def execute(job_id: int) -> str:
    """Run one job to its end (called by the huey task). Returns the final status."""
    url = _url()
    with session_scope(url) as s:
        job = s.get(Job, job_id)
        if job is None or job.status in ("succeeded", "cancelled"):
            return job.status if job else "missing"  # idempotent: a re-delivered task does nothing
        if job.cancel_requested:
            job.status, job.finished_at, job.stage = "cancelled", now(), "cancelled"
            return "cancelled"
        job.status, job.started_at, job.heartbeat_at = "running", now(), now()
        job.attempts += 1
        job.error = None
        pipeline_name, log_ids, params = job.pipeline, list(job.log_ids), dict(job.parameters)
    stop = threading.Event()

    def beat():
        while not stop.wait(HEARTBEAT_S):
            try:
                _set(job_id, heartbeat_at=now())
            except Exception:  # a missed heartbeat is retried at the next beat
                pass

    hb = threading.Thread(target=beat, daemon=True)
    hb.start()
    last = [0.0]
    cancel_cache = [False, 0.0]

    def report(stage, fraction):
        t = time.monotonic()
        if t - last[0] > 0.5 or fraction >= 1.0:
            last[0] = t
            _set(job_id, stage=stage[:200], progress=round(100.0 * fraction, 1), heartbeat_at=now())

    def cancelled():
        t = time.monotonic()
        if t - cancel_cache[1] > 0.5:
            cancel_cache[1] = t
            with session_scope(url) as s:
                cancel_cache[0] = bool(s.scalar(select(Job.cancel_requested).where(Job.id == job_id)))
        return cancel_cache[0]

    try:
        from ldvsurvey.pipelines.registry import get
        from ldvsurvey.store.logs import load_drivelog

        pipe = get(pipeline_name)
        with session_scope(url) as s:
            logs = [load_drivelog(s, i) for i in log_ids]
        if any(lg is None for lg in logs):
            raise InputError("a log of this job was deleted", field="log_ids")
        token = None
        if True:  # every pipeline may use DOV grids: the EGM2008 cache and the uploaded grids
            from ldvsurvey.pipelines.dov import GRID_CACHE
            from ldvsurvey.store.gridcache import DbGridCache

            token = GRID_CACHE.set(DbGridCache(url))
        try:
            result = run_pipeline(pipe, logs, params, Progress(report, cancelled))
        finally:
            if token is not None:
                GRID_CACHE.reset(token)
        files = result_files(result)
        with session_scope(url) as s:  # results written once, in one transaction
            s.execute(delete(JobFile).where(JobFile.job_id == job_id))
            for name, data in files.items():
                s.add(JobFile(job_id=job_id, name=name, size_bytes=len(data), content=data))
            s.execute(update(Job).where(Job.id == job_id).values(
                status="succeeded", stage="done", progress=100.0, finished_at=now(), summary=result.summary))
        return "succeeded"
    except Cancelled:
        _set(job_id, status="cancelled", stage="cancelled", finished_at=now())
        return "cancelled"
    except InputError as exc:
        _set(job_id, status="failed", stage="failed", finished_at=now(), error=str(exc))
        return "failed"
    except Exception as exc:  # keep the worker alive; the user sees what happened
        traceback.print_exc()
        _set(job_id, status="failed", stage="failed", finished_at=now(),
             error=f"internal error: {type(exc).__name__}: {exc}")
        return "failed"
    finally:
        stop.set()


def enqueue(job_id: int) -> None:
    """Hand a job to the queue (its row in ``jobs`` is already there)."""
    _task(job_id)


def reap(stale_s: float | None = None) -> list[int]:
    """Re-queue running jobs whose heartbeat is older than ``stale_s`` (their worker died)."""
    limit = now() - dt.timedelta(seconds=STALE_S if stale_s is None else stale_s)
    with session_scope(_url()) as s:
        ids = list(s.scalars(select(Job.id).where(Job.status == "running", Job.heartbeat_at < limit)))
        for i in ids:
            s.execute(update(Job).where(Job.id == i, Job.status == "running").values(
                status="queued", stage="re-queued after a lost worker"))
    for i in ids:
        enqueue(i)
    return ids


class Consumer:
    """The periodic reaper and, unless workers run as separate processes, the huey consumer."""

    def __init__(self, workers: int = 2, reap_every_s: float = 30.0, consume: bool = True):
        self.consumer = _huey.create_consumer(workers=workers, worker_type="thread", periodic=False,
                                              check_worker_health=True) if consume else None
        self.reap_every_s = reap_every_s
        self._stop = threading.Event()
        self._reaper = threading.Thread(target=self._reap_loop, daemon=True)

    def _reap_loop(self):
        while not self._stop.wait(self.reap_every_s):
            try:
                reap()
            except Exception:
                traceback.print_exc()

    def start(self):
        reap()
        if self.consumer is not None:
            # inside the server the web server owns the signals (and we may not be on the main thread)
            self.consumer._set_signal_handlers = lambda: None
            self.consumer.start()
        self._reaper.start()

    def stop(self):
        self._stop.set()
        if self.consumer is not None:
            self.consumer.stop(graceful=True)
