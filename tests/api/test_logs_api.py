"""The logs REST API over HTTP: upload, list, detail, originals, duplicates, delete, bad input."""

import hashlib

import pytest

from tests import badinput
from tests.bundles import make_bundle, zip_bytes

EMPTY = {"logs": 0, "log_files": 0, "log_arrays": 0}


def _post_zip(client, data: bytes, name="bundle.zip"):
    return client.post("/api/logs", files=[("files", (name, data, "application/zip"))])


def _post_files(client, files: dict[str, bytes]):
    return client.post("/api/logs", files=[("files", (n, d, "application/octet-stream")) for n, d in files.items()])


def test_health(client):
    r = client.get("/api/health")
    assert r.status_code == 200 and r.json()["status"] == "ok"


def test_server_start_and_stop_start_and_stop_the_job_consumer(settings):
    """The app's lifespan: the reaper and the in-process job consumer run while the server does."""
    from fastapi.testclient import TestClient

    from ldvsurvey.api.app import create_app

    app = create_app(settings)
    consumer = app.state.consumer
    assert not consumer._reaper.is_alive()  # building the app starts nothing
    threads = [t for _, t in consumer.consumer.worker_threads]
    assert len(threads) == settings.workers and not any(t.is_alive() for t in threads)
    with TestClient(app):
        assert consumer._reaper.is_alive() and all(t.is_alive() for t in threads)
        assert not consumer.consumer.stop_flag.is_set()
    assert consumer._stop.is_set() and consumer.consumer.stop_flag.is_set()
    for t in [consumer._reaper, *threads]:
        t.join(30)
        assert not t.is_alive()


def test_openapi_docs(client):
    assert client.get("/docs").status_code == 200
    paths = client.get("/openapi.json").json()["paths"]
    assert "/api/logs" in paths and "/api/logs/{log_id}/files/{name}" in paths


def test_upload_zip_then_files_is_duplicate(client, db_counts):
    files = make_bundle(seed=21)
    r = _post_zip(client, zip_bytes(files))
    assert r.status_code == 201, r.text
    body = r.json()
    assert body["duplicate"] is False and body["ldv_kind"] == "2d"
    log_id = body["id"]
    # the same bundle again, as separate files this time: detected, not stored twice
    r2 = _post_files(client, files)
    assert r2.status_code == 200 and r2.json()["duplicate"] is True and r2.json()["id"] == log_id
    assert db_counts() == {"logs": 1, "log_files": 4, "log_arrays": 3}
    # originals byte for byte
    for name, data in files.items():
        f = client.get(f"/api/logs/{log_id}/files/{name}")
        assert f.status_code == 200 and f.content == data
        assert f.headers["x-content-sha256"] == hashlib.sha256(data).hexdigest()
    detail = client.get(f"/api/logs/{log_id}").json()
    assert detail["manifest"]["vendor_extra"] == {"kept": True}
    assert detail["quality"]["imu"]["n"] == 2000
    assert {f["name"] for f in detail["files"]} == set(files)
    assert [lg["id"] for lg in client.get("/api/logs").json()] == [log_id]


def test_stored_arrays_reload_identically(client):
    import numpy as np

    from ldvsurvey.io.drivelog import parse_files
    from ldvsurvey.store.db import session_scope
    from ldvsurvey.store.logs import load_drivelog

    files = make_bundle(seed=22, rotating=True)
    log_id = _post_files(client, files).json()["id"]
    with session_scope(client.app_state.database_url) as s:
        back = load_drivelog(s, log_id)
    orig = parse_files(files)
    np.testing.assert_array_equal(back.imu.dtheta_rad, orig.imu.dtheta_rad)
    np.testing.assert_array_equal(back.imu.turntable_deg, orig.imu.turntable_deg)
    np.testing.assert_array_equal(back.ldv.v_up_mps, orig.ldv.v_up_mps)
    np.testing.assert_array_equal(back.gnss.fix, orig.gnss.fix)
    assert back.manifest == orig.manifest


def test_delete_removes_every_row_and_blob(client, db_counts):
    a = _post_files(client, make_bundle(seed=23)).json()["id"]
    b = _post_files(client, make_bundle(seed=24)).json()["id"]
    assert client.delete(f"/api/logs/{a}").status_code == 204
    assert db_counts() == {"logs": 1, "log_files": 4, "log_arrays": 3}
    assert client.get(f"/api/logs/{a}").status_code == 404
    assert client.get(f"/api/logs/{a}/files/imu.csv").status_code == 404
    assert client.delete(f"/api/logs/{a}").status_code == 404
    assert client.delete(f"/api/logs/{b}").status_code == 204
    assert db_counts() == EMPTY


