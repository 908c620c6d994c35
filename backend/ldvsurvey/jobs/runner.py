"""Running a job: status, stage, progress and heartbeat in the ``jobs`` table; results written once.

A :class:`JobRunner` binds the task to one database and one huey queue; the API keeps its runner in
``app.state.runner``, a separate worker process builds one in :mod:`ldvsurvey.jobs.worker`. Nothing
here is module state: two apps in one process (tests) each have their own runner.
"""

from __future__ import annotations

import datetime as dt
import threading
import time
import traceback

from sqlalchemy import delete, select, update
from sqlalchemy.exc import IntegrityError

from ldvsurvey.errors import InputError
from ldvsurvey.jobs.queue import make_huey
from ldvsurvey.pipelines.base import Cancelled, LogFacts, Progress, result_files, run_pipeline
from ldvsurvey.pipelines.stages.grid_cache import GRID_CACHE
from ldvsurvey.store.db import session_scope
from ldvsurvey.store.models import Job, JobFile

TASK_NAME = "ldvsurvey.run_job"


def log_facts(row) -> LogFacts:
    """What the applicability checks know of a stored log (a ``Log`` row): its manifest and the facts
    found when it was stored (no samples read; a row stored before the facts were kept gets them
    from its stored arrays once, in its session)."""
    from sqlalchemy.orm import object_session

    from ldvsurvey.store.logs import facts_of

    session = object_session(row)
    facts = row.facts if session is None else facts_of(session, row)
    return LogFacts.of_manifest(row.manifest, row.t_start_s, row.t_end_s, row.has_gnss, facts)


def now() -> dt.datetime:
    return dt.datetime.now(dt.UTC)


class LazyGridCache:
    """The database's DOV grid cache (:class:`~ldvsurvey.store.gridcache.DbGridCache`), imported on first use.

    Every job offers the pipeline this cache; most pipelines never ask it for a grid, and importing the
    store's cache imports the grid code (:mod:`ldvsurvey.nav.dovgrid`) a navigate or gravity job does not need.
    """

    def __init__(self, database_url: str):
        self.database_url = database_url
        self._cache = None

    def _db(self):
        if self._cache is None:
            from ldvsurvey.store.gridcache import DbGridCache

            self._cache = DbGridCache(self.database_url)
        return self._cache

    def get(self, key: str):
        """The grid stored under ``key`` (a :class:`~ldvsurvey.nav.dovgrid.DovGrid`), or None."""
        return self._db().get(key)

    def put(self, key: str, grid) -> None:
        """Store ``grid`` under ``key``."""
        self._db().put(key, grid)


class JobRunner:
    """The job task bound to one database and one huey queue (from a :class:`~ldvsurvey.settings.Settings`)."""

    def __init__(self, database_url: str, settings):
        self.database_url = database_url
        self.heartbeat_s = settings.heartbeat_s  #: running jobs refresh their heartbeat this often
        self.stale_s = settings.stale_s  #: a running job without heartbeat for this long is re-queued
        self.huey = make_huey(settings)
        self._task = self.huey.task(retries=0, name=TASK_NAME)(self.execute)

    def _set(self, job_id: int, **values) -> None:
        with session_scope(self.database_url) as s:
            s.execute(update(Job).where(Job.id == job_id).values(**values))

    def execute(self, job_id: int) -> str:
        """Run one job to its end (called by the huey task). Returns the final status."""
        url, _set = self.database_url, self._set
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
            stage_log.append(
                {"attempt": attempt, "t_s": round(time.monotonic() - t0, 3), "stage": stage[:200], "progress": progress}
            )
            return list(stage_log)

        stop = threading.Event()

        def beat():
            while not stop.wait(self.heartbeat_s):
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
            from ldvsurvey.pipelines.warmup import WAITING_STAGE, wait_for_warmup
            from ldvsurvey.store.logs import load_drivelog

            # the first jobs after a fresh install wait for the compile the server started in the
            # background (it listens meanwhile), saying so in their stage
            wait_for_warmup(lambda: report(WAITING_STAGE, 0.0), cancelled)
            pipe = get(pipeline_name)
            check_applicable(url, pipe, log_ids, params)  # the logs may have changed since the submit
            with session_scope(url) as s:
                logs = [load_drivelog(s, i) for i in log_ids]
            if any(lg is None for lg in logs):
                raise InputError("a log of this job was deleted", field="log_ids")
            # every pipeline may use DOV grids (the EGM2008 cache, the uploaded grids): the store's cache,
            # imported only when a pipeline asks it for a grid
            token = GRID_CACHE.set(LazyGridCache(url))
            try:
                result = run_pipeline(pipe, logs, params, Progress(report, cancelled))
            finally:
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
                    s.execute(
                        update(Job)
                        .where(Job.id == job_id)
                        .values(
                            status="succeeded",
                            stage="done",
                            progress=100.0,
                            finished_at=now(),
                            summary=result.summary,
                            stage_log=list(stage_log) if current[0] == "done" else log_stage("done", 100.0),
                        )
                    )
            except IntegrityError:  # the job (its log) was deleted while the results were being written
                raise Cancelled() from None
            return "succeeded"
        except Cancelled:
            _set(
                job_id, status="cancelled", stage="cancelled", finished_at=now(), stage_log=log_stage("cancelled", 0.0)
            )
            return "cancelled"
        except InputError as exc:
            _set(
                job_id,
                status="failed",
                stage="failed",
                finished_at=now(),
                error=str(exc),
                stage_log=log_stage(f"failed: {exc}", 0.0),
            )
            return "failed"
        except Exception as exc:  # keep the worker alive; the user sees what happened and what to do
            traceback.print_exc()
            msg = user_message(pipeline_name, current[0], exc)
            _set(
                job_id,
                status="failed",
                stage="failed",
                finished_at=now(),
                error=msg,
                stage_log=log_stage(f"failed: {type(exc).__name__}", 0.0),
            )
            return "failed"
        finally:
            stop.set()
            # the job's arrays and result bytes are garbage now: give them back, so that the worker's
            # next job does not start from this one's high-water mark (a second 8-h job peaked
            # 0.12 GB above the first)
            from ldvsurvey.pipelines.base import release_free_memory

            release_free_memory()

    def enqueue(self, job_id: int) -> None:
        """Hand a job to the queue (its row in ``jobs`` is already there)."""
        self._task(job_id)

    def reap(self, stale_s: float | None = None) -> list[int]:
        """Re-queue running jobs whose heartbeat is older than ``stale_s`` (their worker died)."""
        limit = now() - dt.timedelta(seconds=self.stale_s if stale_s is None else stale_s)
        with session_scope(self.database_url) as s:
            ids = list(s.scalars(select(Job.id).where(Job.status == "running", Job.heartbeat_at < limit)))
            for i in ids:
                s.execute(
                    update(Job)
                    .where(Job.id == i, Job.status == "running")
                    .values(status="queued", stage="re-queued after a lost worker")
                )
        for i in ids:
            self.enqueue(i)
        return ids


