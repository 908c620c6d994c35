"""``/api/jobs`` and ``/api/logs/{id}/jobs``: start, watch, cancel, retry; result files and views."""

from __future__ import annotations

import datetime as dt

from fastapi import APIRouter, HTTPException, Query, Request, Response
from pydantic import BaseModel, Field
from sqlalchemy.orm import Session

from ldvsurvey.api import models as m
from ldvsurvey.api.auth import (
    CurrentUser,
    check_job_owner,
    check_job_quota,
    principal,
    visible_job,
    visible_jobs,
    visible_log,
)
from ldvsurvey.api.deps import BodyId, JobId, LogId, RunnerDep, SessionDep, SettingsDep
from ldvsurvey.api.headlines import headlines, labels
from ldvsurvey.api.tables import JobTables, job_file
from ldvsurvey.api.views import VIEWS, MissingResult, UnknownView, build_view, views_of
from ldvsurvey.errors import ParameterError
from ldvsurvey.io.nmea import FIX_QUALITY_NAMES
from ldvsurvey.jobs.runner import log_facts
from ldvsurvey.store import jobs as jstore
from ldvsurvey.store.logs import get_log
from ldvsurvey.store.models import Job

router = APIRouter(tags=["jobs"])
#: parameters naming server-side files are not accepted from the network
SERVER_PATH_PARAMS = {"dov_grid", "imu_nodov", "external_grid"}


class JobRequest(BaseModel):
    """A job to start: the pipeline, its parameters (unknown keys refused) and further logs."""

    pipeline: str = Field(..., examples=["height"])
    parameters: dict[str, str | float | int | bool | list[float] | None] = Field(default_factory=dict)
    log_ids: list[BodyId] = Field(
        default_factory=list, max_length=50, description="further logs (gravity line comparison)"
    )


def job_dict(j: Job) -> dict:
    """A job row as the API answers it (:class:`ldvsurvey.api.models.Job`; times in ISO 8601, UTC)."""

    def iso(x):
        return x.isoformat() if isinstance(x, dt.datetime) else None

    return {
        "id": j.id,
        "pipeline": j.pipeline,
        "log_ids": j.log_ids,
        "parameters": j.parameters,
        "status": j.status,
        "stage": j.stage,
        "progress": j.progress,
        "attempts": j.attempts,
        "cancel_requested": j.cancel_requested,
        "error": j.error,
        "created_at": iso(j.created_at),
        "started_at": iso(j.started_at),
        "finished_at": iso(j.finished_at),
        "heartbeat_at": iso(j.heartbeat_at),
        "summary": j.summary,
        "stage_log": j.stage_log or [],
    }


def job_detail(session: Session, j: Job) -> dict:
    """:func:`job_dict` with the inputs (each log's files with their SHA-256) and the warnings."""
    from ldvsurvey.store.logs import list_files

    inputs = []
    for lid in j.log_ids:
        row = get_log(session, lid)
        if row is not None:
            inputs.append(
                {
                    "log_id": lid,
                    "name": row.name,
                    "bundle_sha256": row.sha256,
                    "files": [{"name": n, "sha256": h, "size_bytes": b} for n, h, b in list_files(session, lid)],
                }
            )
    s = j.summary or {}
    warnings = s.get("warnings")
    if warnings is None:  # not finished: the logs' own warnings
        warnings = [
            w
            for lid in j.log_ids
            if (row := get_log(session, lid)) is not None
            for w in (row.quality or {}).get("warnings", [])
        ]
    return {
        **job_dict(j),
        "inputs": inputs,
        "warnings": warnings,
        "views": [v.info() for v in views_of(j.pipeline, s if j.summary else None)],
        "headlines": headlines(j.pipeline, j.summary),
        "labels": labels(j.summary, j.parameters),
    }


def public_schema(model) -> dict:
    """The JSON schema of a parameter model without the parameters naming server-side files."""
    schema = model.model_json_schema()
    schema["properties"] = {k: v for k, v in schema["properties"].items() if k not in SERVER_PATH_PARAMS}
    return schema