#: downloads an original in a fresh process (no other test's threads allocating meanwhile) and
#: prints the bytes, their SHA-256 and the peak of Python allocations while it ran
_MEASURE_DOWNLOAD = """
import hashlib, json, sys, tracemalloc
from fastapi.testclient import TestClient
from ldvsurvey.api.app import create_app
from ldvsurvey.settings import Settings

settings, url = Settings.model_validate_json(sys.argv[1]), sys.argv[2]
with TestClient(create_app(settings)) as client:
    n, digest = 0, hashlib.sha256()
    tracemalloc.start()
    with client.stream("GET", url, headers={"Accept-Encoding": "identity"}) as r:
        for piece in r.iter_raw():
            n += len(piece)
            digest.update(piece)
    peak = tracemalloc.get_traced_memory()[1]
print(json.dumps({"status": r.status_code, "n": n, "sha256": digest.hexdigest(), "peak": peak}))
"""


def test_large_original_streams_from_its_file(settings, monkeypatch):
    """An original too large for its row is sent from the blob folder a piece at a time: byte for
    byte, with the headers a small one gets, never read whole into memory."""
    import json
    import os
    import subprocess
    import sys

    from fastapi.testclient import TestClient
    from sqlalchemy import select

    from ldvsurvey.api.app import create_app
    from ldvsurvey.api.logs import DOWNLOAD_CHUNK_BYTES
    from ldvsurvey.store import blobs
    from ldvsurvey.store.db import session_scope
    from ldvsurvey.store.models import LogFile

    files = make_bundle(seed=25, n_imu=40000)
    big = files["imu.csv"]
    sha = hashlib.sha256(big).hexdigest()
    assert len(big) > 4 * blobs.INLINE_MAX_BYTES and len(big) > 16 * DOWNLOAD_CHUNK_BYTES
    settings = settings.model_copy(update={"run_consumer": False})
    app = create_app(settings)
    with TestClient(app) as client:
        r = _post_zip(client, zip_bytes(files))
        assert r.status_code == 201, r.text
        url = f"/api/logs/{r.json()['id']}/files/imu.csv"
        with session_scope(app.state.database_url) as s:
            where = dict(s.execute(select(LogFile.name, LogFile.blob).where(LogFile.log_id == r.json()["id"])).all())
        assert where["imu.csv"] is not None and where["gnss.nmea"] is None  # one in the blob folder, one in its row

        plain = {"Accept-Encoding": "identity"}
        with monkeypatch.context() as mp:  # the route must not load the file (LogFile.content reads it whole)
            mp.setattr(LogFile, "content", property(lambda _f: pytest.fail("the download read the whole file")))
            pieces, digest = [], hashlib.sha256()
            with client.stream("GET", url, headers=plain) as f:
                for piece in f.iter_raw():  # each ASGI body message as sent: the test client passes them one by one
                    digest.update(piece)
                    pieces.append(len(piece))
        assert f.status_code == 200 and sum(pieces) == len(big) and digest.hexdigest() == sha
        assert max(pieces) <= DOWNLOAD_CHUNK_BYTES and len(pieces) >= len(big) // DOWNLOAD_CHUNK_BYTES
        assert f.headers["content-type"] == "text/csv; charset=utf-8"
        assert f.headers["content-disposition"] == 'attachment; filename="imu.csv"'
        assert f.headers["content-length"] == str(len(big)) and f.headers["x-content-sha256"] == sha
        small = client.get(url.replace("imu.csv", "gnss.nmea"), headers=plain)
        assert small.content == files["gnss.nmea"] and set(f.headers) == set(small.headers)

        # compressed on the way, as the whole-body answer was: decoded, the same bytes
        z = client.get(url)
        assert z.headers["content-encoding"] == "gzip" and z.content == big and z.headers["x-content-sha256"] == sha

    env = {**os.environ, "PYTHONPATH": os.pathsep.join(p for p in sys.path if p)}
    out = subprocess.run(
        [sys.executable, "-c", _MEASURE_DOWNLOAD, settings.model_dump_json(), url],
        capture_output=True,
        text=True,
        env=env,
        check=True,
    )
    got = json.loads(out.stdout.splitlines()[-1])
    assert got["status"] == 200 and got["n"] == len(big) and got["sha256"] == sha
    assert got["peak"] < len(big) / 2, f"{got['peak']} bytes allocated at the peak of a {len(big)}-byte download"


