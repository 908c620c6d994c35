"""``ldv-survey backup DIR`` and ``ldv-survey restore DIR``: the database and the blobs of the stored
logs, taken consistently while the server runs, every file verified by SHA-256 on restore.

SQLite: the database is copied with SQLite's online backup (a snapshot of one moment, the server
may go on writing), then every blob the snapshot names is copied from the blob folder and hashed on
the way. Blobs never change once written (random names, one row each), so the snapshot and its
blobs agree; a log deleted while the blobs are copied loses its files, and is then left out of the
backup as if deleted a moment before the snapshot (named in the output). PostgreSQL:
``pg_dump --format=custom`` (one transaction, a consistent snapshot; the blobs are rows of
``blob_chunks``); blobs still in an older folder must first be moved in (``ldv-survey blobs migrate``).

``DIR/backup.json`` lists every file of the backup with its size and SHA-256. ``restore`` checks
them all before it touches anything, then writes the blobs and replaces the database in one
rename (SQLite) or loads the dump into an empty database (``pg_restore``), and migrates to the
newest schema.
"""

from __future__ import annotations

import datetime as dt
import hashlib
import json
import os
import shutil
import sqlite3
import subprocess
from collections.abc import Callable
from pathlib import Path

from sqlalchemy.engine import make_url

from ldvsurvey import __version__
from ldvsurvey.errors import InputError

FORMAT = "ldv-survey-backup/1"
MANIFEST = "backup.json"
PIECE = 1 << 22


class BackupError(InputError):
    """A backup folder that cannot be restored (missing, altered, not a backup) or cannot be written."""


def _copy_hashed(src: Path, dst: Path) -> tuple[int, str]:
    """Copy ``src`` to ``dst`` (fsynced), returning (size, SHA-256) of what was written."""
    h = hashlib.sha256()
    n = 0
    dst.parent.mkdir(parents=True, exist_ok=True)
    with open(src, "rb") as fi, open(dst, "wb") as fo:
        while piece := fi.read(PIECE):
            h.update(piece)
            fo.write(piece)
            n += len(piece)
        fo.flush()
        os.fsync(fo.fileno())
    return n, h.hexdigest()


def _hash(path: Path) -> tuple[int, str]:
    h = hashlib.sha256()
    n = 0
    with open(path, "rb") as fh:
        while piece := fh.read(PIECE):
            h.update(piece)
            n += len(piece)
    return n, h.hexdigest()


def _sqlite_path(url: str) -> Path:
    return Path(make_url(url).database).resolve()


def _prepare_dir(out: Path) -> None:
    if out.exists() and any(out.iterdir()):
        raise BackupError(f"backup folder {out} is not empty: give a new or empty folder", file=str(out))
    out.mkdir(parents=True, exist_ok=True)


def backup(database_url: str, out: Path, *, say: Callable[[str], None] = print) -> dict:
    """Write a backup of the database at ``database_url`` (and its blobs) into the new folder ``out``.
    Returns the manifest written to ``out/backup.json``."""
    out = Path(out)
    _prepare_dir(out)
    try:
        if make_url(database_url).get_backend_name() == "sqlite":
            manifest = _backup_sqlite(database_url, out, say)
        else:
            manifest = _backup_postgres(database_url, out, say)
        tmp = out / (MANIFEST + ".part")
        tmp.write_text(json.dumps(manifest, indent=1, sort_keys=True))
        os.replace(tmp, out / MANIFEST)  # written last: a folder without it is no (complete) backup
    except BaseException:  # nothing of a failed backup stays (the folder was empty)
        shutil.rmtree(out, ignore_errors=True)
        out.mkdir(parents=True, exist_ok=True)
        raise
    return manifest


def _header(engine: str) -> dict:
    return {
        "format": FORMAT,
        "engine": engine,
        "ldv_survey_version": __version__,
        "created_at": dt.datetime.now(dt.UTC).isoformat(timespec="seconds"),
    }


