"""``ldv-survey backup`` / ``restore`` (SQLite and its blob folder): taken while the server runs and
writes, verified by SHA-256 on restore; the restored server serves the same files byte for byte."""

import json
import shutil
from pathlib import Path

import pytest
from fastapi.testclient import TestClient

from ldvsurvey.sim import catalog
from ldvsurvey.sim.scenario import bundle_files, simulate
from ldvsurvey.store import backup as bk
from ldvsurvey.store import blobs
from tests.bundles import make_bundle, zip_bytes


@pytest.fixture
def cli_env(monkeypatch):
    """Run the CLI against a data folder (LDVSURVEY_DATA_DIR), the settings cache cleared around."""
    from ldvsurvey.cli import main
    from ldvsurvey.settings import get_settings

    def run(data: Path, *argv) -> int:
        monkeypatch.setenv("LDVSURVEY_DATA_DIR", str(data))
        monkeypatch.delenv("LDVSURVEY_DATABASE_URL", raising=False)
        get_settings.cache_clear()
        try:
            return main(list(argv))
        finally:
            get_settings.cache_clear()

    return run


def _upload(c, files) -> int:
    r = c.post("/api/logs", files=[("files", ("b.zip", zip_bytes(files), "application/zip"))])
    assert r.status_code == 201, r.text
    return r.json()["id"]


def _served(c, log_ids, job_ids) -> dict:
    """Every original of the logs and every result file of the jobs, as the server sends them."""
    out = {}
    for i in log_ids:
        for f in c.get(f"/api/logs/{i}").json()["files"]:
            r = c.get(f"/api/logs/{i}/files/{f['name']}")
            assert r.status_code == 200
            out[("log", i, f["name"])] = r.content
    for j in job_ids:
        job = c.get(f"/api/jobs/{j}").json()
        out[("job", j, "status")] = job["status"].encode()
        for f in c.get(f"/api/jobs/{j}/files").json():
            out[("job", j, f["name"])] = c.get(f"/api/jobs/{j}/files/{f['name']}").content
    return out


def test_backup_while_serving_and_restore_byte_for_byte(settings, tmp_path, monkeypatch, cli_env, capsys):
    from ldvsurvey.api.app import create_app

    if settings.database_url:
        pytest.skip("SQLite's backup (PostgreSQL: tests/scaleout/test_blobstore.py)")
    monkeypatch.setattr(blobs, "INLINE_MAX_BYTES", 0)  # every file a blob of the folder
    a_dir = Path(settings.data_dir)
    app = create_app(settings.model_copy(update={"run_consumer": False}))
    with TestClient(app) as c:
        drive = bundle_files(simulate(catalog.drive(minutes=6, static_s=120), seed=5))
        logs = [_upload(c, drive), _upload(c, make_bundle(seed=71)), _upload(c, make_bundle(seed=72))]
        r = c.post(f"/api/logs/{logs[0]}/jobs", json={"pipeline": "navigate", "parameters": {"calibration": "nominal"}})
        assert r.status_code in (200, 201, 202), r.text
        job = r.json()["id"]
        assert app.state.runner.execute(job) == "succeeded"
        before = _served(c, logs[:2], [job])
        waiting = c.post(
            f"/api/logs/{logs[0]}/jobs", json={"pipeline": "navigate", "parameters": {"calibration": "auto"}}
        ).json()["id"]  # queued (no consumer) when the backup is taken

        # the server goes on while the blobs are copied: a log is deleted, another stored
        copy, hits = bk._copy_hashed, []

        def copy_while_serving(src, dst):
            if not hits:
                assert c.delete(f"/api/logs/{logs[2]}").status_code == 204
                hits.append(_upload(c, make_bundle(seed=73)))
            return copy(src, dst)

        monkeypatch.setattr(bk, "_copy_hashed", copy_while_serving)
        assert cli_env(a_dir, "backup", str(tmp_path / "bk")) == 0
        monkeypatch.setattr(bk, "_copy_hashed", copy)
    said = capsys.readouterr().out
    assert f"log {logs[2]} was deleted while the backup ran: left out" in said
    assert "backed up 2 logs, 2 jobs" in said, said
    m = json.loads((tmp_path / "bk" / "backup.json").read_text())
    assert len(m["blobs"]) == sum(len(f) + 3 for f in (drive, make_bundle(seed=71)))

    b_dir = tmp_path / "b"
    assert cli_env(b_dir, "restore", str(tmp_path / "bk")) == 0
    said = capsys.readouterr().out
    assert "blobs verified by SHA-256" in said and "1 jobs queued or running at backup time marked failed" in said
    b_settings = settings.model_copy(update={"data_dir": b_dir, "run_consumer": False})
    with TestClient(create_app(b_settings)) as c:
        assert _served(c, logs[:2], [job]) == before
        assert c.get(f"/api/logs/{logs[2]}").status_code == 404  # deleted during the backup
        assert c.get(f"/api/logs/{hits[0]}").status_code == 404  # stored after its snapshot
        assert sorted(x["id"] for x in c.get("/api/logs").json()) == sorted(logs[:2])
        w = c.get(f"/api/jobs/{waiting}").json()  # its queue was not backed up: failed, to be retried
        assert w["status"] == "failed" and "restore" in w["error"]
        assert c.post(f"/api/jobs/{waiting}/retry").status_code in (200, 202)

    # an existing database is not replaced without --force; with it, the replaced one's files go
    assert cli_env(b_dir, "restore", str(tmp_path / "bk")) == 2
    assert "--force" in capsys.readouterr().err
    stray = b_dir / "blobs" / "ff" / "ff00-imu.csv"
    stray.parent.mkdir(parents=True, exist_ok=True)
    stray.write_bytes(b"of the database being replaced")
    assert cli_env(b_dir, "restore", str(tmp_path / "bk"), "--force") == 0
    assert not stray.exists()
    restored = sorted(p.relative_to(b_dir / "blobs").as_posix() for p in (b_dir / "blobs").rglob("*") if p.is_file())
    assert restored == sorted(m["blobs"])


