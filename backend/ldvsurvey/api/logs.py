"""``/api/logs``: upload, list, inspect, download originals, delete."""

from __future__ import annotations

import datetime as dt
import mimetypes

from fastapi import APIRouter, File, Form, HTTPException, Query, Request, Response, UploadFile
from fastapi.responses import StreamingResponse
from sqlalchemy.orm import Session

from ldvsurvey.api import models as m
from ldvsurvey.api.auth import CurrentUser, Principal, check_upload_rate, refuse_demo, visible_log
from ldvsurvey.api.deps import ID_MAX, LogId, SessionDep, SettingsDep
from ldvsurvey.api.uploads import read_upload
from ldvsurvey.io.drivelog import parse_files
from ldvsurvey.io.quality import quality_report
from ldvsurvey.store import blobs
from ldvsurvey.store import logs as store
from ldvsurvey.store import users as ustore

router = APIRouter(prefix="/api/logs", tags=["logs"])

#: bytes read from a stored original per piece of its download
DOWNLOAD_CHUNK_BYTES = 256 * 1024


def log_summary(row) -> dict:
    """The list view of a log."""
    q = row.quality or {}
    gnss = q.get("gnss") or {}
    return {
        "id": row.id,
        "name": row.name,
        "sha256": row.sha256,
        "project_id": row.project_id,
        "platform": row.platform,
        "ldv_kind": row.ldv_kind,
        "imu_rotating": row.imu_rotating,
        "survey_date": row.survey_date.isoformat(),
        "t_start_s": row.t_start_s,
        "t_end_s": row.t_end_s,
        "duration_s": row.duration_s,
        "has_gnss": row.has_gnss,
        "size_bytes": row.size_bytes,
        "created_at": row.created_at.isoformat(),
        "badges": {
            "imu_gaps": (q.get("imu") or {}).get("gaps"),
            "ldv_below_min_quality_share": (q.get("ldv") or {}).get("below_min_quality_share"),
            "gnss_rtk_fixed_share": (gnss.get("fix_time_share") or {}).get("rtk_fixed"),
            "warnings": len(q.get("warnings") or []),
        },
    }


def target_project(session: Session, who: Principal, project_id: int | None) -> int | None:
    """The project a new log goes to: the one named (404 unless the uploader may write to it), else a
    member's first project, an admin's own default project (none without a user: open mode)."""
    if who.projects is not None:
        if project_id is None:
            if not who.projects:
                raise HTTPException(403, "you are not a member of any project")
            return who.projects[0]
        if project_id not in who.projects:
            raise HTTPException(404, f"project {project_id} not found")
        return project_id
    if who.user is not None:  # an admin: a named project must exist; none named: their own
        from ldvsurvey.store.models import Project

        if project_id is None:
            return ustore.default_project(session, who.user)
        if session.get(Project, project_id) is None:
            raise HTTPException(404, f"project {project_id} not found")
    return project_id


@router.post("", status_code=201, summary="Upload a drive-log bundle (one .zip, or the files)")
def upload_log(
    request: Request,
    response: Response,
    files: list[UploadFile] = File(...),
    project_id: int | None = Form(None, ge=1, le=2**31 - 1),
    *,
    session: SessionDep,
    who: CurrentUser,
    st: SettingsDep,
) -> m.Uploaded:
    """Validate, parse and store a bundle in a project; answers the log with its quality report (201).

    The same bundle uploaded again to the same project is not stored twice (200 with ``duplicate:
    true`` and the existing log). Errors: 422 naming the file, line and field for a bad bundle; 413
    for an archive or file over the limits; 404 for a project the caller may not write to, 403 when
    they are a member of none; 429 past the upload rate.
    """
    check_upload_rate(request, who, st)
    project_id = target_project(session, who, project_id)
    members = read_upload(files, st)
    log = parse_files(members)
    quality = quality_report(log)
    row, created = store.store_log(session, log, quality, project_id)
    session.commit()
    if not created:
        response.status_code = 200
    response.headers["Location"] = f"/api/logs/{row.id}"
    return {**log_summary(row), "duplicate": not created, "quality": row.quality}


