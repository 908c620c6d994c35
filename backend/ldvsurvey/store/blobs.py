"""Column dicts of numpy arrays to and from Parquet, and where the large files of a log live.

Large originals and the Parquet arrays of a log do not go into their own database rows (a row is
limited to 1 GB in SQLite and PostgreSQL alike and is copied through memory on every read and
write). A row names a *blob* by its key instead, which lives

- with SQLite, in the *blob folder* (``blobs`` beside the database file): a file streamed, linked
  from the upload's temporary folder and read column by column;
- with PostgreSQL (any other database), in the database itself: the key is ``db:…`` and the bytes
  are the 1-MiB rows of ``blob_chunks`` (:class:`~ldvsurvey.store.models.BlobChunk`), written and
  read a chunk at a time (never whole in memory), in the transaction of the rows that name them. So
  API and workers share nothing but the database: workers may run on other machines. Keys of an
  older folder (``<LDVSURVEY_DATA_DIR>/blobs``) stay readable there until ``ldv-survey blobs
  migrate`` moves them in (:func:`migrate_to_database`).

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
import threading
import uuid
from collections.abc import Iterator
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


def from_parquet(data) -> dict[str, np.ndarray]:
    """Inverse of :func:`to_parquet` (Parquet bytes or a file path)."""
    return read_parquet_into(data)


def read_parquet_into(data, stacks: dict[str, list[str]] | None = None) -> dict[str, np.ndarray]:
    """Columns of Parquet bytes, file path or open binary file, read one row group at a time into preallocated arrays;
    ``stacks`` names (N, k) arrays to fill from k columns (``{"dtheta_rad": [x, y, z]}``), so a
    stacked array costs no second copy. Returns the plain columns and the stacks by name."""
    if isinstance(data, (bytes, bytearray, memoryview)):
        pf = pq.ParquetFile(io.BytesIO(data))
    elif hasattr(data, "read"):  # an open blob (the database's chunks)
        pf = pq.ParquetFile(data)
    else:
        pf = pq.ParquetFile(str(data))
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
            "blob folder (LDVSURVEY_DATA_DIR on a shared volume), or, with PostgreSQL, the blobs "
            "moved into the database (ldv-survey blobs migrate)"
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
        """Wait until every file handed to the writer's threads is written (re-raising their first error) and stop the
        threads."""
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


# --- blobs in the database (PostgreSQL) ---------------------------------------------------------

#: key prefix of a blob kept in the database (``blob_chunks``); folder keys never hold a colon
DB_PREFIX = "db:"
#: bytes per row of ``blob_chunks``
CHUNK_BYTES = 1 << 20


def in_database(session: Session) -> bool:
    """Whether new blobs of this session's database go into the database (all but SQLite)."""
    return session.get_bind().dialect.name != "sqlite"


def writer_for(session: Session):
    """The writer of new blobs for this session's database: :class:`DbWriter` (PostgreSQL),
    :class:`Writer` on the blob folder (SQLite file), None (in-memory SQLite: all in rows)."""
    if in_database(session):
        return DbWriter(session)
    root = root_for(session)
    return Writer(session, root) if root is not None else None


def _chunks_table():
    from ldvsurvey.store.models import BlobChunk

    return BlobChunk.__table__


class _ChunkSink(io.RawIOBase):
    """A write-only file whose bytes become consecutive ``blob_chunks`` rows of one key (at most one
    chunk held in memory)."""

    def __init__(self, conn, key: str):
        super().__init__()
        self.conn, self.key, self.seq, self.pos = conn, key, 0, 0
        self.buf = bytearray()
        self.table = _chunks_table()

    def writable(self) -> bool:
        return True

    def tell(self) -> int:
        return self.pos

    def write(self, b) -> int:
        mv = memoryview(b).cast("B")
        n = len(mv)
        self.pos += n
        while len(mv):
            take = min(CHUNK_BYTES - len(self.buf), len(mv))
            self.buf += mv[:take]
            mv = mv[take:]
            if len(self.buf) == CHUNK_BYTES:
                self._flush_chunk()
        return n

    def _flush_chunk(self) -> None:
        self.conn.execute(self.table.insert(), {"key": self.key, "seq": self.seq, "data": bytes(self.buf)})
        self.seq += 1
        self.buf.clear()

    def close(self) -> None:
        if not self.closed:
            if self.buf or self.seq == 0:  # an empty blob still has its one (empty) chunk
                self._flush_chunk()
        super().close()