@router.get(
    "/api/pipelines",
    summary="Pipelines with their parameters, defaults and JSON schema",
    response_model_exclude_unset=True,
)
def list_pipelines(
    request: Request,
    session: SessionDep,
    st: SettingsDep,
    log_id: int | None = Query(
        None, ge=1, le=2**31 - 1, description="also say whether each pipeline applies to this log"
    ),
) -> list[m.PipelineInfo]:
    """Every pipeline with its parameters (name, kind, default, help, label, unit, choices) and their JSON
    schema; parameters naming files on the server are left out. With ``log_id``, also whether each
    pipeline applies to that log with its default parameters, and why not (401 without a login when
    authentication is on, 404 for a log the caller cannot see)."""
    from ldvsurvey.pipelines.labels import param_label
    from ldvsurvey.pipelines.registry import PIPELINES

    facts = None
    if log_id is not None:  # the list itself is public; a log's applicability needs the right to see it
        facts = [log_facts(visible_log(session, principal(request, session, st), log_id))]
    out = []
    for p in PIPELINES.values():
        item = {
            "name": p.name,
            "description": p.description,
            "multi_input": p.multi_input,
            "parameters": [
                {
                    "name": q.name,
                    "kind": q.kind,
                    "default": q.default,
                    "help": q.help,
                    "label": param_label(q.name)[0],
                    "unit": param_label(q.name)[1],
                    "choices": list(q.choices) if q.choices else None,
                }
                for q in p.params
                if q.name not in SERVER_PATH_PARAMS
            ],
            "schema": public_schema(p.model),
        }
        if facts is not None:  # with the default parameters
            reasons = p.applicable(facts, p.model())
            item["applicable"] = not reasons
            item["reasons"] = [f"{r.field}: {r.message}" for r in reasons]
        out.append(item)
    return out


@router.post("/api/logs/{log_id}/jobs", status_code=201, summary="Start a pipeline on a log")
def start_job(
    log_id: LogId, req: JobRequest, session: SessionDep, who: CurrentUser, st: SettingsDep, runner: RunnerDep
) -> m.JobStarted:
    """Queue a pipeline run on the log (and, for a pipeline taking several, the further ``log_ids``).

    Answers the queued job with its parameters resolved (defaults filled in). Errors: 404 for a log
    the caller cannot see; 422 naming the field for an unknown pipeline, a parameter unknown, out of
    bounds or naming a file on the server, or a pipeline that does not apply to the logs; 429 past
    the user's limit of active jobs.
    """
    from ldvsurvey.pipelines.registry import get

    ids = [log_id] + [i for i in req.log_ids if i != log_id]
    rows = [visible_log(session, who, i) for i in ids]
    pipe = get(req.pipeline)
    bad = SERVER_PATH_PARAMS & set(req.parameters)
    if bad:
        raise ParameterError("names a file on the server: not accepted through the API", field=sorted(bad)[0])
    if len(ids) > 1 and not pipe.multi_input:
        raise ParameterError(f"'{pipe.name}' takes one log", field="log_ids")
    # types and bounds of every parameter, then whether the pipeline applies to these logs: 422 naming the field
    given = {k: v for k, v in req.parameters.items() if v is not None}
    model = pipe.check([log_facts(r) for r in rows], given)
    check_job_quota(session, who, st)
    job = jstore.add_job(
        session, pipeline=pipe.name, log_ids=ids, parameters=given, user_id=who.user.id if who.user else None
    )
    session.commit()
    runner.enqueue(job.id)
    out = job_dict(job)
    out["resolved_parameters"] = model.model_dump(mode="json")
    return out


@router.get("/api/views", summary="Every view (Plotly figure of a result): pipeline, title, units, files read")
def list_views(
    pipeline: str | None = Query(None, max_length=100, description="only this pipeline's views"),
) -> list[m.ViewInfo]:
    """The registry of views: each one's name, pipeline, title, units and the result files it reads."""
    return [v.info() for v in VIEWS.values() if pipeline is None or v.pipeline == pipeline]


@router.get("/api/names", summary="Names shared by the API and the dashboard: GNSS fix qualities")
def names() -> m.Names:
    """Names the dashboard shows for codes in the results: the GNSS fix qualities by their NMEA code."""
    return {"fix_quality": {str(k): v for k, v in FIX_QUALITY_NAMES.items()}}


@router.get("/api/basemap", summary="The basemap of the maps (LDVSURVEY_BASEMAP_TILE_URL), if one is set")
def basemap(settings: SettingsDep) -> m.Basemap:
    """The tile URL template and attribution of the maps' basemap (both null when none is set)."""
    return {"tile_url": settings.basemap_tile_url, "attribution": settings.basemap_attribution}


@router.get("/api/jobs", summary="Jobs, newest first")
def list_jobs(
    session: SessionDep, who: CurrentUser, log_id: int | None = Query(None, ge=1, le=2**31 - 1)
) -> list[m.Job]:
    """The jobs the caller may see (every log they read is in one of the caller's projects), newest
    first; with ``log_id`` only those that read that log. 401 without a login when authentication is on."""
    jobs = visible_jobs(session, who, jstore.list_jobs(session, log_id=log_id))
    return [job_dict(j) for j in jobs]


@router.get("/api/jobs/{job_id}", summary="One job: status, stage, progress, error, summary")
def get_job(job_id: JobId, session: SessionDep, who: CurrentUser) -> m.JobDetail:
    """One job with its inputs (each log's files and their SHA-256), warnings, views, headline figures
    and labels. 404 when there is no such job or the caller cannot see one of its logs."""
    return job_detail(session, visible_job(session, who, job_id))


