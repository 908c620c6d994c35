"""The database blob store (``blob_chunks``, used with PostgreSQL) on any engine: chunk boundaries,
seeks, streamed downloads, rollback and deletion. Run here on SQLite with tiny chunks; the same code
on PostgreSQL is exercised by tests/scaleout/test_blobstore.py."""

import io

import numpy as np
import pytest
from sqlalchemy import select, text

from ldvsurvey.io.drivelog import parse_files
from ldvsurvey.io.quality import quality_report
from ldvsurvey.store import blobs
from ldvsurvey.store.db import session_scope, upgrade_head
from ldvsurvey.store.logs import delete_log, load_drivelog, store_log
from ldvsurvey.store.models import LogArray, LogFile
from tests.bundles import make_bundle

CHUNK = 1000


@pytest.fixture
def db_store(tmp_path, monkeypatch):
    """A SQLite database whose new blobs go into ``blob_chunks`` in 1000-byte chunks."""
    monkeypatch.setattr(blobs, "in_database", lambda session: True)
    monkeypatch.setattr(blobs, "CHUNK_BYTES", CHUNK)
    monkeypatch.setattr(blobs, "INLINE_MAX_BYTES", 0)
    url = f"sqlite:///{tmp_path / 'db.sqlite'}"
    upgrade_head(url)
    return url


def _keys(url):
    with session_scope(url) as s:
        return list(s.scalars(text("SELECT DISTINCT key FROM blob_chunks")))


def test_store_read_download_delete(db_store, tmp_path):
    files = make_bundle(seed=61, n_imu=3000)
    log = parse_files(files)
    with session_scope(db_store) as s:
        row, created = store_log(s, log, quality_report(log))
    assert created and not (tmp_path / "blobs").exists()
    assert len(_keys(db_store)) == len(files) + 3
    with session_scope(db_store) as s:
        back = load_drivelog(s, row.id)
        for f in s.scalars(select(LogFile).where(LogFile.log_id == row.id)):
            assert f.blob.startswith(blobs.DB_PREFIX)
            assert f.content == files[f.name]
            pieces, size = blobs.download(f, f.blob, piece_bytes=300)
            got = list(pieces)
            assert size == len(files[f.name]) and b"".join(got) == files[f.name]
            assert max(map(len, got)) <= 300
        n_chunks = s.scalar(text("SELECT count(*) FROM blob_chunks"))
    assert n_chunks > sum(len(d) for d in files.values()) // CHUNK
    np.testing.assert_array_equal(back.imu.dtheta_rad, log.imu.dtheta_rad)
    np.testing.assert_array_equal(back.ldv.v_fwd_mps, log.ldv.v_fwd_mps)
    np.testing.assert_array_equal(back.gnss.h_m, log.gnss.h_m)
    assert back.sha256 == log.sha256
    assert {n: back.size_of(n) for n in files} == {n: len(d) for n, d in files.items()}
    with pytest.raises(RuntimeError):  # a deletion rolled back keeps the chunks
        with session_scope(db_store) as s:
            delete_log(s, row.id)
            raise RuntimeError("not committed")
    assert len(_keys(db_store)) == len(files) + 3
    with session_scope(db_store) as s:
        delete_log(s, row.id)
    assert _keys(db_store) == []


def test_rollback_leaves_no_chunks(db_store):
    log = parse_files(make_bundle(seed=62))
    with pytest.raises(RuntimeError):
        with session_scope(db_store) as s:
            store_log(s, log, quality_report(log))
            raise RuntimeError("after storing, before the commit")
    assert _keys(db_store) == []


@pytest.mark.parametrize("size", [0, 1, CHUNK - 1, CHUNK, CHUNK + 1, 5 * CHUNK, 5 * CHUNK + 17])
def test_reader_seeks_and_reads_across_chunks(db_store, size):
    data = np.random.default_rng(size).integers(0, 256, size, dtype=np.uint8).tobytes()
    with session_scope(db_store) as s:
        key = blobs.DbWriter(s).file(data, suffix="-x.bin")
        r = blobs.DbBlobReader(s.connection(), key)
        assert r.size == size and r.read() == data
        ref = io.BytesIO(data)
        rng = np.random.default_rng(7)
        for _ in range(50):  # random seeks and reads agree with an in-memory file
            pos, n = int(rng.integers(0, size + 3)), int(rng.integers(0, 3 * CHUNK))
            whence = int(rng.integers(0, 3))
            off = pos if whence == 0 else pos - size if whence == 2 else pos - ref.tell()
            assert r.seek(off, whence) == ref.seek(max(0, {0: 0, 1: ref.tell(), 2: size}[whence] + off))
            assert r.read(n) == ref.read(n)
            assert r.tell() == ref.tell()
        buf = bytearray(size + 5)
        r.seek(0)
        assert r.readinto(buf) == size and bytes(buf[:size]) == data


def test_parquet_arrays_stream_in_and_out(db_store):
    n = 10_000
    cols = {"t_s": np.arange(n) * 0.01, "v_mps": np.sin(np.arange(n)), "q": np.arange(n, dtype=np.int32)}
    with session_scope(db_store) as s:
        key = blobs.DbWriter(s).parquet(cols)
        a = LogArray(log_id=1, name="x", n_rows=n, blob=key)
        s.add(a)
        back = blobs.from_parquet(blobs.open_blob(a, key))
        s.rollback()
    for k, v in cols.items():
        np.testing.assert_array_equal(back[k], v)
    assert _keys(db_store) == []
