"""Blobs in PostgreSQL: the API and a worker on separate data folders (as on two machines without a
shared disk) process an upload end to end; an older blob folder moves into the database."""

import hashlib
import time
from pathlib import Path

import httpx
import numpy as np
import pytest
from sqlalchemy import create_engine, text

from ldvsurvey.sim import catalog
from ldvsurvey.sim.scenario import bundle_files, simulate
from tests.scaleout.helpers import Stack


def _files(folder: Path) -> list[Path]:
    return sorted(p for p in folder.rglob("*") if p.is_file()) if folder.exists() else []


def _wait(base, job_id, timeout=600):
    t0 = time.time()
    while time.time() - t0 < timeout:
        j = httpx.get(f"{base}/api/jobs/{job_id}", timeout=10).json()
        if j["status"] in ("succeeded", "failed", "cancelled"):
            return j
        time.sleep(0.3)
    raise TimeoutError(job_id)


@pytest.fixture(scope="module")
def drive():
    return bundle_files(simulate(catalog.drive(minutes=6, static_s=120), seed=5))


def test_api_and_worker_on_separate_data_folders(pg_fresh, tmp_path, drive):
    from ldvsurvey.cli import main

    db, rd = pg_fresh
    api_dir, worker_dir = tmp_path / "api", tmp_path / "worker"
    api_dir.mkdir()
    worker_dir.mkdir()
    st = Stack(api_dir, db, rd, api_workers=1)
    try:
        st.start_api()
        st.start_worker(LDVSURVEY_DATA_DIR=str(worker_dir))
        r = httpx.post(st.base + "/api/logs", files=[("files", (n, d)) for n, d in drive.items()], timeout=120)
        assert r.status_code == 201, r.text
        log_id = r.json()["id"]
        with create_engine(db).connect() as c:
            keys = dict(c.execute(text("SELECT name, blob FROM log_files WHERE log_id = :i"), {"i": log_id}).all())
            n_chunks = c.execute(text("SELECT count(*) FROM blob_chunks")).scalar()
        assert keys["imu.csv"].startswith("db:") and len(drive["imu.csv"]) > 2 << 20
        assert n_chunks >= len(drive["imu.csv"]) >> 20  # the large file in 1-MiB chunks
        job = httpx.post(
            f"{st.base}/api/logs/{log_id}/jobs",
            json={"pipeline": "navigate", "parameters": {"calibration": "nominal"}},
            timeout=60,
        ).json()["id"]
        j = _wait(st.base, job)
        assert j["status"] == "succeeded", j["error"]
        names = sorted(f["name"] for f in httpx.get(f"{st.base}/api/jobs/{job}/files").json())
        got = {n: httpx.get(f"{st.base}/api/jobs/{job}/files/{n}").content for n in names}
        for name, data in drive.items():  # the originals come back byte for byte from the database
            f = httpx.get(f"{st.base}/api/logs/{log_id}/files/{name}", timeout=60)
            assert f.status_code == 200 and f.content == data, name
            assert f.headers["x-content-sha256"] == hashlib.sha256(data).hexdigest()
        # neither process kept a blob on its disk: the worker read the log from the database
        assert _files(api_dir / "blobs") == [] and _files(worker_dir / "blobs") == []
        assert _files(api_dir / "tmp") == []  # the upload's staging folder went with the request
    finally:
        st.stop()
    # the same pipeline on the bundle's own files (the CLI, no database) gives the same tables
    bundle = tmp_path / "bundle"
    bundle.mkdir()
    for n, d in drive.items():
        (bundle / n).write_bytes(d)
    assert main(["run", "navigate", str(bundle), "--out", str(tmp_path / "cli"), "--set", "calibration=nominal"]) == 0
    csvs = [n for n in names if n.endswith(".csv")]
    assert csvs
    for n in csvs:
        assert got[n] == (tmp_path / "cli" / n).read_bytes(), n