@router.post("/api/jobs/{job_id}/cancel", summary="Ask a job to stop (between stages)")
def cancel_job(job_id: JobId, session: SessionDep, who: CurrentUser) -> m.Job:
    """Ask the job to stop: a queued job is cancelled at once, a running one at its pipeline's next
    check. Answers the job. 404 for a job the caller cannot see, 409 when it has already ended, 403
    for the demo account on a job it did not start."""
    j = visible_job(session, who, job_id)
    check_job_owner(who, j, "cancel")
    if j.status in jstore.FINISHED:
        raise HTTPException(409, f"job {job_id} already {j.status}")
    jstore.request_cancel(j)
    session.commit()
    return job_dict(j)


@router.post("/api/jobs/{job_id}/retry", summary="Run a failed or cancelled job again")
def retry_job(job_id: JobId, session: SessionDep, who: CurrentUser, st: SettingsDep, runner: RunnerDep) -> m.Job:
    """Queue a failed or cancelled job again, with the same logs and parameters. Answers the job. 404 for
    a job the caller cannot see, 409 when it has not failed or been cancelled, 429 past the user's limit
    of active jobs, 403 for the demo account on a job it did not start."""
    j = visible_job(session, who, job_id)
    check_job_owner(who, j, "retry")
    if j.status not in ("failed", "cancelled"):
        raise HTTPException(409, f"only failed or cancelled jobs can be retried (job {job_id} is {j.status})")
    check_job_quota(session, who, st)  # active again: it counts like a new one
    session.refresh(j)  # as it is under the lock (another request may have retried it meanwhile)
    if j.status not in ("failed", "cancelled"):
        raise HTTPException(409, f"only failed or cancelled jobs can be retried (job {job_id} is {j.status})")
    jstore.requeue(j)
    session.commit()
    runner.enqueue(j.id)
    return job_dict(j)


@router.get("/api/jobs/{job_id}/files", summary="Result files of a job")
def list_job_files(job_id: JobId, session: SessionDep, who: CurrentUser) -> list[m.ResultFile]:
    """The result files of a job (name, size in bytes), by name; empty until it succeeded. 404 for a
    job the caller cannot see."""
    visible_job(session, who, job_id)
    return [{"name": n, "size_bytes": s} for n, s in jstore.list_result_files(session, job_id)]


@router.get(
    "/api/jobs/{job_id}/files/{name}",
    summary="A result file, exactly as the CLI writes it",
    response_class=Response,
    responses={
        200: {
            "description": "the file (CSV, JSON or netCDF; GeoJSON or KML of a table with ?format=)",
            "content": {
                "text/csv": {},
                "application/x-netcdf": {},
                "application/json": {"schema": {"type": "object"}},
                "application/geo+json": {},
                "application/vnd.google-earth.kml+xml": {},
            },
        }
    },
)
def get_job_file(
    job_id: JobId,
    name: str,
    session: SessionDep,
    who: CurrentUser,
    format: str = Query("csv", pattern="^(csv|geojson|kml)$"),
) -> Response:
    """A result file as an attachment: CSV, JSON or netCDF as stored, or with ``format`` a table with
    positions as GeoJSON (RFC 7946) or KML 2.2. 404 for a job the caller cannot see or a file it does
    not have; 422 when a table cannot be turned into that format."""
    j = visible_job(session, who, job_id)
    if format != "csv":  # a table with positions as GeoJSON (RFC 7946) or KML 2.2, with the summary's provenance
        from ldvsurvey.api.imports import job_geo_file

        return job_geo_file(session, j, name, format)
    data = job_file(session, job_id, name)
    ctype = (
        "application/json" if name.endswith(".json") else "application/x-netcdf" if name.endswith(".nc") else "text/csv"
    )
    return Response(content=data, media_type=ctype, headers={"Content-Disposition": f'attachment; filename="{name}"'})


@router.get("/api/jobs/{job_id}/views/{view}", summary="A Plotly figure of a result (downsampled)")
def get_view(
    job_id: JobId,
    view: str,
    session: SessionDep,
    who: CurrentUser,
    x0: float | None = None,
    x1: float | None = None,
    points: int = Query(2000, ge=100, le=20000),
) -> m.Figure:
    """A view of a succeeded job as a Plotly figure, each trace thinned to about ``points`` points in
    ``[x0, x1]`` (the x axis's unit; the whole range by default). 404 for a job the caller cannot see,
    an unknown view or a missing result file; 409 when the job has not succeeded."""
    j = visible_job(session, who, job_id)
    if j.status != "succeeded":
        what = {
            "failed": "it failed, so there are no results (see its error)",
            "cancelled": "it was cancelled, so there are no results",
        }.get(j.status, "no results yet")
        raise HTTPException(409, f"job {job_id} is {j.status}: {what}")
    try:
        return build_view(JobTables(session, j), j.pipeline, j.summary or {}, view, x0, x1, points)
    except (UnknownView, MissingResult) as e:
        raise HTTPException(404, str(e)) from None
