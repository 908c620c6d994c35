"""Jobs in the database: the queries and status changes of the API (the worker's own, which claim a
job, report its progress and write its results, are in :mod:`ldvsurvey.jobs.runner`)."""

from __future__ import annotations

import datetime as dt

from sqlalchemy import func, select
from sqlalchemy.orm import Session

from ldvsurvey.store.models import Job, JobFile

#: a job in one of these counts against its user's limit of active jobs
ACTIVE = ("queued", "running")
#: a job in one of these has ended (it can be retried when it failed or was cancelled)
FINISHED = ("succeeded", "failed", "cancelled")


def add_job(session: Session, *, pipeline: str, log_ids: list[int], parameters: dict, user_id: int | None) -> Job:
    """A new queued job in the session (not committed).

    Parameters
    ----------
    session : Session
        The request's session; the caller commits, then hands the job's id to the queue.
    pipeline : str
        The pipeline's name.
    log_ids : list of int
        The logs it runs on, the first one the job's own.
    parameters : dict
        The parameters as given (the pipeline's defaults fill the rest when it runs).
    user_id : int or None
        Who started it (None with authentication off).

    Returns
    -------
    Job
        The new row (its ``id`` assigned at the next flush).
    """
    job = Job(
        pipeline=pipeline,
        log_ids=log_ids,
        parameters=parameters,
        status="queued",
        stage="queued",
        progress=0.0,
        user_id=user_id,
    )
    session.add(job)
    return job


def list_jobs(session: Session, *, log_id: int | None = None) -> list[Job]:
    """Jobs, newest first; with ``log_id`` only those that read that log."""
    jobs = list(session.scalars(select(Job).order_by(Job.id.desc())))
    if log_id is not None:
        jobs = [j for j in jobs if log_id in j.log_ids]
    return jobs


def count_active(session: Session, user_id: int) -> int:
    """How many of the user's jobs are queued or running."""
    return session.scalar(select(func.count()).select_from(Job).where(Job.user_id == user_id, Job.status.in_(ACTIVE)))


def request_cancel(job: Job) -> None:
    """Ask a job to stop: a queued job is cancelled at once, a running one stops at its next check."""
    job.cancel_requested = True
    if job.status == "queued":
        job.status, job.stage = "cancelled", "cancelled"
        job.finished_at = dt.datetime.now(dt.UTC)


def requeue(job: Job) -> None:
    """Put a failed or cancelled job back in the queued state (error, progress and cancel request cleared)."""
    job.status, job.stage, job.progress, job.error, job.cancel_requested = "queued", "queued", 0.0, None, False
    job.finished_at = None


def list_result_files(session: Session, job_id: int) -> list[tuple[str, int]]:
    """(name, size in bytes) of each result file of a job, by name."""
    rows = session.execute(
        select(JobFile.name, JobFile.size_bytes).where(JobFile.job_id == job_id).order_by(JobFile.name)
    )
    return [(n, s) for n, s in rows]


def result_file(session: Session, job_id: int, name: str) -> JobFile | None:
    """A job's result file of that name, or None."""
    return session.scalar(select(JobFile).where(JobFile.job_id == job_id, JobFile.name == name))


def newest_runs(session: Session, log_ids: set[int]) -> list[Job]:
    """The newest succeeded job of each pipeline on each set of logs, among jobs that read only logs
    in ``log_ids`` (a project's logs); oldest first."""
    newest: dict = {}
    for j in session.scalars(select(Job).where(Job.status == "succeeded").order_by(Job.id.desc())):
        if j.log_ids and set(j.log_ids) <= log_ids:
            newest.setdefault((j.pipeline, tuple(j.log_ids)), j)
    return sorted(newest.values(), key=lambda j: j.id)
