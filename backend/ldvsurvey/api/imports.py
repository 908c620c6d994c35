"""``/api/imports``: foreign recordings (NovAtel, u-blox, KF-GINS, NMEA, CSV) converted to a bundle.

``POST /api/imports/preview`` converts and validates without storing and answers what was found
(formats, time span, rates, a downsampled GNSS track); ``POST /api/imports`` converts, validates and
stores the bundle with the original files kept byte for byte beside it (named ``original-<name>``).
"""

from __future__ import annotations

import json

from fastapi import APIRouter, File, Form, Request, Response, UploadFile
from sqlalchemy.orm import Session

from ldvsurvey.api import models as m
from ldvsurvey.api.auth import CurrentUser, check_upload_rate
from ldvsurvey.api.deps import SessionDep, SettingsDep
from ldvsurvey.api.tables import job_file
from ldvsurvey.api.uploads import part_names
from ldvsurvey.errors import BundleError
from ldvsurvey.io.importers import REGISTRY, Source, build_bundle, detect, parse_partial_manifest

router = APIRouter(prefix="/api/imports", tags=["imports"])
ORIGINAL_PREFIX = "original-"
ROLES = ("imu", "gnss", "ldv")


def _hints(formats: str | None) -> dict[str, tuple[str, str | None]]:
    """``formats`` form field: JSON object file name -> "FORMAT" or "FORMAT:ROLE"."""
    if not formats:
        return {}
    try:
        raw = json.loads(formats)
    except json.JSONDecodeError as exc:
        raise BundleError(f"invalid JSON: {exc.msg}", file="formats", line=exc.lineno) from None
    if not isinstance(raw, dict):
        raise BundleError('must be a JSON object {file name: "format" or "format:role"}', file="formats")
    out = {}
    for name, spec in raw.items():
        fmt, _, role = str(spec).partition(":")
        if fmt not in REGISTRY:
            raise BundleError(f"unknown format '{fmt}' (known: {', '.join(REGISTRY)})", file="formats", field=name)
        if role and role not in ROLES:
            raise BundleError(f"unknown role '{role}' (known: {', '.join(ROLES)})", file="formats", field=name)
        out[name] = (fmt, role or None)
    return out


def _with_axes(partial: dict, axes: str | None) -> dict:
    """The form field ``axes`` (the IMU's sensor axes, any format) over the manifest's import.imu.axes."""
    if not axes:
        return partial
    imp = partial.setdefault("import", {})
    if not isinstance(imp, dict) or not isinstance(imp.setdefault("imu", {}), dict):
        raise BundleError("must be an object", file="manifest", field="import.imu")
    imp["imu"]["axes"] = axes
    return partial


def _read_parts(files: list[UploadFile], manifest: str | None, formats: str | None):
    """(sources, partial manifest, originals) from the multipart fields."""
    if not files:
        raise BundleError("no file in the upload (send the recordings as 'files')")
    hints = _hints(formats)
    partial = None
    originals = {name: up.file.read() for name, up in zip(part_names(files), files)}
    if manifest:
        partial = parse_partial_manifest(manifest.encode(), file="manifest")
    sources = []
    for name, data in originals.items():
        if name in hints:
            fmt, role = hints[name]
            if role is None:
                found = detect(data, name)
                role = found[1] if found and found[0] == fmt else None
            if role is None:
                raise BundleError(
                    f'say which data it holds: "{fmt}:imu", "{fmt}:gnss" or "{fmt}:ldv"', file="formats", field=name
                )
        elif name.lower().endswith(".json") and partial is None:
            partial = parse_partial_manifest(data, file=name)
            continue
        else:
            found = detect(data, name)
            if found is None:
                raise BundleError(
                    f'format not recognised: name it in \'formats\' (e.g. {{"{name}": "csv:imu"}})', file=name
                )
            fmt, role = found
        sources.append(Source(role=role, format=fmt, name=name, data=data))
    return sources, partial or {}, originals


