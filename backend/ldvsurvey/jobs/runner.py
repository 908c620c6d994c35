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
from ldvsurvey.pipelines.base import (
    Cancelled,
    LogFacts,
    Params,
    Progress,
    release_free_memory,
    result_files,
    run_pipeline,
)
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
    """The current time, timezone-aware in UTC."""
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
        """Run one job to its end (called by the huey task).

        The stages: claim the job (a job already finished or cancelled is left as it is), check that
        its pipeline applies to its logs as they are now, load the logs, run the pipeline, store its
        results in one transaction; a cancel, bad input or any other exception ends the job as
        cancelled or failed, with a message for the user.

        Parameters
        ----------
        job_id : int
            The job's row in ``jobs``.

        Returns
        -------
        str
            The job's final status: ``succeeded``, ``failed``, ``cancelled``, or ``missing`` when
            there is no such job.
        """
        job = self._claim(job_id)
        if isinstance(job, str):
            return job
        job.start_heartbeat()
        try:
            pipe = self._check(job)
            logs = self._load_logs(job)
            result = self._run(job, pipe, logs)
            self._store_results(job, result)
            return "succeeded"
        except Cancelled:
            return self._end(job, "cancelled", stage_log=job.log_stage("cancelled", 0.0))
        except InputError as exc:
            return self._end(job, "failed", error=str(exc), stage_log=job.log_stage(f"failed: {exc}", 0.0))
        except Exception as exc:  # keep the worker alive; the user sees what happened and what to do
            traceback.print_exc()
            msg = user_message(job.pipeline, job.current, exc)
            return self._end(job, "failed", error=msg, stage_log=job.log_stage(f"failed: {type(exc).__name__}", 0.0))
        finally:
            job.stop_heartbeat()
            # the job's arrays and result bytes are garbage now: give them back, so that the worker's
            # next job does not start from this one's high-water mark (a second 8-h job peaked
            # 0.12 GB above the first)
            release_free_memory()

    def _claim(self, job_id: int) -> _Attempt | str:
        """Start a new attempt at the job (status running, attempts + 1), or the status to return when
        there is nothing to run: ``missing``, already ``succeeded`` or ``cancelled`` (a re-delivered
        task does nothing), or ``cancelled`` now when a cancel was asked before it started."""
        with session_scope(self.database_url) as s:
            job = s.get(Job, job_id)
            if job is None or job.status in ("succeeded", "cancelled"):
                return job.status if job else "missing"
            if job.cancel_requested:
                job.status, job.finished_at, job.stage = "cancelled", now(), "cancelled"
                return "cancelled"
            job.status, job.started_at, job.heartbeat_at = "running", now(), now()
            job.attempts += 1
            job.error = None
            attempt = _Attempt(self, job_id, job)
            job.stage_log = list(attempt.stage_log)
        return attempt

    def _check(self, job: _Attempt):
        """The job's pipeline, once the compiled core is warm and the pipeline still applies to its logs."""
        from ldvsurvey.pipelines.registry import get
        from ldvsurvey.pipelines.warmup import WAITING_STAGE, wait_for_warmup

        # the first jobs after a fresh install wait for the compile the server started in the
        # background (it listens meanwhile), saying so in their stage
        wait_for_warmup(lambda: job.report(WAITING_STAGE, 0.0), job.cancelled)
        pipe = get(job.pipeline)
        # the logs may have changed since the submit; the run takes the model validated here
        job.params = check_applicable(self.database_url, pipe, job.log_ids, job.params)
        return pipe

    def _load_logs(self, job: _Attempt) -> list:
        """The job's drive logs from the store; an :class:`InputError` when one was deleted."""
        from ldvsurvey.store.logs import load_drivelog

        with session_scope(self.database_url) as s:
            logs = [load_drivelog(s, i) for i in job.log_ids]
        if any(lg is None for lg in logs):
            raise InputError("a log of this job was deleted", field="log_ids")
        return logs

    def _run(self, job: _Attempt, pipe, logs: list):
        """Run the pipeline on the logs with the job's progress and cancel callbacks."""
        # every pipeline may use DOV grids (the EGM2008 cache, the uploaded grids): the store's cache,
        # imported only when a pipeline asks it for a grid
        token = GRID_CACHE.set(LazyGridCache(self.database_url))
        try:
            return run_pipeline(pipe, logs, job.params, Progress(job.report, job.cancelled))
        finally:
            GRID_CACHE.reset(token)

    def _store_results(self, job: _Attempt, result) -> None:
        """Write the result's files and summary and mark the job succeeded, in one transaction;
        :class:`Cancelled` when the job was cancelled or deleted meanwhile (nothing written)."""
        files = result_files(result)
        job_id = job.job_id
        try:
            with session_scope(self.database_url) as s:
                row = s.scalar(select(Job).where(Job.id == job_id).with_for_update())
                if row is None or row.cancel_requested:
                    raise Cancelled()
                s.execute(delete(JobFile).where(JobFile.job_id == job_id))
                for name, data in files.items():
                    s.add(JobFile(job_id=job_id, name=name, size_bytes=len(data), content=data))
                stage_log = list(job.stage_log) if job.current == "done" else job.log_stage("done", 100.0)
                done = dict(status="succeeded", stage="done", progress=100.0, finished_at=now())
                s.execute(
                    update(Job).where(Job.id == job_id).values(**done, summary=result.summary, stage_log=stage_log)
                )
        except IntegrityError:  # the job (its log) was deleted while the results were being written
            raise Cancelled() from None

    def _end(self, job: _Attempt, status: str, **values) -> str:
        """End the job as ``status`` (``cancelled`` or ``failed``, also its stage) with ``values``; returns it."""
        self._set(job.job_id, status=status, stage=status, finished_at=now(), **values)
        return status

    def enqueue(self, job_id: int) -> None:
        """Hand a job to the queue (its row in ``jobs`` is already there)."""
        self._task(job_id)

    def reap(self, *, stale_s: float | None = None) -> list[int]:
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