def _backup_sqlite(database_url: str, out: Path, say) -> dict:
    from ldvsurvey.store.blobs import DB_PREFIX, root_for_url

    src_path = _sqlite_path(database_url)
    if not src_path.is_file():
        raise BackupError(f"no database at {src_path}", file=str(src_path))
    db_out = out / "ldvsurvey.db"
    src = sqlite3.connect(src_path, timeout=30)
    dst = sqlite3.connect(db_out)
    try:
        # SQLite's online backup in one step: a snapshot of one moment (under WAL the server's
        # writers go on meanwhile; in steps, every write in between would restart the copy)
        src.backup(dst, pages=-1)
    finally:
        src.close()
    root = root_for_url(database_url)
    blobs: dict[str, dict] = {}
    dropped: list[int] = []
    try:
        rows = dst.execute(
            "SELECT log_id, blob FROM log_files WHERE blob IS NOT NULL "
            "UNION ALL SELECT log_id, blob FROM log_arrays WHERE blob IS NOT NULL ORDER BY 1"
        ).fetchall()
        for log_id, key in rows:
            if log_id in dropped:
                continue
            if key.startswith(DB_PREFIX):  # chunks inside the database file: already in the snapshot
                continue
            try:
                size, sha = _copy_hashed(root / key, out / "blobs" / key)
            except FileNotFoundError:
                if _log_exists(database_url, log_id):
                    raise BackupError(
                        f"stored file {root / key} of log {log_id} is missing from the blob folder "
                        "(the store is damaged: restore that log from an older backup)",
                        file=str(root / key),
                    ) from None
                dropped.append(log_id)  # deleted since the snapshot: left out, as if deleted before
                continue
            blobs[key] = {"size": size, "sha256": sha}
        for log_id in dropped:
            _drop_log(dst, log_id)
            say(f"log {log_id} was deleted while the backup ran: left out")
        if dropped:  # its files copied before the deletion are not part of the backup
            keep = {r[0] for r in dst.execute("SELECT blob FROM log_files UNION SELECT blob FROM log_arrays")}
            for key in [k for k in blobs if k not in keep]:
                (out / "blobs" / key).unlink()
                del blobs[key]
        dst.commit()
        dst.execute("VACUUM")
    finally:
        dst.close()
    size, sha = _hash(db_out)
    counts = _counts_sqlite(db_out)
    say(
        f"backed up {counts['logs']} logs, {counts['jobs']} jobs and {len(blobs)} blobs "
        f"({(size + sum(b['size'] for b in blobs.values())) / 1e6:.1f} MB) into {out}"
    )
    return {
        **_header("sqlite"),
        "database": {"file": "ldvsurvey.db", "size": size, "sha256": sha},
        "blobs": blobs,
        "counts": counts,
    }


def _log_exists(database_url: str, log_id: int) -> bool:
    c = sqlite3.connect(f"file:{_sqlite_path(database_url)}?mode=ro", uri=True, timeout=30)
    try:
        return c.execute("SELECT 1 FROM logs WHERE id = ?", (log_id,)).fetchone() is not None
    finally:
        c.close()


def _drop_log(conn: sqlite3.Connection, log_id: int) -> None:
    """Remove a log from the backup's database as ``store.logs.delete_log`` does (its jobs too)."""
    jobs = [j for j, ids in conn.execute("SELECT id, log_ids FROM jobs") if log_id in json.loads(ids or "[]")]
    for j in jobs:
        conn.execute("DELETE FROM job_files WHERE job_id = ?", (j,))
        conn.execute("DELETE FROM jobs WHERE id = ?", (j,))
    for t in ("log_arrays", "log_files"):
        conn.execute(f"DELETE FROM {t} WHERE log_id = ?", (log_id,))
    conn.execute("DELETE FROM logs WHERE id = ?", (log_id,))


def _counts_sqlite(path: Path) -> dict:
    c = sqlite3.connect(path)
    try:
        return {t: c.execute(f"SELECT count(*) FROM {t}").fetchone()[0] for t in ("logs", "jobs", "users")}
    finally:
        c.close()


def _libpq_url(database_url: str) -> str:
    return make_url(database_url).set(drivername="postgresql").render_as_string(hide_password=False)


