"""Large originals and arrays live in the blob folder: byte for byte, removed with their log, never
left behind by a refused upload or a rolled-back transaction, and old in-row files still read."""

import hashlib
import json
from pathlib import Path

import numpy as np
import pytest
from sqlalchemy import select, text

from ldvsurvey.io.drivelog import parse_files
from ldvsurvey.io.quality import quality_report
from ldvsurvey.store import blobs
from ldvsurvey.store.db import session_scope, upgrade_head
from ldvsurvey.store.logs import _arrays, count_rows, delete_log, load_drivelog, store_log
from ldvsurvey.store.models import LogArray, LogFile
from tests import badinput
from tests.bundles import make_bundle, zip_bytes


@pytest.fixture
def all_in_blobs(monkeypatch):
    monkeypatch.setattr(blobs, "INLINE_MAX_BYTES", 0)


def _blob_files(root: Path) -> list[Path]:
    return sorted(p for p in root.rglob("*") if p.is_file()) if root.exists() else []


def _stored(url: str, root: Path) -> list:
    """The stored blobs: files of the blob folder (SQLite), keys of ``blob_chunks`` (PostgreSQL)."""
    if url.startswith("sqlite"):
        return _blob_files(root)
    with session_scope(url) as s:
        return list(s.scalars(text("SELECT DISTINCT key FROM blob_chunks")))


def test_upload_download_reload_delete(client, all_in_blobs):
    files = make_bundle(seed=31)
    r = client.post("/api/logs", files=[("files", ("b.zip", zip_bytes(files), "application/zip"))])
    assert r.status_code == 201, r.text
    log_id = r.json()["id"]
    url = client.app_state.database_url
    root = Path(client.app_state.settings.data_dir) / "blobs"
    stored = _stored(url, root)
    assert len(stored) == len(files) + 3  # every original and the three Parquet arrays
    if not url.startswith("sqlite"):
        assert _blob_files(root) == []  # in the database: nothing on the API's disk
    for name, data in files.items():
        f = client.get(f"/api/logs/{log_id}/files/{name}")
        assert f.status_code == 200 and f.content == data
        assert f.headers["x-content-sha256"] == hashlib.sha256(data).hexdigest()
    ref = parse_files(files)
    with session_scope(url) as s:
        back = load_drivelog(s, log_id)
        assert s.scalar(select(LogFile.inline).where(LogFile.name == "imu.csv")) is None
    np.testing.assert_array_equal(back.imu.dtheta_rad, ref.imu.dtheta_rad)
    np.testing.assert_array_equal(back.imu.dvel_mps, ref.imu.dvel_mps)
    np.testing.assert_array_equal(back.ldv.v_up_mps, ref.ldv.v_up_mps)
    np.testing.assert_array_equal(back.gnss.fix, ref.gnss.fix)
    assert {n: back.sha256_of(n) for n in files} == {n: hashlib.sha256(d).hexdigest() for n, d in files.items()}
    assert back.sha256 == ref.sha256
    assert client.delete(f"/api/logs/{log_id}").status_code == 204
    assert _stored(url, root) == []
    with session_scope(url) as s:
        assert count_rows(s) == {"logs": 0, "log_files": 0, "log_arrays": 0}


def test_refused_upload_leaves_nothing(client, all_in_blobs, db_counts):
    files, exp = badinput.case("non_numeric_cell")
    r = client.post("/api/logs", files=[("files", ("b.zip", zip_bytes(files), "application/zip"))])
    assert r.status_code in (400, 422) and exp["file"] in r.text
    data_dir = Path(client.app_state.settings.data_dir)
    assert _blob_files(data_dir / "blobs") == []
    assert _blob_files(data_dir / "tmp") == []  # the inflated members went with the request
    assert db_counts() == {"logs": 0, "log_files": 0, "log_arrays": 0}


def test_rollback_removes_the_blobs_it_wrote(tmp_path, all_in_blobs):
    url = f"sqlite:///{tmp_path / 'db.sqlite'}"
    upgrade_head(url)
    log = parse_files(make_bundle(seed=32))
    with pytest.raises(RuntimeError):
        with session_scope(url) as s:
            store_log(s, log, quality_report(log))
            assert len(_blob_files(tmp_path / "blobs")) == 7
            raise RuntimeError("after storing, before the commit")
    assert _blob_files(tmp_path / "blobs") == []
    with session_scope(url) as s:
        assert count_rows(s) == {"logs": 0, "log_files": 0, "log_arrays": 0}
    # committed: kept; a deletion rolled back keeps them too
    with session_scope(url) as s:
        row, created = store_log(s, log, quality_report(log))
    assert created and len(_blob_files(tmp_path / "blobs")) == 7
    with pytest.raises(RuntimeError):
        with session_scope(url) as s:
            delete_log(s, row.id)
            raise RuntimeError("not committed")
    assert len(_blob_files(tmp_path / "blobs")) == 7
    with session_scope(url) as s:
        assert load_drivelog(s, row.id).imu.t_s[0] == log.imu.t_s[0]