@router.post("/preview", summary="Convert foreign recordings and say what was found (nothing stored)")
def preview_import(
    request: Request,
    files: list[UploadFile] = File(...),
    manifest: str | None = Form(None),
    formats: str | None = Form(None),
    axes: str | None = Form(None),
    *,
    who: CurrentUser,
    st: SettingsDep,
) -> m.ImportPreview:
    """Convert foreign recordings into a bundle without storing anything, and say what was found: the
    files with their detected format and role, time span (s), rates (Hz), GNSS track, survey date,
    IMU axes, static tilt (deg), the import's checks and warnings. 422 naming the file
    and field when a format is not recognised or a recording or the partial manifest is malformed;
    429 past the upload rate.
    """
    check_upload_rate(request, who, st)  # a preview converts everything: it counts as an upload
    sources, partial, _ = _read_parts(files, manifest, formats)
    partial = _with_axes(partial, axes)
    result = build_bundle(sources, partial)
    s = result.summary
    return {
        "files": s["files"],
        "time_span_s": s["time_span_s"],
        "rates_hz": s["rates_hz"],
        "gnss_track": s["gnss_track"],
        "date": s["date"],
        "imu_axes": s["imu_axes"],
        "static_tilt_deg": s["static_tilt_deg"],
        "checks": s.get("checks"),
        "warnings": result.warnings,
    }


@router.post("", status_code=201, summary="Convert foreign recordings, validate and store the bundle")
def create_import(
    request: Request,
    response: Response,
    files: list[UploadFile] = File(...),
    manifest: str | None = Form(None),
    formats: str | None = Form(None),
    axes: str | None = Form(None),
    project_id: int | None = Form(None, ge=1, le=2**31 - 1),
    *,
    session: SessionDep,
    who: CurrentUser,
    st: SettingsDep,
) -> m.Imported:
    """Convert foreign recordings into a bundle, validate and store it in a project, keeping the
    originals with it. Answers like ``POST /api/logs`` (201 with the log; 200 with ``duplicate:
    true``) plus what the import found. Errors as ``POST /api/logs`` and ``/api/imports/preview``
    (422 naming the file and field, 413, 404 or 403 for the project, 429)."""
    from ldvsurvey.api.logs import log_summary, target_project
    from ldvsurvey.io.drivelog import parse_files
    from ldvsurvey.io.quality import quality_report
    from ldvsurvey.store import logs as store

    check_upload_rate(request, who, st)
    project_id = target_project(session, who, project_id)
    sources, partial, originals = _read_parts(files, manifest, formats)
    partial = _with_axes(partial, axes)
    result = build_bundle(sources, partial)
    log = parse_files(result.files)
    quality = quality_report(log)
    quality.setdefault("warnings", [])
    quality["warnings"] = list(quality["warnings"]) + [w for w in result.warnings if w not in quality["warnings"]]
    row, created = store.store_log(session, log, quality, project_id)
    if created:
        store.add_files(session, row.id, {ORIGINAL_PREFIX + name: content for name, content in originals.items()})
    session.commit()
    if not created:
        response.status_code = 200
    response.headers["Location"] = f"/api/logs/{row.id}"
    return {
        **log_summary(row),
        "duplicate": not created,
        "quality": row.quality,
        "import": {
            "files": result.summary["files"],
            "checks": result.summary.get("checks"),
            "warnings": result.warnings,
        },
    }


def job_geo_file(session: Session, job, name: str, fmt: str) -> Response:
    """A job's result table converted to GeoJSON or KML (``GET /api/jobs/{id}/files/{name}?format=``)."""
    from ldvsurvey.io.writers import geo_export
    from ldvsurvey.store.logs import load_array

    if not name.endswith(".csv"):
        raise BundleError("only the CSV tables convert to GeoJSON or KML", file=name, field="format")
    data = job_file(session, job.id, name)
    summary = json.loads(job_file(session, job.id, "summary.json"))
    header = data.split(b"\n", 1)[0].decode().split(",")
    track = None
    if "lat_deg" not in header and job.log_ids:
        g = load_array(session, job.log_ids[0], "gnss")
        if g is not None:
            ok = g["fix"] > 0
            track = {"t_s": g["t_s"][ok], "lat_deg": g["lat_deg"][ok], "lon_deg": g["lon_deg"][ok]}
    out_name, out = geo_export(fmt, name[:-4], data, summary, track)
    ctype = "application/geo+json" if fmt == "geojson" else "application/vnd.google-earth.kml+xml"
    return Response(
        content=out, media_type=ctype, headers={"Content-Disposition": f'attachment; filename="{out_name}"'}
    )
