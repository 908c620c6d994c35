"""Write every format, parse it back, compare."""

import json

import numpy as np
import pytest

from ldvsurvey.io.drivelog import fd_to_v_fwd, parse_files, read_zip
from ldvsurvey.io.manifest import parse_manifest
from ldvsurvey.io.nmea import parse_nmea
from ldvsurvey.io.quality import quality_report
from ldvsurvey.io.writers import imu_csv, ldv_csv, nmea_text
from tests.bundles import MANIFEST, make_arrays, make_bundle, zip_bytes
from tests.helpers.samples import sample_zip


def test_imu_and_ldv_round_trip_bit_exact():
    a = make_arrays(n_imu=3000, seed=3, rotating=True)
    files = make_bundle(seed=3, n_imu=3000, rotating=True)
    log = parse_files(files)
    np.testing.assert_array_equal(log.imu.t_s, a["t"])
    np.testing.assert_array_equal(log.imu.dtheta_rad, a["dtheta"])
    np.testing.assert_array_equal(log.imu.dvel_mps, a["dvel"])
    np.testing.assert_array_equal(log.imu.turntable_deg, a["turn"])
    np.testing.assert_array_equal(log.ldv.v_fwd_mps, a["v_fwd"])
    np.testing.assert_array_equal(log.ldv.v_up_mps, a["v_up"])
    np.testing.assert_array_equal(log.ldv.quality, a["quality"])


def test_fd_hz_converted_with_the_optics():
    files = make_bundle(seed=4, fd=True)
    log = parse_files(files)
    a = make_arrays(seed=4)
    fd = a["v_fwd"] * 1e5
    # independent: lambda0 = c0/f_i; v = c0 fD / (2 n_a f_i sin(theta/2)); v_fwd = v / cos(lambda_s)
    c0 = 299792458.0
    f_i = c0 / 1064e-9
    v = c0 * fd / (2 * 1.00027 * f_i * np.sin(np.radians(5.0)))
    np.testing.assert_allclose(log.ldv.v_fwd_mps, v / np.cos(np.radians(30.0)), rtol=1e-13)
    assert log.ldv.source == "fd_hz"
    np.testing.assert_allclose(
        fd_to_v_fwd(np.array([1e6]), log.manifest.ldv.optics),
        [1064e-9 * 1e6 / (2 * 1.00027 * np.sin(np.radians(5))) / np.cos(np.radians(30))],
    )


def test_nmea_round_trip_with_fix_changes_and_midnight():
    t = 86390.0 + np.arange(30.0)  # crosses midnight at index 10
    lat = 28.1 + 1e-5 * np.arange(30)
    lon = -112.9 - 1e-5 * np.arange(30)
    h = 40 + 0.1 * np.arange(30)
    fix = np.array([4] * 10 + [0] * 5 + [1, 2, 5] * 5)
    data = nmea_text(t, lat, lon, h, fix, sep_m=-18.5, talker="GN")
    g = parse_nmea(data, t_ref_s=86380.0)
    np.testing.assert_allclose(g.t_s, t)  # keeps counting past 86400
    ok = fix > 0
    np.testing.assert_allclose(g.lat_deg[ok], lat[ok], atol=1e-10)
    np.testing.assert_allclose(g.lon_deg[ok], lon[ok], atol=1e-10)
    np.testing.assert_allclose(g.h_m[ok], h[ok], atol=1e-4)  # ellipsoidal = altitude + separation
    assert np.all(np.isnan(g.lat_deg[~ok]))
    np.testing.assert_array_equal(g.fix, fix)
    assert g.skipped_sentences == {"GSA": 30}


