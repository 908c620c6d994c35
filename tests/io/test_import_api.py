"""Foreign files through the REST API (preview, import, originals kept) and GIS downloads of results."""

from __future__ import annotations

import datetime as dt
import hashlib
import json
from pathlib import Path

import numpy as np
import pytest

from ldvsurvey.sim import catalog
from ldvsurvey.sim.scenario import bundle_files, manifest, simulate
from tests.io.import_helpers import kfgins_gnss, kfgins_imu


@pytest.fixture(scope="module")
def recordings():
    sim = simulate(catalog.drive(minutes=2.5, static_s=30.0), seed=8)
    day = dt.date.fromisoformat(sim.scenario.date)
    files = bundle_files(sim)
    partial = manifest(sim)
    for k in ("format",):
        partial.pop(k)
    return (
        sim,
        {
            "imu.txt": kfgins_imu(sim.imu.t_s, sim.dtheta_rad, sim.dvel_mps, day),
            "gnss.txt": kfgins_gnss(sim.gnss_t_s, sim.gnss_lat_deg, sim.gnss_lon_deg, sim.gnss_h_m, sim.gnss_fix, day),
            "ldv.csv": files["ldv.csv"],
        },
        partial,
    )


def _multipart(files):
    return [("files", (n, d, "application/octet-stream")) for n, d in files.items()]


def test_preview_detects_formats_span_rates_track(client, recordings, db_counts):
    sim, files, partial = recordings
    r = client.post("/api/imports/preview", files=_multipart(files), data={"manifest": json.dumps(partial)})
    assert r.status_code == 200, r.text
    p = r.json()
    assert {(f["name"], f["format"], f["role"]) for f in p["files"]} == {
        ("imu.txt", "kf-gins", "imu"),
        ("gnss.txt", "kf-gins", "gnss"),
        ("ldv.csv", "native", "ldv"),
    }
    assert p["time_span_s"][0] == pytest.approx(min(sim.imu.t_s[0], sim.ldv_t_s[0], sim.gnss_t_s[0]), abs=1e-9)
    assert p["time_span_s"][1] == pytest.approx(max(sim.imu.t_s[-1], sim.ldv_t_s[-1], sim.gnss_t_s[-1]), abs=1e-9)
    assert p["rates_hz"] == {"imu": 100.0, "ldv": 100.0, "gnss": 1.0}
    track = np.array(p["gnss_track"])
    np.testing.assert_allclose(track[0], [sim.gnss_lon_deg[0], sim.gnss_lat_deg[0]], atol=1e-8)  # lon, lat order
    assert db_counts() == {"logs": 0, "log_files": 0, "log_arrays": 0}  # a preview stores nothing


def test_import_stores_bundle_and_originals(client, recordings, db_counts):
    _, files, partial = recordings
    r = client.post("/api/imports", files=_multipart(files), data={"manifest": json.dumps(partial)})
    assert r.status_code == 201, r.text
    log_id = r.json()["id"]
    names = {f["name"] for f in client.get(f"/api/logs/{log_id}").json()["files"]}
    assert names == {
        "manifest.json",
        "imu.csv",
        "ldv.csv",
        "gnss.nmea",
        "original-imu.txt",
        "original-gnss.txt",
        "original-ldv.csv",
    }
    for name, data in files.items():
        got = client.get(f"/api/logs/{log_id}/files/original-{name}")
        assert got.content == data and got.headers["x-content-sha256"] == hashlib.sha256(data).hexdigest()
    again = client.post("/api/imports", files=_multipart(files), data={"manifest": json.dumps(partial)})
    assert again.status_code == 200 and again.json()["duplicate"] is True
    assert db_counts()["logs"] == 1


def test_bad_foreign_file_is_422_and_stores_nothing(client, recordings, db_counts):
    _, files, partial = recordings
    bad = dict(files)
    lines = bad["imu.txt"].split(b"\n")
    lines[41] = lines[41].replace(b" ", b" nan ", 1)
    bad["imu.txt"] = b"\n".join(lines)
    r = client.post("/api/imports", files=_multipart(bad), data={"manifest": json.dumps(partial)})
    assert r.status_code == 422
    err = r.json()["error"]
    assert err["file"] == "imu.txt" and err["line"] == 42 and err["field"] == "gps_sow" or err["field"] == "dtheta_x"
    unknown = {"notes.bin": b"\x00\x01garbage", **files}
    r = client.post("/api/imports/preview", files=_multipart(unknown), data={"manifest": json.dumps(partial)})
    assert r.status_code == 422 and r.json()["error"]["file"] == "notes.bin"
    assert db_counts() == {"logs": 0, "log_files": 0, "log_arrays": 0}


