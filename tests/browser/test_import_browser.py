"""Foreign recordings dropped in the dashboard (real Chromium): the user sees the detected formats,
the time span, the rates and a GNSS track before confirming; the import then stores the bundle."""

from __future__ import annotations

import datetime as dt
import json

import httpx
import pytest

from ldvsurvey.sim import catalog
from ldvsurvey.sim.scenario import bundle_files, manifest, simulate
from tests.browser.helpers import shot
from tests.browser.test_dashboard import drop_files
from tests.io.import_helpers import kfgins_gnss, kfgins_imu

pytestmark = pytest.mark.browser


@pytest.fixture(scope="module")
def recordings():
    sim = simulate(catalog.drive(minutes=1.5, static_s=30.0), seed=12)
    day = dt.date.fromisoformat(sim.scenario.date)
    partial = manifest(sim)
    partial.pop("format")
    partial["name"] = "KF-GINS drive dropped in the browser"
    return sim, {
        "imu.txt": kfgins_imu(sim.imu.t_s, sim.dtheta_rad, sim.dvel_mps, day),
        "gnss.txt": kfgins_gnss(sim.gnss_t_s, sim.gnss_lat_deg, sim.gnss_lon_deg, sim.gnss_h_m, sim.gnss_fix, day),
        "ldv.csv": bundle_files(sim)["ldv.csv"],
        "partial.json": json.dumps(partial).encode(),
    }


def test_drop_foreign_files_preview_then_confirm(server, page, recordings):
    sim, files = recordings
    page.goto(server + "/#/logs")
    page.wait_for_selector("#drop")
    drop_files(page, files)
    page.wait_for_selector("#import-preview", timeout=60000)
    formats = page.locator("#import-files td.fmt").all_inner_texts()
    assert sorted(formats) == ["kf-gins", "kf-gins", "native"]
    span = page.inner_text("#import-span")
    assert sim.scenario.date in span and "08:20:00 UTC" in span  # t0 = 30000 s of day
    assert f"{(sim.imu.t_s[-1] - 30000.0) / 60:.1f} min" in span
    rates = page.inner_text("#import-rates")
    assert "IMU 100.0 Hz" in rates and "LDV 100.0 Hz" in rates and "GNSS 1.00 Hz" in rates and "FRD" in rates
    checks = page.inner_text("#import-checks")  # the simulated drive stands still for 30 s at the start
    assert "normal gravity" in checks and "Earth rate 15.041" in checks and "GNSS covers" in checks
    page.wait_for_selector("#import-track .main-svg")  # the Plotly GNSS track
    n_points = page.evaluate("document.getElementById('import-track').data[0].x.length")
    assert n_points == int((sim.gnss_fix > 0).sum())
    shot(page, "import-preview")
    assert not [
        lg for lg in httpx.get(server + "/api/logs").json() if lg["name"] == "KF-GINS drive dropped in the browser"
    ]
    page.click("#import-confirm")
    page.wait_for_selector("#upload-ok", timeout=60000)
    logs = [lg for lg in httpx.get(server + "/api/logs").json() if lg["name"] == "KF-GINS drive dropped in the browser"]
    assert len(logs) == 1
    names = {f["name"] for f in httpx.get(f"{server}/api/logs/{logs[0]['id']}").json()["files"]}
    assert {"original-imu.txt", "original-gnss.txt", "imu.csv", "gnss.nmea"} <= names
    page.goto(f"{server}/#/logs/{logs[0]['id']}")  # the log page keeps the import's checks
    page.wait_for_selector("#import-checks", timeout=30000)
    assert "normal gravity" in page.inner_text("#import-checks")


def test_drop_unrecognised_file_shows_the_file(server, page):
    page.goto(server + "/#/logs")
    page.wait_for_selector("#drop")
    drop_files(page, {"notes.bin": b"\x00\x01\x02 not a recording"})
    page.wait_for_selector("#upload-error", timeout=30000)
    assert "notes.bin" in page.inner_text("#upload-error")


def test_ubx_without_axes_asks_for_them(server, page):
    """A u-blox recording has no default sensor frame: the refusal names the axis carrying gravity and the
    page asks for the axes, then previews with them."""
    from pathlib import Path

    ex = Path(__file__).resolve().parents[2] / "docs" / "examples"
    page.goto(server + "/#/logs")
    page.wait_for_selector("#drop")
    files = {
        "receiver.ubx": (ex / "ubx" / "receiver.ubx").read_bytes(),
        "ldv.csv": (ex / "ldv.csv").read_bytes(),
        "partial.json": (ex / "partial.json").read_bytes(),
    }
    drop_files(page, files)
    page.wait_for_selector("#axes-input", timeout=60000)
    assert "-z axis" in page.inner_text("#upload-error")
    page.fill("#axes-input", "FRD")
    page.click("#axes-retry")
    page.wait_for_selector("#import-preview", timeout=60000)
    assert "FRD" in page.inner_text("#import-rates") and "ESF-RAW time base" in page.inner_text("#import-checks")