def test_restore_refuses_an_altered_backup_and_touches_nothing(settings, tmp_path, monkeypatch, cli_env, capsys):
    from ldvsurvey.api.app import create_app

    if settings.database_url:
        pytest.skip("SQLite's backup")
    monkeypatch.setattr(blobs, "INLINE_MAX_BYTES", 0)
    with TestClient(create_app(settings.model_copy(update={"run_consumer": False}))) as c:
        _upload(c, make_bundle(seed=74))
    assert cli_env(Path(settings.data_dir), "backup", str(tmp_path / "bk")) == 0
    assert cli_env(Path(settings.data_dir), "backup", str(tmp_path / "bk")) == 2  # not into a used folder
    capsys.readouterr()
    m = json.loads((tmp_path / "bk" / "backup.json").read_text())
    victim = tmp_path / "bk" / "blobs" / next(k for k in m["blobs"] if k.endswith("-imu.csv"))
    shutil.copytree(tmp_path / "bk", tmp_path / "bad")
    bad = tmp_path / "bad" / victim.relative_to(tmp_path / "bk")
    data = bytearray(bad.read_bytes())
    data[len(data) // 2] ^= 0x01  # one bit
    bad.write_bytes(bytes(data))
    c_dir = tmp_path / "c"
    assert cli_env(c_dir, "restore", str(tmp_path / "bad")) == 2
    err = capsys.readouterr().err
    assert str(bad) in err and "SHA-256" in err
    assert not c_dir.exists() or not any(c_dir.rglob("*"))  # nothing restored
    # a backup that fails (here: a stored file gone from a log that still exists) leaves nothing
    (Path(settings.data_dir) / "blobs" / next(iter(m["blobs"]))).unlink()
    assert cli_env(Path(settings.data_dir), "backup", str(tmp_path / "bk2")) == 2
    assert "missing from the blob folder" in capsys.readouterr().err
    assert list((tmp_path / "bk2").iterdir()) == []
    (tmp_path / "bad" / "backup.json").unlink()
    assert cli_env(c_dir, "restore", str(tmp_path / "bad")) == 2
    assert "not a complete ldv-survey backup" in capsys.readouterr().err