def _backup_postgres(database_url: str, out: Path, say) -> dict:
    from sqlalchemy import func, select

    from ldvsurvey.store.db import session_scope
    from ldvsurvey.store.models import Job, Log, LogArray, LogFile

    with session_scope(database_url) as s:
        in_folder = sum(
            s.scalar(select(func.count()).select_from(t).where(t.blob.is_not(None), ~t.blob.startswith("db:")))
            for t in (LogFile, LogArray)
        )
        counts = {t.__tablename__: s.scalar(select(func.count()).select_from(t)) for t in (Log, Job)}
    if in_folder:
        raise BackupError(
            f"{in_folder} blobs are still in the blob folder: move them into the database first "
            "(ldv-survey blobs migrate), then back up"
        )
    exe = shutil.which("pg_dump")
    if exe is None:
        raise BackupError("pg_dump is not installed (Debian: apt-get install postgresql-client)")
    dump = out / "database.pgdump"
    r = subprocess.run(
        [exe, "--format=custom", "--no-owner", "--file", str(dump), "--dbname", _libpq_url(database_url)],
        capture_output=True,
        text=True,
    )
    if r.returncode != 0:
        raise BackupError(f"pg_dump failed: {r.stderr.strip()[:500]}")
    size, sha = _hash(dump)
    say(f"backed up {counts['logs']} logs and {counts['jobs']} jobs ({size / 1e6:.1f} MB, pg_dump) into {out}")
    return {
        **_header("postgresql"),
        "database": {"file": "database.pgdump", "size": size, "sha256": sha},
        "blobs": {},
        "counts": counts,
    }


def _read_manifest(src: Path) -> dict:
    path = src / MANIFEST
    try:
        m = json.loads(path.read_text())
    except FileNotFoundError:
        raise BackupError(f"{path} is missing: not a complete ldv-survey backup", file=str(path)) from None
    except (OSError, ValueError) as exc:
        raise BackupError(f"{path} cannot be read: {exc}", file=str(path)) from None
    if not isinstance(m, dict) or m.get("format") != FORMAT:
        raise BackupError(f"not an {FORMAT} backup", file=str(path), field="format")
    return m


def verify(src: Path) -> dict:
    """Check every file of a backup against its size and SHA-256 in ``backup.json``; returns the
    manifest. Raises :class:`BackupError` naming the first file that is missing or differs."""
    src = Path(src)
    m = _read_manifest(src)
    files = [(m["database"]["file"], m["database"])] + [(f"blobs/{k}", v) for k, v in m["blobs"].items()]
    for rel, want in files:
        p = src / rel
        if ".." in Path(rel).parts or Path(rel).is_absolute():
            raise BackupError(f"unsafe path in the backup: '{rel}'", file=str(src / MANIFEST), field=rel)
        try:
            size, sha = _hash(p)
        except FileNotFoundError:
            raise BackupError(f"{p} is missing from the backup", file=str(p)) from None
        if (size, sha) != (want["size"], want["sha256"]):
            raise BackupError(
                f"{p} differs from the backup's record: SHA-256 {sha} ({size} bytes), "
                f"recorded {want['sha256']} ({want['size']} bytes)",
                file=str(p),
                field="sha256",
            )
    return m


def restore(database_url: str, src: Path, *, force: bool = False, say: Callable[[str], None] = print) -> dict:
    """Restore the backup in ``src`` into the database at ``database_url``; stop the server first.

    Every file is verified by size and SHA-256 first; the schema is brought to this version's
    (``upgrade head``) and jobs that were queued or running at backup time are marked failed.

    Parameters
    ----------
    database_url : str
        The target database (of the same engine as the backup's).
    src : Path
        The backup folder (``backup.json`` with the files it names).
    force : bool
        Replace a database that already holds data (refused otherwise).
    say : callable
        Receives one line per step (default: print).

    Returns
    -------
    dict
        The backup's manifest.

    Raises
    ------
    BackupError
        Naming the file: a file missing or differing, another engine, a target holding data without
        ``force``.
    """
    src = Path(src)
    m = verify(src)
    engine = make_url(database_url).get_backend_name()
    if m["engine"] != engine:
        raise BackupError(
            f"this backup is of a {m['engine']} database; the target is {engine}", file=str(src / MANIFEST)
        )
    if engine == "sqlite":
        _restore_sqlite(database_url, src, m, force)
    else:
        _restore_postgres(database_url, src, m, force)
    from ldvsurvey.store.db import dispose_engines, upgrade_head

    dispose_engines()
    upgrade_head(database_url)  # a backup of an older version: brought to this version's schema
    interrupted = _fail_unfinished_jobs(database_url)
    if interrupted:
        say(f"{interrupted} jobs queued or running at backup time marked failed (retry them)")
    c = m.get("counts", {})
    say(
        f"restored {c.get('logs', '?')} logs and {c.get('jobs', '?')} jobs, {len(m['blobs'])} blobs verified "
        f"by SHA-256, from {src}"
    )
    return m


