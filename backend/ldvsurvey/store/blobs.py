"""Column dicts of numpy arrays to and from Parquet, and the blob folder of large log files.

Large originals and the Parquet arrays of a log do not go into database rows: a row holds the name
of a file in the *blob folder* (``<data_dir>/blobs``; for a SQLite database file, ``blobs`` beside
it). A database row is limited to 1 GB in SQLite and PostgreSQL alike and is copied through memory
on every read and write; a file is streamed, linked from the upload's temporary folder and read
column by column. The folder must be shared by every process that uses the database: with
PostgreSQL and separate API and worker containers, a shared volume at ``LDVSURVEY_DATA_DIR``
(``docker-compose.yml`` mounts ``appdata`` at ``/data`` in both).

Files are written before the rows that name them and fsynced; a transaction that rolls back removes
the files it wrote, and files of deleted rows are removed once the deletion is committed
(:func:`track_written`, :func:`unlink_after_commit`). A file is written as ``<name>.part`` under its
writer's lock and renamed once fsynced; a ``.part`` nobody holds was left by a process that died and
is removed by :mod:`ldvsurvey.store.leftovers`. Every file belongs to exactly one row (names
are random), so removing one never touches another log.
"""

from __future__ import annotations

import io
import os
import shutil
import uuid
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
from sqlalchemy import event
from sqlalchemy.engine import make_url
from sqlalchemy.orm import Session, object_session

from ldvsurvey.store.leftovers import hold

#: files smaller than this stay in their database row
INLINE_MAX_BYTES = 1 << 20
#: rows per Parquet row group (and per slice copied out of a strided array while writing)
ROW_GROUP = 1 << 20
#: lz4 over byte-stream-split floats: about as small as zstd here at twice its speed both ways;
#: no dictionary encoding (useless on measured values, and slow)
_PARQUET = {"compression": "lz4", "use_dictionary": False, "write_statistics": False}

_roots: dict[str, Path] = {}


def to_parquet(columns: dict[str, np.ndarray]) -> bytes:
    """Serialize equal-length 1-D arrays (None values are left out) to Parquet bytes."""
    buf = io.BytesIO()
    write_parquet(columns, buf)
    return buf.getvalue()


def write_parquet(columns: dict[str, np.ndarray], where) -> None:
    """Write equal-length 1-D arrays (None values left out) as Parquet to a path or binary file,
    one row group at a time (a strided column is copied one slice at a time, never whole)."""
    cols = {k: np.asarray(v) for k, v in columns.items() if v is not None}
    n = len(next(iter(cols.values()))) if cols else 0
    schema = pa.schema([(k, _ARROW[v.dtype.str[1:]]) for k, v in cols.items()])
    split = {k: "BYTE_STREAM_SPLIT" for k, v in cols.items() if v.dtype.kind == "f"}
    with pq.ParquetWriter(where, schema, column_encoding=split or None, **_PARQUET) as w:
        for a in range(0, max(n, 1), ROW_GROUP):
            w.write_table(pa.Table.from_arrays([_to_arrow(v[a : a + ROW_GROUP]) for v in cols.values()], schema=schema))


#: numpy dtype (without byte order) to Arrow type, for the columns a log stores
_ARROW = {
    "f8": pa.float64(),
    "f4": pa.float32(),
    "i8": pa.int64(),
    "i4": pa.int32(),
    "i2": pa.int16(),
    "i1": pa.int8(),
    "u8": pa.uint64(),
    "u4": pa.uint32(),
    "u2": pa.uint16(),
    "u1": pa.uint8(),
}


def _to_arrow(v: np.ndarray) -> pa.Array:
    """A numeric numpy array as an Arrow array over the same (contiguous) memory. Built from its
    buffer: ``pa.array`` would import pandas (a third of a second at every start)."""
    v = np.ascontiguousarray(v)
    return pa.Array.from_buffers(_ARROW[v.dtype.str[1:]], len(v), [None, pa.py_buffer(v)])


