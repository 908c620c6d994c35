"""Storing, listing, loading and deleting drive logs. One transaction per write.

Large originals and the Parquet arrays live in the blob folder (see :mod:`ldvsurvey.store.blobs`);
small files and databases without a folder (in-memory SQLite) keep them in the rows.
"""

from __future__ import annotations

import hashlib
from pathlib import Path

import numpy as np
from sqlalchemy import delete, func, select
from sqlalchemy.exc import IntegrityError
from sqlalchemy.orm import Session

from ldvsurvey.io.drivelog import DriveLog, ImuData, LdvData
from ldvsurvey.io.imutime import BridgedGap
from ldvsurvey.io.logfacts import facts_from_streams, log_facts
from ldvsurvey.io.manifest import Manifest
from ldvsurvey.io.nmea import GnssData
from ldvsurvey.store import blobs
from ldvsurvey.store.blobs import from_parquet, read_parquet_into, to_parquet
from ldvsurvey.store.models import Log, LogArray, LogFile


def _arrays(log: DriveLog) -> dict[str, dict[str, np.ndarray]]:
    imu, ldv = log.imu, log.ldv
    out = {
        "imu": {
            "t_s": imu.t_s,
            "dtheta_x_rad": imu.dtheta_rad[:, 0],
            "dtheta_y_rad": imu.dtheta_rad[:, 1],
            "dtheta_z_rad": imu.dtheta_rad[:, 2],
            "dvel_x_mps": imu.dvel_mps[:, 0],
            "dvel_y_mps": imu.dvel_mps[:, 1],
            "dvel_z_mps": imu.dvel_mps[:, 2],
            "turntable_deg": imu.turntable_deg,
        },
    }
    if ldv is not None:  # a log without an LDV stores no ldv array
        out["ldv"] = {
            "t_s": ldv.t_s,
            "v_fwd_mps": ldv.v_fwd_mps,
            "v_up_mps": ldv.v_up_mps,
            "quality": ldv.quality,
            "fd_hz": ldv.fd_hz,
        }
    if log.gnss is not None:
        g = log.gnss
        out["gnss"] = {
            "t_s": g.t_s,
            "lat_deg": g.lat_deg,
            "lon_deg": g.lon_deg,
            "h_m": g.h_m,
            "fix": g.fix,
            "n_sat": g.n_sat,
            "hdop": g.hdop,
            "line": g.line_of_row,
        }
    return out


def find_by_sha(session: Session, sha256: str, *, project_id: int | None = None) -> Log | None:
    """The log of the project (None: no project) whose bundle has this SHA-256, or None."""
    return session.scalar(
        select(Log).where(
            Log.sha256 == sha256, Log.project_id.is_(project_id) if project_id is None else Log.project_id == project_id
        )
    )


def store_log(session: Session, log: DriveLog, quality: dict, project_id: int | None = None) -> tuple[Log, bool]:
    """Store a parsed bundle (originals, Parquet arrays, quality) unless already stored.

    Large originals and the arrays go to blobs (the folder beside a SQLite file, ``blob_chunks``
    with PostgreSQL), small ones into their rows; every blob is written before a row names it.

    Parameters
    ----------
    session : Session
        The caller's session (flushed here, committed by the caller).
    log : DriveLog
        The parsed bundle.
    quality : dict
        Its quality report (:func:`ldvsurvey.io.quality.quality_report`).
    project_id : int, optional
        The project it belongs to (None: none, with authentication off).

    Returns
    -------
    Log
        The stored row, or the existing one of the same bundle SHA-256 in that project.
    bool
        Whether it was created now (False: a duplicate upload, also when a concurrent upload of the
        same bundle won the race).
    """
    sha = log.sha256
    existing = find_by_sha(session, sha, project_id=project_id)
    if existing is not None:
        return existing, False
    m = log.manifest
    row = Log(
        sha256=sha,
        project_id=project_id,
        name=m.name,
        platform=m.platform,
        ldv_kind="none" if m.ldv is None else m.ldv.kind,
        imu_rotating=m.imu.rotating,
        survey_date=m.date,
        t_start_s=float(log.imu.t_s[0]),
        t_end_s=float(log.imu.t_s[-1]),
        duration_s=float(log.imu.t_s[-1] - log.imu.t_s[0]),
        has_gnss=log.gnss is not None,
        size_bytes=sum(log.size_of(n) for n in log.files),
        manifest=m.model_dump(mode="json"),
        quality=quality,
        facts=log_facts(log),
    )
    session.add(row)
    try:
        session.flush()
        writer = blobs.writer_for(session)  # the folder (SQLite) or the database (PostgreSQL)
        try:
            for name, content in sorted(log.files.items()):
                size = log.size_of(name)
                if writer is not None and size > blobs.INLINE_MAX_BYTES:
                    # a file of the upload's own temporary folder is linked, anything else copied
                    f = LogFile(blob=writer.file(content, suffix="-" + name, link=log.keep is not None))
                else:
                    f = LogFile(
                        content=bytes(content)
                        if isinstance(content, (bytes, bytearray, memoryview))
                        else Path(content).read_bytes()
                    )
                f.log_id, f.name, f.sha256, f.size_bytes = row.id, name, log.sha256_of(name), size
                session.add(f)
            for name, cols in _arrays(log).items():
                a = LogArray(blob=writer.parquet(cols)) if writer is not None else LogArray(parquet=to_parquet(cols))
                a.log_id, a.name, a.n_rows = row.id, name, len(cols["t_s"])
                session.add(a)
        finally:
            if writer is not None:
                writer.done()  # every blob on disk (fsynced) or in the database before a row names it
        session.flush()
    except IntegrityError:  # a concurrent upload of the same bundle won the race
        session.rollback()
        existing = find_by_sha(session, sha, project_id=project_id)
        if existing is None:
            raise
        return existing, False
    return row, True