class DbWriter:
    """Writes the blobs of one store operation into ``blob_chunks`` through the session's own
    connection: they commit or roll back with the rows that name them."""

    def __init__(self, session: Session):
        self.session = session

    def _sink(self, suffix: str) -> tuple[str, _ChunkSink]:
        key = f"{DB_PREFIX}{uuid.uuid4().hex}{suffix}"[:200]
        return key, _ChunkSink(self.session.connection(), key)

    def file(self, src: Path | bytes, suffix: str = "", link: bool = False) -> str:
        """Store a file's bytes (or bytes) as a new blob, read and written a chunk at a time."""
        key, sink = self._sink(suffix)
        with sink:
            if isinstance(src, (bytes, bytearray, memoryview)):
                sink.write(src)
            else:
                with open(src, "rb") as fh:
                    while piece := fh.read(CHUNK_BYTES):
                        sink.write(piece)
        return key

    def parquet(self, columns: dict[str, np.ndarray]) -> str:
        """Store columns as a new Parquet blob (written row group by row group)."""
        key, sink = self._sink(".parquet")
        with sink:
            write_parquet(columns, sink)
        return key

    def done(self) -> None:
        """Nothing to wait for: the chunks were written through the session's connection."""
        pass


class DbBlobReader(io.RawIOBase):
    """A read-only, seekable file over the chunks of one blob in the database (fetches the chunks a
    read needs; keeps the last one for the small reads around it)."""

    def __init__(self, conn, key: str):
        super().__init__()
        from sqlalchemy import text

        self.conn, self.key, self.pos = conn, key, 0
        self._lock = threading.Lock()
        self._last: tuple[int, bytes] | None = None
        row = conn.execute(
            text("SELECT seq, length(data) FROM blob_chunks WHERE key = :k ORDER BY seq DESC LIMIT 1"), {"k": key}
        ).first()
        if row is None:
            raise FileNotFoundError(f"stored blob '{key}' is missing from the database (blob_chunks)")
        self.size = int(row[0]) * CHUNK_BYTES + int(row[1])
        self._range = text("SELECT seq, data FROM blob_chunks WHERE key = :k AND seq >= :a AND seq <= :b ORDER BY seq")

    def readable(self) -> bool:
        """Always True."""
        return True

    def seekable(self) -> bool:
        """Always True."""
        return True

    def tell(self) -> int:
        """The position, bytes from the start."""
        return self.pos

    def seek(self, offset: int, whence: int = 0) -> int:
        """Move to ``offset`` bytes from the start (``whence`` 0), the position (1) or the end (2); returns the new
        position (never below 0)."""
        base = {0: 0, 1: self.pos, 2: self.size}[whence]
        self.pos = max(0, base + offset)
        return self.pos

    def _chunks(self, a: int, b: int) -> list[bytes]:
        if self._last is not None and a == b == self._last[0]:
            return [self._last[1]]
        rows = self.conn.execute(self._range, {"k": self.key, "a": a, "b": b}).all()
        if len(rows) != b - a + 1:
            raise OSError(f"stored blob '{self.key}' lost chunks {a}..{b} while being read")
        self._last = (rows[-1][0], bytes(rows[-1][1]))
        return [bytes(r[1]) for r in rows]

    def read(self, n: int = -1) -> bytes:
        """Up to ``n`` bytes from the position (all the rest for ``n`` < 0 or None); empty at the end."""
        with self._lock:
            end = self.size if n is None or n < 0 else min(self.size, self.pos + n)
            if end <= self.pos:
                return b""
            a, b = self.pos // CHUNK_BYTES, (end - 1) // CHUNK_BYTES
            data = b"".join(self._chunks(a, b))
            out = data[self.pos - a * CHUNK_BYTES : end - a * CHUNK_BYTES]
            self.pos = end
            return out

    def readall(self) -> bytes:
        """All bytes from the position to the end."""
        return self.read(-1)

    def readinto(self, buf) -> int:
        """Read up to ``len(buf)`` bytes into ``buf``; returns how many."""
        data = self.read(len(buf))
        memoryview(buf).cast("B")[: len(data)] = data
        return len(data)


def open_blob(row, key: str):
    """An open binary file of blob ``key`` named by a row bound to a session (the database's chunks
    through the session's connection, or the folder's file)."""
    if key.startswith(DB_PREFIX):
        session = object_session(row)
        if session is None:
            raise RuntimeError(f"blob '{key}' cannot be read: the row is not bound to a session")
        return DbBlobReader(session.connection(), key)
    return blob_path(row, key).open("rb")


class StoredBlob:
    """A stored original named by a loaded :class:`~ldvsurvey.io.drivelog.DriveLog` without reading
    it (``files[name]`` of a log loaded from the database)."""

    def __init__(self, key: str, size_bytes: int):
        self.key, self.size_bytes = key, size_bytes

    def __repr__(self) -> str:
        return f"StoredBlob({self.key!r}, {self.size_bytes})"