def test_job_download_as_geojson_and_kml(client, recordings):
    """A navigate result stored as a job; its trajectory downloaded with format=geojson|kml."""
    geojson = pytest.importorskip("geojson")
    shapely_geometry = pytest.importorskip("shapely.geometry")
    from ldvsurvey.io.drivelog import parse_files
    from ldvsurvey.pipelines.base import result_files, run_pipeline
    from ldvsurvey.pipelines.registry import get
    from ldvsurvey.store.db import session_scope
    from ldvsurvey.store.models import Job, JobFile

    sim, files, partial = recordings
    r = client.post("/api/imports", files=_multipart(files), data={"manifest": json.dumps(partial)})
    log_id = r.json()["id"]
    log = parse_files(
        {
            n: client.get(f"/api/logs/{log_id}/files/{n}").content
            for n in ("manifest.json", "imu.csv", "ldv.csv", "gnss.nmea")
        }
    )
    res = run_pipeline(get("navigate"), [log], {"aiding": "ldv+gnss"})
    with session_scope(client.app_state.database_url) as s:
        job = Job(pipeline="navigate", log_ids=[log_id], parameters={}, status="succeeded", stage="done", progress=1.0)
        s.add(job)
        s.flush()
        for name, content in result_files(res).items():
            s.add(JobFile(job_id=job.id, name=name, size_bytes=len(content), content=content))
        job_id = job.id
    g = client.get(f"/api/jobs/{job_id}/files/trajectory.csv?format=geojson")
    assert g.status_code == 200 and g.headers["content-type"].startswith("application/geo+json")
    assert geojson.loads(g.text).is_valid  # an independent validator (it rounds coordinates: compare on json)
    fc = json.loads(g.text)
    assert fc["type"] == "FeatureCollection"
    line = shapely_geometry.shape(fc["features"][0]["geometry"])
    assert line.geom_type == "LineString" and line.is_valid
    lon0, lat0 = line.coords[0][:2]
    assert lon0 == pytest.approx(res.tables["trajectory"]["lon_deg"][0], abs=1e-9)  # RFC 7946: lon, lat
    assert lat0 == pytest.approx(res.tables["trajectory"]["lat_deg"][0], abs=1e-9)
    assert fc["provenance"]["pipeline"] == "navigate"
    assert {i["file"] for i in fc["provenance"]["inputs"]} >= {"imu.csv", "ldv.csv", "gnss.nmea"}
    k = client.get(f"/api/jobs/{job_id}/files/trajectory.csv?format=kml")
    assert k.status_code == 200 and b'xmlns="http://www.opengis.net/kml/2.2"' in k.content
    assert client.get(f"/api/jobs/{job_id}/files/trajectory.csv?format=shp").status_code == 422
    missing = client.get(f"/api/jobs/{job_id}/files/no_such.csv?format=geojson")
    assert missing.status_code == 404 and missing.json()["detail"] == f"job {job_id} has no file 'no_such.csv'"


def test_formats_hint_and_partial_manifest_as_a_json_file(client):
    """A CSV needs its format named (form field ``formats``); a .json part is the partial manifest."""
    from pathlib import Path

    ex = Path(__file__).resolve().parents[2] / "docs" / "examples"
    files = {
        "imu.csv": (ex / "csv" / "imu.csv").read_bytes(),
        "receiver.nmea": (ex / "nmea" / "receiver.nmea").read_bytes(),
        "ldv.csv": (ex / "ldv.csv").read_bytes(),
        "partial.json": (ex / "csv" / "partial.json").read_bytes(),
    }
    r = client.post("/api/imports/preview", files=_multipart(files))
    assert r.status_code == 422 and r.json()["error"]["file"] == "imu.csv"  # a CSV is not guessed
    r = client.post(
        "/api/imports/preview", files=_multipart(files), data={"formats": json.dumps({"imu.csv": "csv:imu"})}
    )
    assert r.status_code == 200, r.text
    p = r.json()
    assert {(f["name"], f["format"], f["role"]) for f in p["files"]} == {
        ("imu.csv", "csv", "imu"),
        ("receiver.nmea", "nmea", "gnss"),
        ("ldv.csv", "native", "ldv"),
    }
    assert p["imu_axes"] == "FLU" and p["date"] == "2023-03-20" and p["rates_hz"]["imu"] == 100.0
    r = client.post("/api/imports/preview", files=_multipart(files), data={"formats": json.dumps({"imu.csv": "sbf"})})
    assert r.status_code == 422 and r.json()["error"]["file"] == "formats"