def list_logs(
    session: Session, *, project_id: int | None = None, platform: str | None = None, date_from=None, date_to=None
) -> list[Log]:
    """Logs, newest first; each given filter narrows (survey dates inclusive)."""
    q = select(Log).order_by(Log.id.desc())
    if project_id is not None:
        q = q.where(Log.project_id == project_id)
    if platform is not None:
        q = q.where(Log.platform == platform)
    if date_from is not None:
        q = q.where(Log.survey_date >= date_from)
    if date_to is not None:
        q = q.where(Log.survey_date <= date_to)
    return list(session.scalars(q))


def facts_of(session: Session, row: Log) -> dict:
    """The stored facts of a log (see :func:`ldvsurvey.io.logfacts.log_facts`). A row stored before
    the facts were kept (``facts`` NULL) gets them now from its stored LDV and GNSS arrays, once."""
    if row.facts is not None:
        return row.facts
    m = row.manifest or {}
    ldv_m = m.get("ldv")
    ldv = gnss = None
    if ldv_m:
        d = load_array(session, row.id, "ldv")
        if d is not None:
            ldv = (d["t_s"], d["v_fwd_mps"], d.get("quality"))
    if row.has_gnss:
        g = load_array(session, row.id, "gnss")
        if g is not None:
            gnss = (g["t_s"], g["lat_deg"], g["lon_deg"], g["fix"])
    row.facts = facts_from_streams(
        ldv_kind=ldv_m.get("kind") if ldv_m else None,
        imu_rotating=bool((m.get("imu") or {}).get("rotating", False)),
        ldv=ldv,
        min_quality=ldv_m.get("min_quality") if ldv_m else None,
        gnss=gnss,
    )
    return row.facts


def get_log(session: Session, log_id: int) -> Log | None:
    """The log of that id, or None."""
    return session.get(Log, log_id)


def add_files(session: Session, log_id: int, files: dict[str, bytes]) -> None:
    """Keep further files with a stored log (an import's original recordings), each with its SHA-256
    and size, under their names (not committed)."""
    for name, content in sorted(files.items()):
        sha256 = hashlib.sha256(content).hexdigest()
        session.add(LogFile(log_id=log_id, name=name, sha256=sha256, size_bytes=len(content), content=content))


def list_files(session: Session, log_id: int) -> list[tuple[str, str, int]]:
    """(name, sha256, size) of each original file."""
    rows = session.execute(
        select(LogFile.name, LogFile.sha256, LogFile.size_bytes).where(LogFile.log_id == log_id).order_by(LogFile.name)
    )
    return [tuple(r) for r in rows]


def get_file(session: Session, log_id: int, name: str) -> LogFile | None:
    """The stored file ``name`` of a log, or None."""
    return session.scalar(select(LogFile).where(LogFile.log_id == log_id, LogFile.name == name))


def delete_log(session: Session, log_id: int) -> bool:
    """Delete a log with every file and array row. Returns False when it did not exist."""
    if session.get(Log, log_id) is None:
        return False
    from ldvsurvey.store.models import Job, JobFile

    job_ids = [j.id for j in session.scalars(select(Job)) if log_id in (j.log_ids or [])]
    if job_ids:  # the results computed from this log go with it; a running one stops when it sees its
        # row gone (jobs.runner treats a missing row as cancelled and keeps no results)
        session.execute(delete(JobFile).where(JobFile.job_id.in_(job_ids)))
        session.execute(delete(Job).where(Job.id.in_(job_ids)))
    keys = [
        k
        for t in (LogFile, LogArray)
        for k in session.scalars(select(t.blob).where(t.log_id == log_id, t.blob.is_not(None)))
    ]
    session.execute(delete(LogArray).where(LogArray.log_id == log_id))
    session.execute(delete(LogFile).where(LogFile.log_id == log_id))
    session.execute(delete(Log).where(Log.id == log_id))
    blobs.delete_from_database(session, keys)  # in this transaction
    in_folder = [k for k in keys if not k.startswith(blobs.DB_PREFIX)]
    root = blobs.root_for(session) if in_folder else None
    if root is not None:  # the files go once the deletion is committed
        blobs.unlink_after_commit(session, [root / k for k in in_folder])
    return True