def download(row, key: str, *, piece_bytes: int = CHUNK_BYTES) -> tuple[Iterator[bytes], int]:
    """A blob as pieces for an HTTP answer streamed after the route returned.

    A folder's file is opened now; a database blob is read in a transaction of its own begun now
    (REPEATABLE READ), so a deletion committed meanwhile cannot cut the download short.

    Parameters
    ----------
    row : LogFile
        The row naming the blob (its session tells where blobs live).
    key : str
        The blob's key.
    piece_bytes : int
        Largest piece, bytes.

    Returns
    -------
    Iterator[bytes]
        The pieces, in order.
    int
        The blob's size, bytes (the ``Content-Length``).
    """
    if not key.startswith(DB_PREFIX):
        fh = blob_path(row, key).open("rb")
        return _file_pieces(fh, piece_bytes), os.fstat(fh.fileno()).st_size
    from sqlalchemy import text

    engine = object_session(row).get_bind()
    conn = engine.connect()
    if engine.dialect.name == "postgresql":
        conn = conn.execution_options(isolation_level="REPEATABLE READ")
    try:
        conn.begin()
        reader = DbBlobReader(conn, key)  # the snapshot is taken by this first query
    except BaseException:
        conn.close()
        raise
    # a piece at a time out of its chunk (substr of an uncompressed out-of-line value reads only that
    # slice): a whole 1-MiB chunk would cost several MiB on the way (PostgreSQL sends bytea as hex)
    piece = text("SELECT substr(data, :a, :n) FROM blob_chunks WHERE key = :k AND seq = :i")

    def pieces() -> Iterator[bytes]:
        try:
            at = 0
            while at < reader.size:
                i, a = divmod(at, CHUNK_BYTES)
                n = min(piece_bytes, CHUNK_BYTES - a, reader.size - at)
                data = conn.execute(piece, {"k": key, "i": i, "a": a + 1, "n": n}).scalar_one()
                if data is None or len(data) != n:
                    raise OSError(f"stored blob '{key}' ends early at byte {at}")
                at += n
                yield bytes(data)
        finally:
            conn.close()

    return pieces(), reader.size


def _file_pieces(fh, piece_bytes: int) -> Iterator[bytes]:
    try:
        while piece := fh.read(piece_bytes):
            yield piece
    finally:
        fh.close()


def delete_from_database(session: Session, keys: list[str]) -> None:
    """Delete the chunks of database blobs (in the session's transaction)."""
    from sqlalchemy import delete

    from ldvsurvey.store.models import BlobChunk

    db_keys = [k for k in keys if k.startswith(DB_PREFIX)]
    for a in range(0, len(db_keys), 500):
        session.execute(delete(BlobChunk).where(BlobChunk.key.in_(db_keys[a : a + 500])))


def migrate_to_database(database_url: str, folder: Path, *, log=print) -> tuple[int, int]:
    """Move every blob of the folder named by a row into the database (PostgreSQL), one log per
    transaction: the chunks are written and the row renamed together, an original's SHA-256 checked
    against its row on the way; the file is removed once that is committed. Returns (blobs, bytes).
    Safe to repeat and to run while the server runs (a log deleted meanwhile is skipped)."""
    import hashlib

    from sqlalchemy import select

    from ldvsurvey.store.db import session_scope
    from ldvsurvey.store.models import Log, LogArray, LogFile

    register_root(database_url, folder)
    n = nbytes = 0
    with session_scope(database_url) as s:
        if not in_database(s):
            raise RuntimeError("SQLite keeps its blobs in the folder beside the database: nothing to migrate")
        log_ids = list(s.scalars(select(Log.id).order_by(Log.id)))
    for log_id in log_ids:
        with session_scope(database_url) as s:
            if s.get(Log, log_id, with_for_update=True) is None:
                continue
            gone = []
            for t in (LogFile, LogArray):
                for row in s.scalars(select(t).where(t.log_id == log_id, t.blob.is_not(None))):
                    if row.blob.startswith(DB_PREFIX):
                        continue
                    path = blob_path(row, row.blob)
                    key = f"{DB_PREFIX}{row.blob.replace('/', '-')}"[:200]
                    h = hashlib.sha256()
                    size = 0
                    with _ChunkSink(s.connection(), key) as sink, open(path, "rb") as fh:
                        while piece := fh.read(CHUNK_BYTES):
                            h.update(piece)
                            size += len(piece)
                            sink.write(piece)
                    if isinstance(row, LogFile) and (h.hexdigest() != row.sha256 or size != row.size_bytes):
                        raise RuntimeError(
                            f"{path}: SHA-256 {h.hexdigest()} ({size} bytes) differs from the stored "
                            f"{row.sha256} ({row.size_bytes} bytes) of log {log_id} file '{row.name}': not moved"
                        )
                    row.blob = key
                    gone.append(path)
                    n += 1
                    nbytes += size
            unlink_after_commit(s, gone)
        if gone:
            log(f"log {log_id}: {len(gone)} blobs moved into the database")
    return n, nbytes
