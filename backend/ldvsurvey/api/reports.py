"""``/api/jobs/{id}/report`` and ``/api/projects/{id}/report``: the survey report as one HTML file.

The report itself is built by :mod:`ldvsurvey.api.report` from what is gathered here: a job's
summary, its tables (:class:`ldvsurvey.api.tables.JobTables`), its logs (name, survey date, bundle
SHA-256) and its project.
"""

from __future__ import annotations

import datetime as dt
import re

from fastapi import APIRouter, HTTPException, Response
from sqlalchemy.orm import Session

from ldvsurvey import __version__
from ldvsurvey.api.auth import CurrentUser, visible_job
from ldvsurvey.api.deps import JobId, PathId, SessionDep
from ldvsurvey.api.report import ReportJob, job_report, project_report
from ldvsurvey.api.tables import JobTables
from ldvsurvey.store.jobs import newest_runs
from ldvsurvey.store.logs import get_log, list_logs
from ldvsurvey.store.models import Job, Log, Project

router = APIRouter(tags=["reports"])
#: a project report holds at most this many jobs (the newest run of each pipeline on each set of logs)
MAX_PROJECT_JOBS = 20
HTML = {200: {"content": {"text/html": {}}, "description": "the report: one self-contained HTML file"}}


def _log_info(row: Log) -> dict:
    return {
        "id": row.id,
        "name": row.name,
        "sha256": row.sha256,
        "survey_date": row.survey_date.isoformat() if row.survey_date else "",
        "duration_s": float(row.duration_s),
    }


def _report_job(session: Session, j: Job, project: str | None) -> ReportJob:
    logs = [_log_info(r) for lid in j.log_ids if (r := get_log(session, lid)) is not None]
    fin = j.finished_at.isoformat(timespec="seconds") if j.finished_at else None
    return ReportJob(j.id, j.pipeline, j.status, j.summary or {}, JobTables(session, j), logs, fin, project)


def _download(text: str, name: str) -> Response:
    safe = re.sub(r"[^A-Za-z0-9._-]+", "-", name)
    return Response(
        text.encode("utf-8"),
        media_type="text/html; charset=utf-8",
        headers={"Content-Disposition": f'attachment; filename="{safe}"'},
    )


@router.get(
    "/api/jobs/{job_id}/report",
    summary="The survey report of a job: one self-contained HTML file (figures as SVG, tables, provenance)",
    response_class=Response,
    responses=HTML,
)
def get_job_report(job_id: JobId, session: SessionDep, who: CurrentUser) -> Response:
    """The report of a succeeded job as an HTML attachment: its figures, tables, parameters and
    provenance (logs with their SHA-256, software version). 404 for a job the caller cannot see, 409
    when the job has not succeeded."""
    j = visible_job(session, who, job_id)
    if j.status != "succeeded":
        raise HTTPException(409, f"job {job_id} is {j.status}: only a succeeded job has a report")
    first = get_log(session, j.log_ids[0]) if j.log_ids else None
    proj = session.get(Project, first.project_id) if first is not None and first.project_id else None
    text = job_report(_report_job(session, j, proj.name if proj else None), f"ldv-survey {__version__}", _now())
    return _download(text, f"ldv-survey-job-{j.id}-{j.pipeline}-report.html")


@router.get(
    "/api/projects/{project_id}/report",
    summary="The survey report of a project: its logs, a map, and the newest finished job of each kind",
    response_class=Response,
    responses=HTML,
)
def get_project_report(project_id: PathId, session: SessionDep, who: CurrentUser) -> Response:
    """The report of a project as an HTML attachment: its logs, a map, and the newest succeeded job of
    each pipeline on each set of its logs (at most ``MAX_PROJECT_JOBS``, the newest). 404 for a
    project the caller is not a member of."""
    p = session.get(Project, project_id)
    if p is None or (who.projects is not None and project_id not in who.projects):
        raise HTTPException(404, f"project {project_id} not found")
    logs = list_logs(session, project_id=project_id)[::-1]  # oldest first
    jobs = newest_runs(session, {r.id for r in logs})[-MAX_PROJECT_JOBS:]
    text = project_report(
        p.name,
        [_report_job(session, j, p.name) for j in jobs],
        [_log_info(r) for r in logs],
        f"ldv-survey {__version__}",
        _now(),
    )
    return _download(text, f"ldv-survey-project-{p.id}-{p.name}-report.html")


def _now() -> dt.datetime:
    return dt.datetime.now(dt.UTC)
