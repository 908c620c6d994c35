"""Acceptance: a drive in KF-GINS text (IMU + GNSS) plus a native ldv.csv, imported with
``ldv-survey import``, validates, and navigate/gravity on it agree with the native bundle."""

from __future__ import annotations

import datetime as dt
import json
import zipfile

import numpy as np
import pytest

from ldvsurvey.cli import main
from ldvsurvey.io.drivelog import load_bundle, parse_files
from ldvsurvey.pipelines.base import run_pipeline
from ldvsurvey.pipelines.registry import get
from ldvsurvey.sim import catalog
from ldvsurvey.sim.scenario import bundle_files, simulate
from tests.io.import_helpers import kfgins_gnss, kfgins_imu

R_EARTH_M = 6.371e6


@pytest.fixture(scope="module")
def drive(tmp_path_factory):
    """Two repeated 3-km gravity lines (fixed IMU, 2-D LDV, partly degraded GNSS), ~16 min."""
    sc = catalog.gravity(n_lines=2, line_km=3.0)
    sim = simulate(sc, seed=3)
    files = bundle_files(sim)
    day = dt.date.fromisoformat(sc.date)
    d = tmp_path_factory.mktemp("kfgins")
    (d / "imu.txt").write_bytes(kfgins_imu(sim.imu.t_s, sim.dtheta_rad, sim.dvel_mps, day))
    (d / "gnss.txt").write_bytes(
        kfgins_gnss(sim.gnss_t_s, sim.gnss_lat_deg, sim.gnss_lon_deg, sim.gnss_h_m, sim.gnss_fix, day)
    )
    (d / "ldv.csv").write_bytes(files["ldv.csv"])
    partial = json.loads(files["manifest.json"])
    for key in ("format",):  # what the recordings hold is taken from them
        partial.pop(key)
    partial["imu"].pop("rate_hz")
    partial["ldv"].pop("rate_hz")
    (d / "partial.json").write_text(json.dumps(partial))
    return sim, files, d


@pytest.fixture(scope="module")
def imported(drive):
    _, _, d = drive
    out = d / "bundle.zip"
    rc = main(
        [
            "import",
            "--imu",
            f"kf-gins:{d / 'imu.txt'}",
            "--gnss",
            f"kf-gins:{d / 'gnss.txt'}",
            "--ldv",
            f"native:{d / 'ldv.csv'}",
            "--manifest",
            str(d / "partial.json"),
            "--out",
            str(out),
        ]
    )
    assert rc == 0
    return load_bundle(out)


def test_import_validates_and_matches_the_simulation(drive, imported, capsys):
    sim, files, d = drive
    assert main(["validate", str(d / "bundle.zip")]) == 0
    native = parse_files(files)
    # times exact (both sides are the same decimal numbers), increments bitwise: KF-GINS text is float text
    np.testing.assert_array_equal(imported.imu.t_s, native.imu.t_s)
    np.testing.assert_allclose(imported.imu.dtheta_rad, sim.dtheta_rad, rtol=0, atol=1e-15)
    np.testing.assert_allclose(imported.imu.dvel_mps, sim.dvel_mps, rtol=0, atol=1e-15)
    assert imported.manifest.imu.rate_hz == 100.0 and imported.manifest.ldv.rate_hz == 100.0
    assert str(imported.manifest.date) == sim.scenario.date
    ok = native.gnss.fix > 0  # KF-GINS files have no rows without a fix
    np.testing.assert_array_equal(imported.gnss.t_s, native.gnss.t_s[ok])
    np.testing.assert_array_equal(imported.gnss.fix, native.gnss.fix[ok])
    np.testing.assert_allclose(imported.gnss.h_m, native.gnss.h_m[ok], atol=2e-4)  # GGA keeps 0.1 mm
    prov = json.loads(imported.files["manifest.json"])["import"]["provenance"]
    assert prov["gps_minus_utc_s"] == 18 and prov["imu_axes"] == "FRD"
    assert {s["file"] for s in prov["sources"]} == {"imu.txt", "gnss.txt", "ldv.csv"}


def _horizontal_m(a, b):
    dlat = np.radians(np.asarray(a["lat_deg"]) - np.asarray(b["lat_deg"]))
    dlon = np.radians(np.asarray(a["lon_deg"]) - np.asarray(b["lon_deg"])) * np.cos(np.radians(a["lat_deg"]))
    return R_EARTH_M * np.hypot(dlat, dlon)