def test_admin_import_without_project_lands_in_their_own_project(settings, recordings):
    """As an upload does: an admin's import without ``project_id`` goes to a project of theirs, not nowhere."""
    from fastapi.testclient import TestClient

    from ldvsurvey.api.app import create_app

    st = settings.model_copy(update={"auth_enabled": True, "admin_user": "root", "admin_password": "first-admin-pw"})
    _, files, partial = recordings
    with TestClient(create_app(st)) as c:
        r = c.post("/api/login", json={"username": "root", "password": "first-admin-pw"})
        h = {"X-CSRF-Token": r.json()["csrf"]}
        own = c.post("/api/imports", files=_multipart(files), data={"manifest": json.dumps(partial)}, headers=h)
        assert own.status_code == 201, own.text
        assert own.json()["project_id"] is not None
        missing = c.post(
            "/api/imports",
            files=_multipart(files),
            data={"manifest": json.dumps(partial), "project_id": "999"},
            headers=h,
        )
        assert missing.status_code == 404


def test_import_without_ldv_through_the_api(client, recordings):
    """KF-GINS IMU and GNSS only, the partial manifest still carrying a template's ldv section: a
    bundle without ldv.csv is stored, the section left out with a warning; navigate applies, height not."""
    _, files, partial = recordings
    ins_gnss = {k: v for k, v in files.items() if k != "ldv.csv"}
    r = client.post("/api/imports", files=_multipart(ins_gnss), data={"manifest": json.dumps(partial)})
    assert r.status_code == 201, r.text
    body = r.json()
    assert body["ldv_kind"] == "none" and body["quality"]["ldv"] is None
    assert any("ldv section was left out" in w for w in body["import"]["warnings"]), body["import"]
    names = {f["name"] for f in client.get(f"/api/logs/{body['id']}").json()["files"]}
    assert "ldv.csv" not in names and {"imu.csv", "gnss.nmea"} <= names
    at = {p["name"]: p for p in client.get(f"/api/pipelines?log_id={body['id']}").json()}
    assert at["navigate"]["applicable"] and at["dov"]["applicable"] and not at["height"]["applicable"]
    # an IMU alone is refused, naming what is missing
    r = client.post(
        "/api/imports", files=_multipart({"imu.txt": files["imu.txt"]}), data={"manifest": json.dumps(partial)}
    )
    assert r.status_code == 422 and "GNSS or an LDV" in r.json()["error"]["message"], r.text


def test_axes_form_field_for_a_ubx_recording(client):
    """u-blox has no default sensor frame: without axes the preview is a 422 naming them and the axis that
    carries gravity; the form field `axes` gives them for any format."""
    ex = Path(__file__).resolve().parents[2] / "docs" / "examples"
    files = {"receiver.ubx": (ex / "ubx" / "receiver.ubx").read_bytes(), "ldv.csv": (ex / "ldv.csv").read_bytes()}
    data = {"manifest": (ex / "partial.json").read_text(), "formats": json.dumps({"receiver.ubx": "ubx:imu"})}
    r = client.post("/api/imports/preview", files=_multipart(files), data=data)
    err = r.json()["error"]
    assert r.status_code == 422 and err["field"] == "axes" and "-z axis" in err["message"]
    r = client.post("/api/imports/preview", files=_multipart(files), data={**data, "axes": "FRD"})
    assert r.status_code == 200, r.text
    assert r.json()["imu_axes"] == "FRD" and r.json()["checks"]["imu_source"]["time_base"]["message"] == "ESF-RAW"