def check_applicable(database_url: str, pipe, log_ids: list[int], params: dict) -> dict:
    """The submit-time check again, in the worker: :meth:`Pipeline.check` on the stored logs' facts.
    Raises the same :class:`~ldvsurvey.errors.ParameterError` the submit would (the job fails with it)."""
    from ldvsurvey.store.models import Log

    with session_scope(database_url) as s:
        rows = [s.get(Log, i) for i in log_ids]
        if any(r is None for r in rows):
            raise InputError("a log of this job was deleted", field="log_ids")
        facts = [log_facts(r) for r in rows]
    return pipe.check(facts, params)


def user_message(pipeline: str, stage: str, exc: Exception) -> str:
    """What a user reads when a pipeline stops on something other than bad input."""
    detail = f"{type(exc).__name__}: {exc}"[:300]
    if isinstance(exc, MemoryError):
        what = "ran out of memory"
        todo = "Run it on a shorter log (split the drive) or ask the operator for a larger worker."
    else:
        what = "stopped on a case it does not handle"
        todo = (
            "Check the log's quality report (gaps, GNSS fixes, LDV quality) and the parameters, then retry; "
            "if it fails again, report this job with its log."
        )
    return f"The {pipeline} pipeline {what} during '{stage}'. {todo} (technical detail: {detail})"


class Consumer:
    """The periodic reaper and, unless workers run as separate processes, the huey consumer."""

    def __init__(
        self,
        runner: JobRunner,
        workers: int = 2,
        reap_every_s: float = 30.0,
        consume: bool = True,
        housekeeping=None,
        housekeeping_every_s: float = 600.0,
    ):
        self.runner = runner
        self.consumer = (
            runner.huey.create_consumer(workers=workers, worker_type="thread", periodic=False, check_worker_health=True)
            if consume
            else None
        )
        self.reap_every_s = reap_every_s
        #: called every ``housekeeping_every_s`` from the reaper's thread (the server's clean-up of
        #: what stopped uploads left, :func:`ldvsurvey.store.leftovers.clean_leftovers`)
        self.housekeeping = housekeeping
        self.housekeeping_every_s = housekeeping_every_s
        self._stop = threading.Event()
        self._reaper = threading.Thread(target=self._reap_loop, daemon=True)

    def _reap_loop(self):
        last = time.monotonic()
        while not self._stop.wait(min(self.reap_every_s, self.housekeeping_every_s)):
            try:
                self.runner.reap()
            except Exception:
                traceback.print_exc()
            if self.housekeeping is not None and time.monotonic() - last >= self.housekeeping_every_s:
                last = time.monotonic()
                try:
                    self.housekeeping()
                except Exception:
                    traceback.print_exc()

    def start(self):
        self.runner.reap()
        if self.consumer is not None:
            # inside the server the web server owns the signals (and we may not be on the main thread)
            self.consumer._set_signal_handlers = lambda: None
            self.consumer.start()
        self._reaper.start()

    def stop(self):
        self._stop.set()
        if self.consumer is not None:
            self.consumer.stop(graceful=True)