def test_navigate_and_gravity_agree_with_the_native_bundle(drive, imported):
    _, files, _ = drive
    native = parse_files(files)
    for params in ({"aiding": "ldv+gnss"},):
        ra = run_pipeline(get("navigate"), [native], params).tables["trajectory"]
        rb = run_pipeline(get("navigate"), [imported], params).tables["trajectory"]
        np.testing.assert_array_equal(ra["t_s"], rb["t_s"])
        assert np.max(_horizontal_m(ra, rb)) < 0.02
        assert np.max(np.abs(np.asarray(ra["h_m"]) - np.asarray(rb["h_m"]))) < 0.02
    ga = run_pipeline(get("gravity"), [native], {})
    gb = run_pipeline(get("gravity"), [imported], {})
    assert len(ga.tables["gravity"]["dg_mgal"]) == len(gb.tables["gravity"]["dg_mgal"]) > 100
    assert np.max(np.abs(np.asarray(ga.tables["gravity"]["dg_mgal"]) - gb.tables["gravity"]["dg_mgal"])) < 0.05
    assert gb.summary["total_mgal"] == pytest.approx(ga.summary["total_mgal"], abs=0.05)


def test_swapped_axes_are_refused_naming_the_axis(drive, tmp_path):
    """Declaring the FRD file as RFU puts gravity's reaction on a 'down' axis: a clear error, no output."""
    _, _, d = drive
    partial = json.loads((d / "partial.json").read_text())
    partial["import"] = {"imu": {"axes": "RFU"}}
    (tmp_path / "p.json").write_text(json.dumps(partial))
    out = tmp_path / "b.zip"
    rc = main(
        [
            "import",
            "--imu",
            f"kf-gins:{d / 'imu.txt'}",
            "--ldv",
            f"native:{d / 'ldv.csv'}",
            "--manifest",
            str(tmp_path / "p.json"),
            "--out",
            str(out),
        ]
    )
    assert rc == 2 and not out.exists()


def test_swapped_axes_message(drive):
    from ldvsurvey.errors import BundleError
    from ldvsurvey.io.importers import Source, build_bundle

    _, _, d = drive
    partial = json.loads((d / "partial.json").read_text())
    partial["import"] = {"imu": {"axes": "RFU"}}
    with pytest.raises(BundleError) as e:
        build_bundle(
            [
                Source("imu", "kf-gins", "imu.txt", (d / "imu.txt").read_bytes()),
                Source("ldv", "native", "ldv.csv", (d / "ldv.csv").read_bytes()),
            ],
            partial,
        )
    msg = str(e.value)
    assert "imu.txt" in msg and "-z axis" in msg and "swapped" in msg


def test_bad_kfgins_row_names_file_line_field(tmp_path):
    from ldvsurvey.errors import BundleError
    from ldvsurvey.io.importers import get_importer

    bad = b"388800.01 0 0 0 0 0 -0.098\n388800.02 0 0 x 0 0 -0.098\n"
    with pytest.raises(BundleError) as e:
        get_importer("kf-gins").read(bad, "imu.txt", "imu", {})
    assert (e.value.file, e.value.line, e.value.field) == ("imu.txt", 2, "dtheta_z")
    with pytest.raises(BundleError) as e:
        get_importer("kf-gins").read(b"388800.0 28.1 113.0 40.0 0.02 0.02\n", "gnss.txt", "gnss", {})
    assert (e.value.line, e.value.field) == (1, "sigma_d_m")


def test_missing_date_is_a_clear_error(drive):
    from ldvsurvey.errors import BundleError
    from ldvsurvey.io.importers import Source, build_bundle

    _, _, d = drive
    partial = json.loads((d / "partial.json").read_text())
    partial.pop("date")
    with pytest.raises(BundleError) as e:
        build_bundle(
            [
                Source("imu", "kf-gins", "imu.txt", (d / "imu.txt").read_bytes()),
                Source("ldv", "native", "ldv.csv", (d / "ldv.csv").read_bytes()),
            ],
            partial,
        )
    assert e.value.field == "date"


def test_zip_holds_only_bundle_files(drive, imported):
    _, _, d = drive
    with zipfile.ZipFile(d / "bundle.zip") as zf:
        assert sorted(zf.namelist()) == ["gnss.nmea", "imu.csv", "ldv.csv", "manifest.json"]