def test_in_memory_database_keeps_everything_in_rows(all_in_blobs):
    url = "sqlite://"
    upgrade_head(url)
    files = make_bundle(seed=33)
    log = parse_files(files)
    with session_scope(url) as s:
        row, _ = store_log(s, log, quality_report(log))
        assert s.scalar(select(LogArray.blob).where(LogArray.log_id == row.id)) is None
        assert s.scalar(select(LogFile).where(LogFile.name == "imu.csv")).content == files["imu.csv"]
        np.testing.assert_array_equal(load_drivelog(s, row.id).imu.dvel_mps, log.imu.dvel_mps)


def test_rows_stored_before_0006_still_read(tmp_path):
    """A log stored by the previous schema (bytes in the rows) reads the same after the upgrade."""
    from alembic import command
    from alembic.config import Config

    from ldvsurvey.store.db import MIGRATIONS_DIR, get_engine

    url = f"sqlite:///{tmp_path / 'old.db'}"
    cfg = Config()
    cfg.set_main_option("script_location", str(MIGRATIONS_DIR))
    cfg.set_main_option("sqlalchemy.url", url)
    with get_engine(url).begin() as conn:
        cfg.attributes["connection"] = conn
        command.upgrade(cfg, "0005_people")
    files = make_bundle(seed=34)
    log = parse_files(files)
    parquet = {n: blobs.to_parquet(c) for n, c in _arrays(log).items()}
    with get_engine(url).begin() as c:
        c.execute(
            text(
                "INSERT INTO logs (id, sha256, name, platform, ldv_kind, imu_rotating, survey_date, t_start_s,"
                " t_end_s, duration_s, has_gnss, size_bytes, manifest, quality, created_at) VALUES "
                "(1, :sha, 'n', 'vehicle', '2d', 0, '2023-03-20', 0, 1, 1, 1, 1, :m, :q, '2023-01-01')"
            ),
            {"sha": log.sha256, "m": json.dumps(log.manifest.model_dump(mode="json")), "q": '{"warnings": []}'},
        )
        for name, data in files.items():
            c.execute(
                text("INSERT INTO log_files (log_id, name, sha256, size_bytes, content) VALUES (1, :n, :h, :s, :c)"),
                {"n": name, "h": hashlib.sha256(data).hexdigest(), "s": len(data), "c": data},
            )
        for name, data in parquet.items():
            c.execute(
                text("INSERT INTO log_arrays (log_id, name, n_rows, parquet) VALUES (1, :n, 1, :p)"),
                {"n": name, "p": data},
            )
    upgrade_head(url)
    with session_scope(url) as s:
        back = load_drivelog(s, 1)
        assert s.scalar(select(LogFile).where(LogFile.name == "ldv.csv")).content == files["ldv.csv"]
    np.testing.assert_array_equal(back.imu.dtheta_rad, log.imu.dtheta_rad)
    assert back.files["imu.csv"] == files["imu.csv"]


def test_a_missing_blob_folder_is_named(tmp_path, all_in_blobs):
    """A worker that does not see the API's blob folder says so instead of failing obscurely."""
    url = f"sqlite:///{tmp_path / 'db.sqlite'}"
    upgrade_head(url)
    log = parse_files(make_bundle(seed=35))
    with session_scope(url) as s:
        row, _ = store_log(s, log, quality_report(log))
    for p in _blob_files(tmp_path / "blobs"):
        p.unlink()
    with session_scope(url) as s, pytest.raises(FileNotFoundError, match="same blob folder"):
        load_drivelog(s, row.id)


def test_bridged_imu_gaps_survive_the_store():
    """The gaps the reader bridged (issue 29: the gravity chains carry the lost rows' uncertainty)
    come back from the database as they were parsed: a job on a stored log sees them too."""
    from ldvsurvey.io.writers import imu_csv
    from tests.bundles import make_arrays

    url = "sqlite://"
    upgrade_head(url)
    files = make_bundle(seed=34)
    a = make_arrays(n_imu=2000, seed=34)
    keep = np.setdiff1d(np.arange(len(a["t"])), np.r_[500:503, 1200:1201])
    files["imu.csv"] = imu_csv(a["t"][keep], a["dtheta"][keep], a["dvel"][keep])
    log = parse_files(files)
    assert [(g.rows, g.lost) for g in log.imu.bridges] == [(3, True), (1, True)]
    with session_scope(url) as s:
        row, _ = store_log(s, log, quality_report(log))
        back = load_drivelog(s, row.id)
    assert back.imu.bridges == log.imu.bridges and back.imu.bridged_rows == log.imu.bridged_rows == 4
