"""What a process killed mid-write leaves on disk, and its removal.

Two kinds of leftovers: the *staging folder* of an upload (``<data_dir>/tmp/ldvs-bundle-*``, the
inflated members, see :class:`ldvsurvey.io.drivelog.BundleFiles`) and a ``.part`` file of the blob
folder (a blob being written, renamed to its final name once fsynced, see
:class:`ldvsurvey.store.blobs.Writer`). The process writing either holds an exclusive ``flock`` on it
(the folder's ``.lock`` file, the ``.part`` file itself) for as long as it writes; the kernel drops the
lock when the process dies, even by ``kill -9``. So a leftover is one whose lock is free: no guess by
age about whether its writer is still alive, and several API and worker processes sharing the data
folder never remove each other's work. One that carries no lock yet (created a moment ago, before the
lock was taken, or by an older version) is removed only once older than :data:`GRACE_S`, a ``.part``
nobody holds once older than :data:`PART_GRACE_S`. A third kind, with SQLite: complete blob files no
row names, written by a process killed before its commit, removed once older than
:data:`UNREFERENCED_GRACE_S` (:func:`remove_unreferenced`).

The server cleans at start and every ``LDVSURVEY_CLEAN_EVERY_S`` (:func:`clean_leftovers`), logs what
it removed, and ``GET /api/admin/storage`` and ``ldv-survey clean`` report it; leftovers are never
counted as stored data (:func:`stored_bytes` sums the stored logs' files only).
"""

from __future__ import annotations

import fcntl
import logging
import os
import shutil
import threading
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path

from ldvsurvey.io.drivelog import FOLDER_LOCK

#: a staging folder without a lock is left alone while younger than this (s)
GRACE_S = 60.0
#: a ``.part`` file nobody holds is left alone while younger than this (s): it is created a moment
#: before its writer takes the lock
PART_GRACE_S = 5.0
#: a complete blob file that no row names is left alone while younger than this (s): its rows may
#: be in a transaction not yet committed
UNREFERENCED_GRACE_S = 3600.0
STAGING_GLOB = "ldvs-bundle-*"

log = logging.getLogger("ldvsurvey.leftovers")


def hold(fd: int) -> None:
    """Take the exclusive lock that marks a file as being written by this process (kept until the
    descriptor is closed or the process ends)."""
    fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)


def _held(path: Path) -> bool | None:
    """Whether a live process holds the lock on ``path`` (None: the file does not exist)."""
    try:
        fd = os.open(path, os.O_RDONLY | os.O_CLOEXEC)
    except FileNotFoundError:
        return None
    except OSError:
        return True  # unreadable: not ours to judge
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except BlockingIOError:
        return True
    except OSError:
        return True
    else:
        fcntl.flock(fd, fcntl.LOCK_UN)
        return False
    finally:
        os.close(fd)


def _size(path: Path) -> int:
    if path.is_dir():
        return sum(p.lstat().st_size for p in path.rglob("*") if p.is_file())
    return path.lstat().st_size


@dataclass
class Leftovers:
    """Counts and bytes of staging folders and ``.part`` blobs (removed, or found in progress)."""

    staging_folders: int = 0
    part_blobs: int = 0
    #: complete blob files no row names (written, then the process died before its commit)
    unreferenced_blobs: int = 0
    bytes: int = 0
    paths: list[str] = field(default_factory=list, repr=False)

    def message(self, verb: str = "removed") -> str:
        """One line for the log: ``verb`` (e.g. removed) with the counts and the size in MB."""
        extra = (
            f", {self.unreferenced_blobs} blob{'s' * (self.unreferenced_blobs != 1)} no row names"
            if self.unreferenced_blobs
            else ""
        )
        return (
            f"{verb} {self.staging_folders} staging folder{'s' * (self.staging_folders != 1)} and "
            f"{self.part_blobs} .part blob{'s' * (self.part_blobs != 1)}{extra} "
            f"({self.bytes / 1e6:.1f} MB)"
        )

    def as_dict(self) -> dict:
        """The counts and bytes as a dict (without the paths)."""
        d = asdict(self)
        d.pop("paths")
        return d


def _orphan(path: Path, lock: Path, now: float, grace_s: float, free_lock_suffices: bool) -> bool:
    """Nobody holds ``lock``, and it is missing or not proof enough (a ``.part`` is its own lock,
    unlocked for a moment after its creation) and ``path`` is older than ``grace_s``."""
    held = _held(lock)
    if held:
        return False
    if held is None or not free_lock_suffices:
        try:
            return now - path.lstat().st_mtime > grace_s
        except FileNotFoundError:
            return False
    return True