def count_rows(session: Session) -> dict[str, int]:
    """Row counts of the log tables (used by tests to prove nothing was left behind)."""
    return {t.__tablename__: session.scalar(select(func.count()).select_from(t)) for t in (Log, LogFile, LogArray)}


def _array_source(session: Session, a: LogArray):
    if a.blob is None:
        return a.parquet
    if a.blob.startswith(blobs.DB_PREFIX):
        return blobs.open_blob(a, a.blob)
    return blobs.blob_path(a, a.blob)


def load_array(session: Session, log_id: int, name: str) -> dict[str, np.ndarray] | None:
    """One stored stream (``imu``, ``ldv``, ``gnss``) as columns, without reading the others."""
    a = session.scalar(select(LogArray).where(LogArray.log_id == log_id, LogArray.name == name))
    return None if a is None else from_parquet(_array_source(session, a))


def load_drivelog(session: Session, log_id: int) -> DriveLog | None:
    """Rebuild the parsed :class:`DriveLog` from the stored Parquet arrays (no re-parse).

    The arrays are read row group by row group into their final arrays; the originals are not read
    (``files`` holds the path of a file in the blob folder, or the bytes of a small one kept in its
    row; ``file_sha256`` the stored hashes).

    Parameters
    ----------
    session : Session
        An open session (blobs kept in the database are read through it).
    log_id : int
        The log's id.

    Returns
    -------
    DriveLog or None
        The log with its samples as parsed (units in the field names: ``t_s``, ``dtheta_rad``, …), or
        None when there is no such log.
    """
    row = session.get(Log, log_id)
    if row is None:
        return None
    stacks = {
        "imu": {
            "dtheta_rad": ["dtheta_x_rad", "dtheta_y_rad", "dtheta_z_rad"],
            "dvel_mps": ["dvel_x_mps", "dvel_y_mps", "dvel_z_mps"],
        }
    }
    arrays = {
        a.name: read_parquet_into(_array_source(session, a), stacks.get(a.name))
        for a in session.scalars(select(LogArray).where(LogArray.log_id == log_id))
    }
    files, sha = {}, {}
    for f in session.scalars(select(LogFile).where(LogFile.log_id == log_id)):
        if f.blob is None:
            files[f.name] = f.inline
        elif f.blob.startswith(blobs.DB_PREFIX):  # named, not read (the pipelines read the arrays)
            files[f.name] = blobs.StoredBlob(f.blob, f.size_bytes)
        else:
            files[f.name] = blobs.blob_path(f, f.blob)
        sha[f.name] = f.sha256
    manifest = Manifest.model_validate(row.manifest, strict=False)
    i = arrays["imu"]
    q_imu = (row.quality or {}).get("imu") or {}
    imu = ImuData(
        t_s=i["t_s"],
        dtheta_rad=i["dtheta_rad"],
        dvel_mps=i["dvel_mps"],
        turntable_deg=i.get("turntable_deg"),
        bridged_rows=int(q_imu.get("bridged_rows") or 0),
        # the gaps the reader bridged (the gravity chains carry the lost increments' uncertainty)
        bridges=[
            BridgedGap(int(r), int(k), float(a), float(b), bool(lost))
            for r, k, a, b, lost in q_imu.get("bridged_gaps", [])
        ],
    )
    ldv = None
    if "ldv" in arrays:
        d = arrays["ldv"]
        ldv = LdvData(
            t_s=d["t_s"],
            v_fwd_mps=d["v_fwd_mps"],
            v_up_mps=d.get("v_up_mps"),
            quality=d.get("quality"),
            fd_hz=d.get("fd_hz"),
            source="fd_hz" if "fd_hz" in d else "v_fwd",
        )
    gnss = None
    if "gnss" in arrays:
        g = arrays["gnss"]
        gnss = GnssData(
            t_s=g["t_s"],
            lat_deg=g["lat_deg"],
            lon_deg=g["lon_deg"],
            h_m=g["h_m"],
            fix=g["fix"],
            n_sat=g["n_sat"],
            hdop=g["hdop"],
            line_of_row=g["line"],
        )
    return DriveLog(
        manifest=manifest,
        imu=imu,
        ldv=ldv,
        gnss=gnss,
        files=files,
        warnings=list(row.quality.get("warnings", [])),
        file_sha256=sha,
    )