class _Attempt:
    """One attempt at a job: what it runs, its stage log, and the progress, cancel and heartbeat
    callbacks the pipeline and the worker use while it runs."""

    def __init__(self, runner: JobRunner, job_id: int, job: Job):
        self.runner, self.job_id = runner, job_id
        self.attempt = job.attempts
        #: the stage log of the earlier attempts, then this one's entries (``t_s`` from its start, s)
        self.stage_log = [e for e in (job.stage_log or []) if e.get("attempt", 0) < self.attempt]
        self.stage_log.append({"attempt": self.attempt, "t_s": 0.0, "stage": "started", "progress": 0.0})
        self.pipeline, self.log_ids, self.params = job.pipeline, list(job.log_ids), dict(job.parameters)
        self.current = "started"  #: the stage the job is in (at most 200 characters)
        self.t0_s = time.monotonic()
        self._last_report_s = 0.0
        self._cancel_flag, self._cancel_checked_s = False, 0.0
        self._stop = threading.Event()

    def log_stage(self, stage: str, progress: float) -> list:
        """Enter ``stage`` (progress in %) in the stage log; returns a copy of the log to store."""
        self.current = stage[:200]
        t_s = round(time.monotonic() - self.t0_s, 3)
        self.stage_log.append({"attempt": self.attempt, "t_s": t_s, "stage": stage[:200], "progress": progress})
        return list(self.stage_log)

    def report(self, stage: str, fraction: float) -> None:
        """The pipeline's progress report (``fraction`` of the job done, 0 to 1): a new stage enters the
        stage log at once, the same stage's progress is written at most every 0.5 s."""
        t = time.monotonic()
        pct = round(100.0 * fraction, 1)
        set_job = self.runner._set
        if stage[:200] != self.current:
            self._last_report_s = t
            set_job(
                self.job_id, stage=stage[:200], progress=pct, heartbeat_at=now(), stage_log=self.log_stage(stage, pct)
            )
        elif t - self._last_report_s > 0.5 or fraction >= 1.0:
            self._last_report_s = t
            set_job(self.job_id, stage=stage[:200], progress=pct, heartbeat_at=now())

    def cancelled(self) -> bool:
        """Whether the job was cancelled or deleted (the database is asked at most every 0.5 s)."""
        t = time.monotonic()
        if t - self._cancel_checked_s > 0.5:
            self._cancel_checked_s = t
            with session_scope(self.runner.database_url) as s:
                flag = s.scalar(select(Job.cancel_requested).where(Job.id == self.job_id))
            self._cancel_flag = flag is None or bool(flag)  # a deleted job (its log was deleted) stops too
        return self._cancel_flag

    def _beat(self) -> None:
        while not self._stop.wait(self.runner.heartbeat_s):
            try:
                self.runner._set(self.job_id, heartbeat_at=now())
            except Exception:  # a missed heartbeat is retried at the next beat
                pass

    def start_heartbeat(self) -> None:
        """Refresh the job's heartbeat every ``heartbeat_s`` from a daemon thread until :meth:`stop_heartbeat`."""
        threading.Thread(target=self._beat, daemon=True).start()

    def stop_heartbeat(self) -> None:
        """End the heartbeat thread (at its next wake-up)."""
        self._stop.set()


def check_applicable(database_url: str, pipe, log_ids: list[int], params: dict) -> Params:
    """The submit-time check again, in the worker: :meth:`Pipeline.check` on the stored logs' facts.

    Parameters
    ----------
    database_url : str
        The database holding the logs.
    pipe : Pipeline
        The job's pipeline.
    log_ids : list of int
        The job's logs.
    params : dict
        The parameters as given at the submit.

    Returns
    -------
    Params
        The pipeline's validated parameter model, defaults filled in.

    Raises
    ------
    ParameterError
        The same the submit would raise now (the job fails with its message).
    InputError
        When a log of the job was deleted (naming ``log_ids``).
    """
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
        *,
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

    def start(self) -> None:
        """Re-queue jobs lost by a dead worker, then start the consumer (if any) and the reaper's thread."""
        self.runner.reap()
        if self.consumer is not None:
            # inside the server the web server owns the signals (and we may not be on the main thread)
            self.consumer._set_signal_handlers = lambda: None
            self.consumer.start()
        self._reaper.start()

    def stop(self) -> None:
        """Stop the reaper and let the consumer's workers finish their current jobs."""
        self._stop.set()
        if self.consumer is not None:
            self.consumer.stop(graceful=True)
