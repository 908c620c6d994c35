"""Running a job: status, stage, progress and heartbeat in the ``jobs`` table; results written once."""

from __future__ import annotations

import datetime as dt
import threading
import time
import traceback

from sqlalchemy import delete, select, update
from sqlalchemy.exc import IntegrityError

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
        attempt = job.attempts
        stage_log = [e for e in (job.stage_log or []) if e.get("attempt", 0) < attempt]
        stage_log.append({"attempt": attempt, "t_s": 0.0, "stage": "started", "progress": 0.0})
        job.stage_log = list(stage_log)
        pipeline_name, log_ids, params = job.pipeline, list(job.log_ids), dict(job.parameters)
    t0 = time.monotonic()
    current = ["started"]

    def log_stage(stage: str, progress: float) -> list:
        current[0] = stage[:200]
        stage_log.append({"attempt": attempt, "t_s": round(time.monotonic() - t0, 3), "stage": stage[:200],
                          "progress": progress})
        return list(stage_log)
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
        pct = round(100.0 * fraction, 1)
        if stage[:200] != current[0]:  # every stage enters the job's stage log
            last[0] = t
            _set(job_id, stage=stage[:200], progress=pct, heartbeat_at=now(), stage_log=log_stage(stage, pct))
        elif t - last[0] > 0.5 or fraction >= 1.0:
            last[0] = t
            _set(job_id, stage=stage[:200], progress=pct, heartbeat_at=now())

    def cancelled():
        t = time.monotonic()
        if t - cancel_cache[1] > 0.5:
            cancel_cache[1] = t
            with session_scope(url) as s:
                flag = s.scalar(select(Job.cancel_requested).where(Job.id == job_id))
            cancel_cache[0] = flag is None or bool(flag)  # a deleted job (its log was deleted) stops too
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
        try:
            with session_scope(url) as s:  # results written once, in one transaction
                row = s.scalar(select(Job).where(Job.id == job_id).with_for_update())
                if row is None or row.cancel_requested:
                    raise Cancelled()
                s.execute(delete(JobFile).where(JobFile.job_id == job_id))
                for name, data in files.items():
                    s.add(JobFile(job_id=job_id, name=name, size_bytes=len(data), content=data))
                s.execute(update(Job).where(Job.id == job_id).values(
                    status="succeeded", stage="done", progress=100.0, finished_at=now(), summary=result.summary,
                    stage_log=list(stage_log) if current[0] == "done" else log_stage("done", 100.0)))
        except IntegrityError:  # the job (its log) was deleted while the results were being written
            raise Cancelled() from None
        return "succeeded"
    except Cancelled:
        _set(job_id, status="cancelled", stage="cancelled", finished_at=now(),
             stage_log=log_stage("cancelled", 0.0))
        return "cancelled"
    except InputError as exc:
        _set(job_id, status="failed", stage="failed", finished_at=now(), error=str(exc),
             stage_log=log_stage(f"failed: {exc}", 0.0))
        return "failed"
    except Exception as exc:  # keep the worker alive; the user sees what happened and what to do
        traceback.print_exc()
        msg = user_message(pipeline_name, current[0], exc)
        _set(job_id, status="failed", stage="failed", finished_at=now(), error=msg,
             stage_log=log_stage(f"failed: {type(exc).__name__}", 0.0))
        return "failed"
    finally:
        stop.set()


def user_message(pipeline: str, stage: str, exc: Exception) -> str:
    """What a user reads when a pipeline stops on something other than bad input."""
    detail = f"{type(exc).__name__}: {exc}"[:300]
    if isinstance(exc, MemoryError):
        what = "ran out of memory"
        todo = "Run it on a shorter log (split the drive) or ask the operator for a larger worker."
    else:
        what = "stopped on a case it does not handle"
        todo = ("Check the log's quality report (gaps, GNSS fixes, LDV quality) and the parameters, then retry; "
                "if it fails again, report this job with its log.")
    return f"The {pipeline} pipeline {what} during '{stage}'. {todo} (technical detail: {detail})"


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
