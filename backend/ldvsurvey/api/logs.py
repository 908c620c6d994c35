"""``/api/logs``: upload, list, inspect, download originals, delete."""

from __future__ import annotations

import mimetypes

from fastapi import APIRouter, Depends, File, Form, HTTPException, Request, Response, UploadFile
from sqlalchemy.orm import Session

from ldvsurvey.api.auth import Principal, check_upload_rate, principal, visible_log
from ldvsurvey.api.deps import LogId, get_session
from ldvsurvey.errors import BundleError
from ldvsurvey.io.drivelog import parse_files, read_zip
from ldvsurvey.io.quality import quality_report
from ldvsurvey.store import logs as store

router = APIRouter(prefix="/api/logs", tags=["logs"])


def log_summary(row) -> dict:
    """The list view of a log."""
    q = row.quality or {}
    gnss = q.get("gnss") or {}
    return {
        "id": row.id, "name": row.name, "sha256": row.sha256, "project_id": row.project_id, "platform": row.platform,
        "ldv_kind": row.ldv_kind, "imu_rotating": row.imu_rotating,
        "survey_date": row.survey_date.isoformat(), "t_start_s": row.t_start_s,
        "t_end_s": row.t_end_s, "duration_s": row.duration_s, "has_gnss": row.has_gnss,
        "size_bytes": row.size_bytes, "created_at": row.created_at.isoformat(),
        "badges": {
            "imu_gaps": (q.get("imu") or {}).get("gaps"),
            "ldv_below_min_quality_share": (q.get("ldv") or {}).get("below_min_quality_share"),
            "gnss_rtk_fixed_share": (gnss.get("fix_time_share") or {}).get("rtk_fixed"),
            "warnings": len(q.get("warnings") or []),
        },
    }


def read_upload(uploads: list[UploadFile], max_unzipped: int, max_ratio: float) -> dict[str, bytes]:
    """Turn the multipart parts into ``{file name: bytes}`` (one zip, or the files)."""
    if not uploads:
        raise BundleError("no file in the upload (send one .zip or the bundle's files as 'files')")
    parts = {}
    for up in uploads:
        name = (up.filename or "").replace("\\", "/").rsplit("/", 1)[-1]
        if not name:
            raise BundleError("an uploaded part has no file name")
        if name in parts:
            raise BundleError("file uploaded twice", file=name)
        parts[name] = up.file.read()
    if len(parts) == 1:
        (name, data), = parts.items()
        if name.lower().endswith(".zip") or data[:2] == b"PK":
            return read_zip(data, max_unzipped, max_ratio, name=name)
    zips = [n for n in parts if n.lower().endswith(".zip")]
    if zips:
        raise BundleError("send either one .zip or the separate files, not both", file=zips[0])
    return parts


@router.post("", status_code=201, summary="Upload a drive-log bundle (one .zip, or the files)")
def upload_log(request: Request, response: Response, files: list[UploadFile] = File(...),
               project_id: int | None = Form(None, ge=1, le=2**31 - 1), session: Session = Depends(get_session),
               who: Principal = Depends(principal)) -> dict:
    """Validate, parse and store a bundle in a project. The same bundle uploaded again to the same
    project is not stored twice (200 with ``duplicate: true`` and the existing log)."""
    st = request.app.state.settings
    check_upload_rate(request, who)
    if who.projects is not None:
        if project_id is None:
            if not who.projects:
                raise HTTPException(403, "you are not a member of any project")
            project_id = who.projects[0]
        elif project_id not in who.projects:
            raise HTTPException(404, f"project {project_id} not found")
    members = read_upload(files, st.max_unzipped_bytes, st.max_zip_ratio)
    log = parse_files(members)
    quality = quality_report(log)
    row, created = store.store_log(session, log, quality, project_id)
    session.commit()
    if not created:
        response.status_code = 200
    response.headers["Location"] = f"/api/logs/{row.id}"
    return {**log_summary(row), "duplicate": not created, "quality": row.quality}


@router.get("", summary="List drive logs")
def list_logs(session: Session = Depends(get_session), who: Principal = Depends(principal)) -> list[dict]:
    return [log_summary(r) for r in store.list_logs(session) if who.can_see(r)]


@router.get("/{log_id}", summary="One log: manifest, quality report, files")
def get_log(log_id: LogId, session: Session = Depends(get_session), who: Principal = Depends(principal)) -> dict:
    row = visible_log(session, who, log_id)
    return {**log_summary(row), "manifest": row.manifest, "quality": row.quality,
            "files": [{"name": n, "sha256": h, "size_bytes": s} for n, h, s in store.list_files(session, log_id)]}


@router.get("/{log_id}/files/{name}", summary="An original file, byte for byte")
def get_file(log_id: LogId, name: str, session: Session = Depends(get_session),
             who: Principal = Depends(principal)) -> Response:
    visible_log(session, who, log_id)
    f = store.get_file(session, log_id, name)
    if f is None:
        raise HTTPException(404, f"log {log_id} has no file '{name}'")
    ctype = {"manifest.json": "application/json", "imu.csv": "text/csv", "ldv.csv": "text/csv"}.get(
        name, mimetypes.guess_type(name)[0] or "application/octet-stream")
    return Response(content=f.content, media_type=ctype,
                    headers={"Content-Disposition": f'attachment; filename="{name}"',
                             "X-Content-SHA256": f.sha256})


@router.delete("/{log_id}", status_code=204, summary="Delete a log with all its files and arrays")
def delete_log(log_id: LogId, session: Session = Depends(get_session), who: Principal = Depends(principal)) -> Response:
    visible_log(session, who, log_id)
    store.delete_log(session, log_id)
    return Response(status_code=204)