def test_blobs_of_an_older_folder_move_into_the_database(pg_fresh, tmp_path, monkeypatch, capsys):
    """A PostgreSQL deployment of the previous version kept its blobs in a shared folder: `ldv-survey
    blobs migrate` moves them (checked by SHA-256), and the log reads the same afterwards."""
    from ldvsurvey.cli import main
    from ldvsurvey.io.drivelog import parse_files
    from ldvsurvey.io.quality import quality_report
    from ldvsurvey.settings import get_settings
    from ldvsurvey.store import blobs
    from ldvsurvey.store.db import session_scope
    from ldvsurvey.store.logs import load_drivelog, store_log
    from tests.bundles import make_bundle

    db, _ = pg_fresh
    folder = tmp_path / "data" / "blobs"
    files = make_bundle(seed=51, n_imu=30_000)
    log = parse_files(files)
    monkeypatch.setattr(blobs, "INLINE_MAX_BYTES", 0)
    with monkeypatch.context() as m:  # as the previous version stored it: in the folder
        m.setattr(blobs, "writer_for", lambda s: blobs.Writer(s, folder))
        with session_scope(db) as s:
            row, _ = store_log(s, log, quality_report(log))
    log_id = row.id
    assert len(_files(folder)) == len(files) + 3
    monkeypatch.setenv("LDVSURVEY_DATABASE_URL", db)
    monkeypatch.setenv("LDVSURVEY_DATA_DIR", str(tmp_path / "data"))
    get_settings.cache_clear()
    try:
        assert main(["blobs", "migrate"]) == 0
        assert f"moved {len(files) + 3} blobs" in capsys.readouterr().out
        assert _files(folder) == []
        assert main(["blobs", "migrate"]) == 0  # again: nothing left to move
        assert "moved 0 blobs" in capsys.readouterr().out
    finally:
        get_settings.cache_clear()
    with session_scope(db) as s:
        back = load_drivelog(s, log_id)
        from ldvsurvey.store.models import LogFile

        for f in s.query(LogFile).filter(LogFile.log_id == log_id):
            assert f.blob.startswith("db:") and f.content == files[f.name]
    np.testing.assert_array_equal(back.imu.dtheta_rad, log.imu.dtheta_rad)
    np.testing.assert_array_equal(back.gnss.lat_deg, log.gnss.lat_deg)


def test_a_corrupt_folder_blob_is_not_moved(pg_fresh, tmp_path, monkeypatch):
    from ldvsurvey.io.drivelog import parse_files
    from ldvsurvey.io.quality import quality_report
    from ldvsurvey.store import blobs
    from ldvsurvey.store.db import session_scope
    from ldvsurvey.store.logs import store_log
    from tests.bundles import make_bundle

    db, _ = pg_fresh
    folder = tmp_path / "blobs"
    log = parse_files(make_bundle(seed=52))
    monkeypatch.setattr(blobs, "INLINE_MAX_BYTES", 0)
    with monkeypatch.context() as m:
        m.setattr(blobs, "writer_for", lambda s: blobs.Writer(s, folder))
        with session_scope(db) as s:
            store_log(s, log, quality_report(log))
    victim = next(p for p in _files(folder) if p.name.endswith("-imu.csv"))
    victim.write_bytes(victim.read_bytes().replace(b"1", b"2", 1))
    with pytest.raises(RuntimeError, match="imu.csv.*not moved"):
        blobs.migrate_to_database(db, folder)
    assert len(_files(folder)) == 7  # nothing of that log moved or removed
    with create_engine(db).connect() as c:
        assert c.execute(text("SELECT count(*) FROM blob_chunks")).scalar() == 0


def test_backup_and_restore_round_trip_on_postgresql(pg_fresh, tmp_path, drive):
    """pg_dump/pg_restore through `ldv-survey backup` / `restore`: a database with logs (their blobs
    inside) and a job comes back into a new database, served byte for byte."""
    from fastapi.testclient import TestClient
    from sqlalchemy.engine import make_url

    from ldvsurvey.api.app import create_app
    from ldvsurvey.settings import Settings
    from ldvsurvey.store.backup import backup, restore
    from ldvsurvey.store.db import dispose_engines
    from tests.bundles import make_bundle, zip_bytes
    from tests.store.test_backup import _served

    db, _ = pg_fresh
    target = make_url(db).set(database=make_url(db).database + "_restored")
    admin = create_engine(make_url(db).set(database="postgres"), isolation_level="AUTOCOMMIT")
    with admin.connect() as c:
        c.execute(text(f'DROP DATABASE IF EXISTS "{target.database}" WITH (FORCE)'))
        c.execute(text(f'CREATE DATABASE "{target.database}"'))
    target_url = target.render_as_string(hide_password=False)

    def settings(url, d):
        return Settings(data_dir=tmp_path / d, database_url=url, auth_enabled=False, run_consumer=False)

    app = create_app(settings(db, "a"))
    with TestClient(app) as c:
        logs = []
        for files in (drive, make_bundle(seed=81)):
            r = c.post("/api/logs", files=[("files", ("b.zip", zip_bytes(files), "application/zip"))])
            assert r.status_code == 201, r.text
            logs.append(r.json()["id"])
        job = c.post(
            f"/api/logs/{logs[0]}/jobs", json={"pipeline": "navigate", "parameters": {"calibration": "nominal"}}
        ).json()["id"]
        assert app.state.runner.execute(job) == "succeeded"
        before = _served(c, logs, [job])
        m = backup(db, tmp_path / "bk")  # while the server runs
    assert m["engine"] == "postgresql" and m["counts"] == {"logs": 2, "jobs": 1}
    restore(target_url, tmp_path / "bk")
    try:
        with TestClient(create_app(settings(target_url, "b"))) as c:
            assert _served(c, logs, [job]) == before
        assert list((tmp_path / "b").rglob("blobs/*")) == []
    finally:
        dispose_engines()
        with admin.connect() as c:
            c.execute(text(f'DROP DATABASE IF EXISTS "{target.database}" WITH (FORCE)'))