def _to_numpy(chunk: pa.Array) -> np.ndarray:
    """A null-free numeric Arrow array as a numpy view of its value buffer (no pandas import)."""
    dt = _NUMPY[str(chunk.type)]
    return np.frombuffer(chunk.buffers()[1], dtype=dt, count=len(chunk), offset=dt.itemsize * chunk.offset)


_NUMPY = {str(t): np.dtype(k) for k, t in _ARROW.items()}


def from_parquet(data: bytes | Path) -> dict[str, np.ndarray]:
    """Inverse of :func:`to_parquet` (Parquet bytes or a file path)."""
    return read_parquet_into(data)


def read_parquet_into(data: bytes | Path, stacks: dict[str, list[str]] | None = None) -> dict[str, np.ndarray]:
    """Columns of a Parquet blob or file, read one row group at a time into preallocated arrays;
    ``stacks`` names (N, k) arrays to fill from k columns (``{"dtheta_rad": [x, y, z]}``), so a
    stacked array costs no second copy. Returns the plain columns and the stacks by name."""
    pf = pq.ParquetFile(io.BytesIO(data) if isinstance(data, (bytes, bytearray, memoryview)) else str(data))
    n = pf.metadata.num_rows
    names = pf.schema_arrow.names
    stacks = {k: v for k, v in (stacks or {}).items() if all(c in names for c in v)}
    out: dict[str, np.ndarray] = {}
    dest: dict[str, np.ndarray] = {}
    for k, cols in stacks.items():
        out[k] = np.empty((n, len(cols)), dtype=np.float64)
        for j, c in enumerate(cols):
            dest[c] = out[k][:, j]
    for c in names:
        if c not in dest:
            out[c] = dest[c] = np.empty(n, dtype=_NUMPY[str(pf.schema_arrow.field(c).type)])
    at = 0
    for i in range(pf.num_row_groups):
        t = pf.read_row_group(i, use_threads=True)
        m = t.num_rows
        for c in names:
            k = at
            for chunk in t.column(c).chunks:
                dest[c][k : k + len(chunk)] = _to_numpy(chunk)
                k += len(chunk)
        at += m
        del t
    return out


def register_root(database_url: str, folder: str | Path) -> None:
    """Use ``folder`` as the blob folder of the database at ``database_url`` in this process."""
    _roots[database_url] = Path(folder)


def root_for(session: Session) -> Path | None:
    """The blob folder of the session's database (see :func:`root_for_url`)."""
    return root_for_url(session.get_bind().url)


def root_for_url(url) -> Path | None:
    """The blob folder of the database at ``url``: registered, else ``blobs`` beside a SQLite file,
    else ``<LDVSURVEY_DATA_DIR>/blobs``; None for an in-memory SQLite database (all in rows)."""
    url = make_url(url) if isinstance(url, str) else url
    key = url.render_as_string(hide_password=False)
    if key in _roots:
        return _roots[key]
    if url.get_backend_name() == "sqlite":
        db = url.database
        if not db or db == ":memory:" or db.startswith("file:"):
            return None
        return Path(db).resolve().parent / "blobs"
    from ldvsurvey.settings import get_settings

    return Path(get_settings().data_dir).resolve() / "blobs"


def blob_path(row, key: str) -> Path:
    """The file of blob ``key`` named by a row bound to a session."""
    session = object_session(row)
    root = root_for(session) if session is not None else None
    if root is None:
        raise RuntimeError(f"blob '{key}' has no blob folder (the row is not bound to a session)")
    path = root / key
    if not path.is_file():  # say where it was looked for: the usual cause is a folder not shared
        raise FileNotFoundError(
            f"stored file {path} is missing: every API and worker process must see the same "
            "blob folder (LDVSURVEY_DATA_DIR on a shared volume)"
        )
    return path


def _new_key(suffix: str) -> str:
    u = uuid.uuid4().hex
    return f"{u[:2]}/{u}{suffix}"