@pytest.mark.parametrize("name", badinput.CASES)
def test_bad_bundle_422_and_nothing_stored(client, db_counts, name):
    files, exp = badinput.case(name)
    r = _post_files(client, files)
    assert r.status_code == 422, r.text
    err = r.json()["error"]
    assert err["file"] == exp["file"]
    if exp["line"] is not None:
        assert err["line"] == exp["line"]
    if exp["field"] is not None:
        assert err["field"] == exp["field"]
    assert db_counts() == EMPTY


@pytest.mark.parametrize(
    "make,status",
    [
        (badinput.truncated_zip, 422),
        (lambda: badinput.traversal_zip("../../etc/passwd"), 422),
        (lambda: badinput.traversal_zip("/abs/path"), 422),
        (lambda: badinput.bomb_zip(60 * 1024 * 1024), 413),
    ],
)
def test_bad_zip(client, db_counts, make, status):
    r = _post_zip(client, make())
    assert r.status_code == status, r.text
    assert r.json()["detail"]
    assert db_counts() == EMPTY


@pytest.mark.parametrize("member", ["imu.csv", "gnss.nmea"])
def test_corrupt_deflate_data_is_422_naming_the_member(client, db_counts, member):
    r = _post_zip(client, badinput.corrupt_deflate_zip(member))
    assert r.status_code == 422, r.text
    assert r.json()["error"]["file"] == "bundle.zip" and r.json()["error"]["field"] == member
    assert db_counts() == EMPTY


def test_encrypted_member_is_422_naming_the_member(client, db_counts):
    """Found by tests/api/test_upload_fuzz.py: a flipped encryption flag gave a 500 (RuntimeError)."""
    r = _post_zip(client, badinput.encrypted_flag_zip("ldv.csv"))
    assert r.status_code == 422, r.text
    assert r.json()["error"]["field"] == "ldv.csv" and "encrypted" in r.json()["detail"]
    assert db_counts() == EMPTY


def test_upload_over_limit_is_413(client, db_counts):
    big = make_bundle(seed=25, n_imu=60000)  # ~7 MB of CSV, limit is 5 MB in the tests
    r = _post_files(client, big)
    assert r.status_code == 413
    assert db_counts() == EMPTY


def test_empty_upload_and_mixed_upload(client, db_counts):
    r = client.post("/api/logs", files=[])
    assert r.status_code == 422
    files = make_bundle(seed=26)
    r = client.post(
        "/api/logs",
        files=[
            ("files", ("b.zip", zip_bytes(files), "application/zip")),
            ("files", ("imu.csv", files["imu.csv"], "text/csv")),
        ],
    )
    assert r.status_code == 422 and "not both" in r.json()["detail"]
    assert db_counts() == EMPTY


def test_list_filters_by_project_platform_and_date(settings):
    import copy

    from fastapi.testclient import TestClient

    from ldvsurvey.api.app import create_app
    from ldvsurvey.store.db import session_scope
    from ldvsurvey.store.users import create_user, new_api_token
    from tests.bundles import MANIFEST

    st = settings.model_copy(update={"auth_enabled": True})
    app = create_app(st)
    with session_scope(app.state.database_url) as s:
        u = create_user(s, "root", "root-password", is_admin=True)
        tok = new_api_token(s, u, "t")
    h = {"Authorization": f"Bearer {tok}"}
    with TestClient(app) as c:
        p2 = c.post("/api/admin/projects", json={"name": "second"}, headers=h).json()["id"]
        made = {}
        for seed, (date, platform, project) in enumerate(
            [("2023-03-20", "vehicle", None), ("2024-06-01", "vessel", None), ("2024-07-15", "vehicle", p2)]
        ):
            m = copy.deepcopy(MANIFEST)
            m["date"], m["platform"] = date, platform
            data = {"project_id": str(project)} if project else {}
            r = c.post(
                "/api/logs",
                headers=h,
                data=data,
                files=[("files", (n, d, "x")) for n, d in make_bundle(seed=80 + seed, n_imu=300, manifest=m).items()],
            )
            assert r.status_code == 201, r.text
            made[(date, platform)] = r.json()["id"]

        def ids(q):
            return sorted(lg["id"] for lg in c.get(f"/api/logs?{q}", headers=h).json())

        assert ids("") == sorted(made.values())
        assert ids("platform=vessel") == [made[("2024-06-01", "vessel")]]
        assert ids(f"project_id={p2}") == [made[("2024-07-15", "vehicle")]]
        assert ids("date_from=2024-01-01") == sorted([made[("2024-06-01", "vessel")], made[("2024-07-15", "vehicle")]])
        assert ids("date_to=2024-06-01&platform=vehicle") == [made[("2023-03-20", "vehicle")]]
        assert c.get("/api/logs?date_from=yesterday", headers=h).status_code == 422
