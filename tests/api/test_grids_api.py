"""Uploaded .gdf deflection grids over HTTP: validation naming file/line/field, and a job using them."""

import time

import numpy as np
import pytest

from ldvsurvey.io.gdf import write_gdf
from ldvsurvey.sim import catalog
from ldvsurvey.sim.scenario import bundle_files, simulate
from tests.bundles import zip_bytes


@pytest.fixture(scope="module")
def small_drive():
    sc = catalog.drive(minutes=3.0, static_s=60.0)
    sim = simulate(sc, seed=3)
    lat, lon = np.degrees(sim.imu.lat_rad), np.degrees(sim.imu.lon_rad)
    st = 0.5 / 60
    la = np.arange(np.floor(lat.min() / st) - 2, np.ceil(lat.max() / st) + 3) * st
    lo = np.arange(np.floor(lon.min() / st) - 2, np.ceil(lon.max() / st) + 3) * st
    xi = 5.0 + 0.0 * la[:, None] + 0.0 * lo[None, :]  # arcsec
    eta = -3.0 + 0.0 * xi
    return zip_bytes(bundle_files(sim)), write_gdf(la, lo, xi, "xi", "arcsec"), write_gdf(la, lo, eta, "eta", "arcsec")


def _grid_rows(client):
    from sqlalchemy import text

    from ldvsurvey.store.db import get_engine

    with get_engine(client.app_state.database_url).connect() as c:
        return c.execute(text("SELECT count(*) FROM dov_grids")).scalar()


def _wait(client, job_id, timeout_s=180.0):
    t0 = time.monotonic()
    while time.monotonic() - t0 < timeout_s:
        j = client.get(f"/api/jobs/{job_id}").json()
        if j["status"] in ("succeeded", "failed", "cancelled"):
            return j
        time.sleep(0.5)
    raise AssertionError("job did not finish")


def test_bad_grid_is_refused_with_file_line_field(client, small_drive):
    _, g_xi, g_eta = small_drive
    lines = g_xi.decode().splitlines()
    k = len(lines) - 2
    lines[k] = lines[k].split()[0] + " north 1.0"
    bad = ("\n".join(lines) + "\n").encode()
    r = client.post("/api/grids", files=[("xi", ("myxi.gdf", bad)), ("eta", ("myeta.gdf", g_eta))])
    assert r.status_code == 422, r.text
    err = r.json()["error"]
    assert err["file"] == "myxi.gdf" and err["line"] == k + 1
    r = client.post("/api/grids", files=[("xi", ("myxi.gdf", g_xi))])
    assert r.status_code == 422 and r.json()["error"]["field"] == "eta"
    assert _grid_rows(client) == 0  # nothing stored


def test_uploaded_grid_drives_a_job(client, small_drive):
    bundle, g_xi, g_eta = small_drive
    r = client.post("/api/grids", files=[("xi", ("xi.gdf", g_xi)), ("eta", ("eta.gdf", g_eta))])
    assert r.status_code == 201, r.text
    gid = r.json()["id"]
    assert client.get(f"/api/grids/{gid}").json()["has_dg"] is False
    r = client.post("/api/logs", files=[("files", ("b.zip", bundle, "application/zip"))])
    assert r.status_code == 201, r.text
    log_id = r.json()["id"]
    r = client.post(
        f"/api/logs/{log_id}/jobs",
        json={"pipeline": "navigate", "parameters": {"aiding": "gnss", "dov": "grid", "dov_grid_id": gid}},
    )
    assert r.status_code == 201, r.text
    j = _wait(client, r.json()["id"])
    assert j["status"] == "succeeded", j["error"]
    dov = j["summary"]["dov"]
    assert dov["source"] == "xi.gdf, eta.gdf"
    assert dov["xi_arcsec_max"] == pytest.approx(5.0) and dov["eta_arcsec_max"] == pytest.approx(3.0)
    # an unknown id fails the job with the field named
    r = client.post(
        f"/api/logs/{log_id}/jobs",
        json={
            "pipeline": "navigate",
            "parameters": {"aiding": "gnss", "dov": "grid", "dov_grid_id": "0123456789abcdef01234567"},
        },
    )
    j = _wait(client, r.json()["id"])
    assert j["status"] == "failed" and "dov_grid_id" in j["error"]