def _fsync(path: Path) -> None:
    fd = os.open(path, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


class Writer:
    """Writes the blobs of one store operation; each file is fsynced in a background thread while
    the next is written, and :meth:`done` waits for all (call it before the rows are flushed)."""

    def __init__(self, session: Session, root: Path):
        from concurrent.futures import ThreadPoolExecutor

        self.session, self.root = session, root
        self._pool = ThreadPoolExecutor(max_workers=2, thread_name_prefix="ldvs-fsync")
        self._pending = []

    def _target(self, suffix: str) -> tuple[str, Path, Path]:
        key = _new_key(suffix)
        dst = self.root / key
        dst.parent.mkdir(parents=True, exist_ok=True)
        track_written(self.session, dst)
        return key, dst, dst.with_name(dst.name + ".part")

    def _finish(self, tmp: Path, dst: Path, fh) -> None:
        """fsync and rename in the background; ``fh`` holds the ``.part``'s lock until renamed (a
        ``.part`` nobody holds was left by a stopped process: :mod:`ldvsurvey.store.leftovers`)."""

        def sync():
            try:
                _fsync(tmp)
                os.replace(tmp, dst)
            finally:
                fh.close()

        self._pending.append(self._pool.submit(sync))

    @staticmethod
    def _locked_part(tmp: Path):
        """A new ``.part`` file, created under this process's lock (no moment without it)."""
        fh = open(tmp, "xb")
        try:
            hold(fh.fileno())
        except BaseException:
            fh.close()
            raise
        return fh

    def file(self, src: Path | bytes, suffix: str = "", link: bool = False) -> str:
        """Store a file's bytes as a new blob; a path is copied, or hard-linked when ``link`` (only
        for a temporary file nobody else writes to) and the file system allows it."""
        key, dst, tmp = self._target(suffix)
        fh = None
        try:
            if isinstance(src, (bytes, bytearray, memoryview)):
                fh = self._locked_part(tmp)
                fh.write(src)
                fh.flush()
            else:
                if link:
                    try:  # the upload's temporary file on the same file system: no copy. Locked
                        # first (the lock is the file's, so the link is born locked)
                        fh = open(src, "rb")
                        hold(fh.fileno())
                        os.link(src, tmp)
                    except OSError:
                        if fh is not None:
                            fh.close()
                            fh = None
                if fh is None:
                    fh = self._locked_part(tmp)
                    shutil.copyfile(src, tmp)  # same file (inode): the lock stays
        except BaseException:
            if fh is not None:
                fh.close()
            raise
        self._finish(tmp, dst, fh)
        return key

    def parquet(self, columns: dict[str, np.ndarray]) -> str:
        """Store columns as a new Parquet blob."""
        key, dst, tmp = self._target(".parquet")
        fh = self._locked_part(tmp)
        try:
            write_parquet(columns, str(tmp))
        except BaseException:
            fh.close()
            raise
        self._finish(tmp, dst, fh)
        return key

    def done(self) -> None:
        try:
            for f in self._pending:
                f.result()
        finally:
            self._pool.shutdown(wait=True)


def track_written(session: Session, path: Path) -> None:
    """Remove ``path`` if the session's transaction rolls back; keep it once committed."""
    session.info.setdefault("ldvs_blobs_written", []).append(path)


def unlink_after_commit(session: Session, paths: list[Path]) -> None:
    """Remove ``paths`` once the session's transaction commits (kept if it rolls back)."""
    session.info.setdefault("ldvs_blobs_unlink", []).extend(paths)


def _remove(paths) -> None:
    for p in paths:
        for q in (p, p.with_name(p.name + ".part")):
            try:
                q.unlink()
            except FileNotFoundError:
                pass
            except OSError:  # a file left behind is garbage, never a wrong answer
                pass


@event.listens_for(Session, "after_commit")
def _after_commit(session: Session) -> None:
    session.info.pop("ldvs_blobs_written", None)
    _remove(session.info.pop("ldvs_blobs_unlink", []))


@event.listens_for(Session, "after_transaction_end")
def _after_transaction_end(session: Session, transaction) -> None:
    if transaction.parent is not None or transaction.nested:  # the outer transaction decides
        return
    # what is left was not committed (rolled back or closed): its new files go, deleted ones stay
    session.info.pop("ldvs_blobs_unlink", None)
    _remove(session.info.pop("ldvs_blobs_written", []))