@router.get("", summary="List drive logs (newest first), optionally filtered")
def list_logs(
    project_id: int | None = Query(None, ge=1, le=ID_MAX),
    platform: str | None = Query(None, max_length=16, description="vehicle or vessel"),
    date_from: dt.date | None = Query(None, description="survey date on or after (YYYY-MM-DD)"),
    date_to: dt.date | None = Query(None, description="survey date on or before (YYYY-MM-DD)"),
    *,
    session: SessionDep,
    who: CurrentUser,
) -> list[m.LogSummary]:
    """The drive logs the caller may see, newest first; each given filter (project, platform, survey dates inclusive)
    narrows. 401 without a login when authentication is on."""
    rows = store.list_logs(
        session, project_id=project_id, platform=platform or None, date_from=date_from, date_to=date_to
    )
    return [log_summary(r) for r in rows if who.can_see(r)]


@router.get("/{log_id}", summary="One log: manifest, quality report, files")
def get_log(log_id: LogId, session: SessionDep, who: CurrentUser) -> m.LogDetail:
    """One log: its summary, manifest, quality report and original files (name, SHA-256, size in bytes). 404 for a log
    the caller cannot see."""
    row = visible_log(session, who, log_id)
    return {
        **log_summary(row),
        "manifest": row.manifest,
        "quality": row.quality,
        "files": [{"name": n, "sha256": h, "size_bytes": s} for n, h, s in store.list_files(session, log_id)],
    }


@router.get(
    "/{log_id}/files/{name}",
    summary="An original file, byte for byte",
    response_class=Response,
    responses={
        200: {
            "description": "the file as uploaded (X-Content-SHA256: its SHA-256)",
            "content": {
                "text/csv": {},
                "application/json": {"schema": {"type": "object"}},
                "application/octet-stream": {},
            },
        }
    },
)
def get_file(log_id: LogId, name: str, session: SessionDep, who: CurrentUser) -> Response:
    """An original file of a log byte for byte, as an attachment with its SHA-256 in ``X-Content-SHA256`` (large files
    streamed). 404 for a log the caller cannot see or a file it does not have."""
    visible_log(session, who, log_id)
    f = store.get_file(session, log_id, name)
    if f is None:
        raise HTTPException(404, f"log {log_id} has no file '{name}'")
    ctype = {"manifest.json": "application/json", "imu.csv": "text/csv", "ldv.csv": "text/csv"}.get(
        name, mimetypes.guess_type(name)[0] or "application/octet-stream"
    )
    headers = {"Content-Disposition": f'attachment; filename="{name}"', "X-Content-SHA256": f.sha256}
    if f.blob is None:  # a small file kept in its row
        return Response(content=f.inline, media_type=ctype, headers=headers)
    # a large one is sent from the blob folder or the database, a piece at a time (an 8-h imu.csv
    # is close to 1 GB); opened here, so a deletion committed meanwhile cannot cut the download short
    pieces, size = blobs.download(f, f.blob, piece_bytes=DOWNLOAD_CHUNK_BYTES)
    headers["Content-Length"] = str(size)
    return StreamingResponse(pieces, media_type=ctype, headers=headers)


@router.delete("/{log_id}", status_code=204, summary="Delete a log with all its files and arrays")
def delete_log(log_id: LogId, session: SessionDep, who: CurrentUser) -> Response:
    """Delete a log with its files, arrays and every job computed from it; answers once it is gone (204). 404 for a log
    the caller cannot see, 403 for the demo account."""
    visible_log(session, who, log_id)
    refuse_demo(who, "delete logs")  # logs do not record their uploader: none is the demo's to delete
    store.delete_log(session, log_id)
    session.commit()  # answer only once it is gone: an immediate GET says 404
    return Response(status_code=204)