def test_nmea_bad_checksum_skipped_and_counted_and_talkers_mixed():
    good = (
        nmea_text(
            np.array([100.0, 101.0, 102.0]),
            np.full(3, 10.0),
            np.full(3, 20.0),
            np.full(3, 5.0),
            np.full(3, 4),
            talker="GP",
            extra_sentences=False,
        )
        .decode()
        .splitlines()
    )
    gn = (
        nmea_text(
            np.array([103.0]),
            np.full(1, 10.0),
            np.full(1, 20.0),
            np.full(1, 5.0),
            np.full(1, 4),
            talker="GN",
            extra_sentences=False,
        )
        .decode()
        .splitlines()
    )
    corrupt = good[1][:-2] + ("00" if not good[1].endswith("00") else "11")
    lines = [good[0], corrupt, good[2], gn[0], "$GPRMC,unknown*00", "$PUBX,00,foo*7F"]
    g = parse_nmea(("\n".join(lines)).encode(), t_ref_s=100.0)
    np.testing.assert_array_equal(g.t_s, [100.0, 102.0, 103.0])
    assert g.bad_checksum >= 2  # the corrupted GGA, and the made-up RMC/PUBX whose checksums are wrong


def test_manifest_unknown_keys_kept():
    m = parse_manifest(json.dumps(MANIFEST).encode())
    assert m.model_extra["vendor_extra"] == {"kept": True}
    assert m.ldv.kind == "2d" and m.imu.rate_hz == 100.0


def test_zip_and_folder_prefix_equivalent():
    files = make_bundle(seed=5)
    z = zip_bytes({f"run2/{k}": v for k, v in files.items()})
    assert read_zip(z, 10**9) == files


def test_quality_report_counts():
    files = make_bundle(seed=6, n_imu=3000)
    rep = quality_report(parse_files(files))
    a = make_arrays(n_imu=3000, seed=6)
    assert rep["imu"]["n"] == 3000 and rep["imu"]["gaps"] == 0
    assert rep["imu"]["rate_hz"] == pytest.approx(100.0)
    assert rep["ldv"]["below_min_quality"] == int(np.sum(a["quality"] < 100))
    fix = a["gnss"]["fix"]
    assert rep["gnss"]["fix_time_share"]["differential"] == pytest.approx(np.mean(fix == 2))
    assert rep["gnss"]["fix_time_share"]["rtk_fixed"] == pytest.approx(np.mean(fix == 4))


def test_quality_report_sees_gaps():
    a = make_arrays(n_imu=1000, seed=7)
    t = a["t"].copy()
    t[500:] += 0.37  # one gap of 0.38 s
    files = make_bundle(seed=7, n_imu=1000)
    files["imu.csv"] = imu_csv(t, a["dtheta"], a["dvel"])
    rep = quality_report(parse_files(files))
    assert rep["imu"]["gaps"] == 1
    assert rep["imu"]["longest_gap_s"] == pytest.approx(0.38)


def test_exactly_repeated_row_is_dropped_and_counted():
    a = make_arrays(n_imu=500, seed=8)
    idx = np.r_[np.arange(300), 299, np.arange(300, 500)]
    files = make_bundle(seed=8, n_imu=500)
    files["ldv.csv"] = ldv_csv(
        a["t"][idx], v_fwd_mps=a["v_fwd"][idx], v_up_mps=a["v_up"][idx], quality=a["quality"][idx]
    )
    log = parse_files(files)
    assert log.ldv.duplicated_rows == 1 and len(log.ldv.t_s) == 500


@pytest.mark.parametrize("name", ["fixed-imu-2d-ldv-8min", "rotating-imu-1d-ldv-8min", "vessel-water-ldv-8min"])
def test_independent_samples_validate(name):
    path = sample_zip(name)
    from ldvsurvey.io.drivelog import load_bundle

    log = load_bundle(path)
    rep = quality_report(log)
    assert rep["imu"]["n"] == 48000 and rep["imu"]["gaps"] == 0
    assert rep["gnss"]["n"] == 481 and rep["gnss"]["skipped_sentences"]["RMC"] == 481
    assert (log.imu.turntable_deg is not None) == ("rotating" in name)
    assert rep["ldv"]["below_min_quality"] > 0