def _fail_unfinished_jobs(database_url: str) -> int:
    """Jobs queued or running in the backup: their queue was not backed up, so they would wait
    forever; marked failed with the reason, their owners may retry them."""
    from sqlalchemy import update

    from ldvsurvey.store.db import session_scope
    from ldvsurvey.store.models import Job

    with session_scope(database_url) as s:
        r = s.execute(
            update(Job)
            .where(Job.status.in_(("queued", "running")))
            .values(
                status="failed",
                stage="failed",
                error="interrupted by a restore from a backup: retry the job",
                finished_at=dt.datetime.now(dt.UTC),
            )
        )
        return r.rowcount


def _has_data_sqlite(path: Path) -> bool:
    if not path.exists():
        return False
    c = sqlite3.connect(f"file:{path}?mode=ro", uri=True)
    try:
        tables = {r[0] for r in c.execute("SELECT name FROM sqlite_master WHERE type='table'")}
        return any(c.execute(f"SELECT 1 FROM {t} LIMIT 1").fetchone() for t in ("logs", "users") if t in tables)
    finally:
        c.close()


def _restore_sqlite(database_url: str, src: Path, m: dict, force: bool) -> None:
    from ldvsurvey.store.blobs import root_for_url

    target = _sqlite_path(database_url)
    if _has_data_sqlite(target) and not force:
        raise BackupError(
            f"{target} already holds data: stop the server and add --force to replace it", file=str(target)
        )
    target.parent.mkdir(parents=True, exist_ok=True)
    root = root_for_url(database_url)
    for key, want in m["blobs"].items():  # blobs first: the database that names them comes last
        dst = root / key
        if dst.is_file() and _hash(dst) == (want["size"], want["sha256"]):
            continue
        tmp = dst.with_name(dst.name + ".part")
        size, sha = _copy_hashed(src / "blobs" / key, tmp)
        if (size, sha) != (want["size"], want["sha256"]):
            tmp.unlink()
            raise BackupError(f"{src / 'blobs' / key} changed while being restored", file=str(src / "blobs" / key))
        os.replace(tmp, dst)
    tmp = target.with_name(target.name + ".restoring")
    size, sha = _copy_hashed(src / m["database"]["file"], tmp)
    if (size, sha) != (m["database"]["size"], m["database"]["sha256"]):
        tmp.unlink()
        raise BackupError("the backup's database changed while being restored", file=str(src))
    for suffix in ("-wal", "-shm"):  # the replaced database's journal must not be replayed into it
        target.with_name(target.name + suffix).unlink(missing_ok=True)
    os.replace(tmp, target)
    _prune(root, set(m["blobs"]))


def _prune(root: Path, keep: set[str]) -> None:
    """Remove the blob files of a replaced database (named by no row of the restored one)."""
    if not root.is_dir():
        return
    for p in root.glob("*/*"):
        key = p.relative_to(root).as_posix()
        if p.is_file() and key not in keep and not p.name.startswith("."):
            p.unlink()


def _restore_postgres(database_url: str, src: Path, m: dict, force: bool) -> None:
    from sqlalchemy import inspect

    from ldvsurvey.store.db import get_engine

    tables = set(inspect(get_engine(database_url)).get_table_names())
    if tables and not force:
        raise BackupError(
            "the target database is not empty: restore into a new database (createdb), or stop the "
            "servers and add --force to replace its tables"
        )
    exe = shutil.which("pg_restore")
    if exe is None:
        raise BackupError("pg_restore is not installed (Debian: apt-get install postgresql-client)")
    from ldvsurvey.store.db import dispose_engines

    dispose_engines()
    r = subprocess.run(
        [
            exe,
            "--clean",
            "--if-exists",
            "--no-owner",
            "--single-transaction",
            "--exit-on-error",
            "--dbname",
            _libpq_url(database_url),
            str(src / m["database"]["file"]),
        ],
        capture_output=True,
        text=True,
    )
    if r.returncode != 0:
        raise BackupError(f"pg_restore failed: {r.stderr.strip()[:500]}")