def scan(tmp_dir: Path | None, blob_root: Path | None, remove: bool) -> tuple[Leftovers, Leftovers]:
    """What stopped uploads left under the staging folder and the blob folder, and what is in progress.

    A staging folder or ``.part`` blob is a leftover when no process holds its lock and it is older
    than its grace period.

    Parameters
    ----------
    tmp_dir : Path or None
        The staging folder (``<data_dir>/tmp``).
    blob_root : Path or None
        The blob folder (None with blobs in the database).
    remove : bool
        Remove the leftovers (else only count them).

    Returns
    -------
    Leftovers
        The leftovers (removed when ``remove``), with their bytes and paths.
    Leftovers
        Those in progress (locked by a live process or within their grace period).
    """
    now = time.time()
    gone, busy = Leftovers(), Leftovers()
    if tmp_dir is not None and tmp_dir.is_dir():
        for d in sorted(tmp_dir.glob(STAGING_GLOB)):
            if not d.is_dir():
                continue
            try:
                size = _size(d)
            except OSError:
                size = 0
            if _orphan(d, d / FOLDER_LOCK, now, GRACE_S, True):
                if remove:
                    shutil.rmtree(d, ignore_errors=True)
                    if d.exists():
                        continue
                gone.staging_folders += 1
                gone.bytes += size
                gone.paths.append(str(d))
            else:
                busy.staging_folders += 1
                busy.bytes += size
    if blob_root is not None and blob_root.is_dir():
        for p in sorted(blob_root.glob("*/*.part")):
            try:
                size = p.lstat().st_size
            except FileNotFoundError:
                continue
            if _orphan(p, p, now, PART_GRACE_S, False):
                if remove:
                    try:
                        p.unlink()
                    except FileNotFoundError:
                        continue
                    except OSError:
                        continue
                gone.part_blobs += 1
                gone.bytes += size
                gone.paths.append(str(p))
            else:
                busy.part_blobs += 1
                busy.bytes += size
    return gone, busy


def folders_of(settings) -> tuple[Path, Path | None]:
    """The staging folder (``<data_dir>/tmp``) and the blob folder of the settings' database."""
    from ldvsurvey.store.blobs import root_for_url

    return Path(settings.data_dir) / "tmp", root_for_url(settings.resolved_database_url())


class Report:
    """What this process removed since it started, for ``GET /api/admin/storage``."""

    def __init__(self):
        self._lock = threading.Lock()
        self.total = Leftovers()
        self.last_at: float | None = None

    def add(self, gone: Leftovers) -> None:
        """Add what one clean-up removed to the totals and note when (Unix s)."""
        with self._lock:
            self.total.staging_folders += gone.staging_folders
            self.total.part_blobs += gone.part_blobs
            self.total.unreferenced_blobs += gone.unreferenced_blobs
            self.total.bytes += gone.bytes
            self.last_at = time.time()


def remove_unreferenced(database_url: str, root: Path | None, gone: Leftovers) -> None:
    """SQLite: remove the blob files beside the database that no row names, once older than
    :data:`UNREFERENCED_GRACE_S` (a process killed after writing a log's files, before its commit).
    Only there: that folder belongs to that database file alone (an older PostgreSQL installation's
    folder may be shared, and is emptied by ``ldv-survey blobs migrate`` instead)."""
    from sqlalchemy import select
    from sqlalchemy.engine import make_url

    from ldvsurvey.store.db import session_scope
    from ldvsurvey.store.models import LogArray, LogFile

    if root is None or not root.is_dir() or make_url(database_url).get_backend_name() != "sqlite":
        return
    now = time.time()
    old = []
    for p in root.glob("*/*"):  # listed before the rows are read: a blob committed meanwhile is kept
        try:
            st = p.lstat()
        except FileNotFoundError:
            continue
        if p.is_file() and not p.name.endswith(".part") and now - st.st_mtime > UNREFERENCED_GRACE_S:
            old.append((p, st.st_size))
    if not old:
        return
    with session_scope(database_url) as s:
        named = {k for t in (LogFile, LogArray) for k in s.scalars(select(t.blob).where(t.blob.is_not(None)))}
    for p, size in old:
        if p.relative_to(root).as_posix() not in named:
            try:
                p.unlink()
            except OSError:
                continue
            gone.unreferenced_blobs += 1
            gone.bytes += size
            gone.paths.append(str(p))


def clean_leftovers(settings, report: Report | None = None) -> Leftovers:
    """Remove the leftovers of stopped processes under the settings' data and blob folders; log a
    line naming what went (nothing when there was nothing)."""
    tmp_dir, root = folders_of(settings)
    gone, _ = scan(tmp_dir, root, remove=True)
    remove_unreferenced(settings.resolved_database_url(), root, gone)
    if gone.staging_folders or gone.part_blobs or gone.unreferenced_blobs:
        log.warning("%s left by a stopped process (killed mid-upload): %s", gone.message(), ", ".join(gone.paths))
    if report is not None:
        report.add(gone)
    return gone


def stored_bytes(database_url: str) -> int:
    """Bytes of the stored logs' original files (the data; leftovers and Parquet copies not counted)."""
    from sqlalchemy import func, select

    from ldvsurvey.store.db import session_scope
    from ldvsurvey.store.models import Log

    with session_scope(database_url) as s:
        return int(s.scalar(select(func.coalesce(func.sum(Log.size_bytes), 0))))
