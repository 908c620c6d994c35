"""Time scales (leap seconds, week roll-over, midnight), the NMEA and CSV importers."""

from __future__ import annotations

import datetime as dt
import json
from decimal import Decimal

import numpy as np
import pytest

from ldvsurvey.errors import BundleError
from ldvsurvey.io.drivelog import parse_files
from ldvsurvey.io.importers import Source, build_bundle, gpstime
from ldvsurvey.io.nmea import format_gga
from tests.helpers.nmea import sentence
from tests.io.import_helpers import sow_of_midnight

G = 9.80665
PARTIAL = {"platform": "vehicle", "ldv": {"kind": "1d"}, "imu": {"gyro_bias_dph": 0.01}}


def test_leap_seconds_against_known_dates():
    # published GPS - UTC values (IERS Bulletin C / GPS ICD): 0 at the GPS epoch, 13 in 2000, 18 since 2017
    assert gpstime.gps_minus_utc_s(dt.date(1980, 1, 6)) == 0
    assert gpstime.gps_minus_utc_s(dt.date(2000, 6, 1)) == 13
    assert gpstime.gps_minus_utc_s(dt.date(2016, 12, 31)) == 17
    assert gpstime.gps_minus_utc_s(dt.date(2017, 1, 1)) == 18
    assert gpstime.LEAP_TABLE_VALID_TO >= dt.date(2025, 12, 31)
    # GPS week 2245 began on Sunday 2023-01-15 (independent count: days since 1980-01-06 / 7)
    assert gpstime.gps_week_of(dt.date(2023, 1, 15), 18) == (2245, 18.0)
    assert gpstime.resolve_week(2245 % 1024, 2245) == 2245  # a 10-bit week number made whole


def _static_kfgins(t_s, day):
    _, s0 = sow_of_midnight(day)
    rows = []
    for t in t_s:
        sow = (Decimal(repr(float(t))) + s0) % 604800
        rows.append(f"{sow} 0 0 0 0 0 {-G * 0.01!r}")  # FRD: specific force up = -z
    return ("\n".join(rows) + "\n").encode()


def _ldv(t_s):
    return ("t,v_fwd\n" + "".join(f"{float(t)!r},0.0\n" for t in t_s)).encode()


def test_log_across_midnight_and_the_gps_week_roll_over():
    """Saturday 2023-01-14: UTC midnight at t = 86400, the GPS week ends 18 s earlier (SOW wraps to 0)."""
    day = dt.date(2023, 1, 14)
    t = np.round(86300.0 + np.arange(1, 20001) * 0.01, 2)  # 86300.01 ... 86500.00
    files = build_bundle(
        [
            Source("imu", "kf-gins", "imu.txt", _static_kfgins(t, day)),
            Source("ldv", "native", "ldv.csv", _ldv(t[::10])),
        ],
        {**PARTIAL, "date": "2023-01-14"},
    ).files
    log = parse_files(files)
    np.testing.assert_array_equal(log.imu.t_s, t)  # keeps counting past 86400, across the week wrap
    np.testing.assert_allclose(log.imu.dvel_mps[:, 2], G * 0.01)


def test_nmea_across_midnight_takes_the_date_from_rmc():
    t = np.arange(86390.0, 86411.0)
    lines = []
    for k, tt in enumerate(t):
        lines.append(format_gga(tt, 28.1 + 1e-6 * k, 113.0, 40.0, -16.5, 4))
        if k == 5:  # the same epoch from a second talker: kept once
            lines.append(format_gga(tt, 28.1 + 1e-6 * k, 113.0, 40.0, -16.5, 4, talker="GN"))
        if k == 0:
            lines.append(sentence("GPRMC,235950.00,A,2806.0000,N,11300.0000,E,0.0,0.0,200323,,,A"))
    lines.append("$GPGGA,000011.00,2806.00,N,11300.00,E,4,10,0.9,40.0,M,-16.5,M,,*00")  # bad checksum: skipped
    nmea = ("\r\n".join(lines) + "\r\n").encode()
    ti = np.round(86389.0 + np.arange(1, 2201) * 0.01, 2)
    imu = (
        "t,dtheta_x,dtheta_y,dtheta_z,dvel_x,dvel_y,dvel_z\n"
        + "".join(f"{float(x)!r},0,0,0,0,0,{G * 0.01!r}\n" for x in ti)
    ).encode()
    res = build_bundle(
        [
            Source("imu", "native", "imu.csv", imu),
            Source("gnss", "nmea", "rx.nmea", nmea),
            Source("ldv", "native", "ldv.csv", _ldv(ti[::10])),
        ],
        dict(PARTIAL),
    )
    log = parse_files(res.files)
    assert str(log.manifest.date) == "2023-03-20"
    np.testing.assert_array_equal(log.gnss.t_s, t)
    np.testing.assert_allclose(log.gnss.h_m, 40.0 - 16.5)
    assert any("bad checksum" in w for w in res.warnings)
    assert any("repeated GGA" in w for w in res.warnings)


def test_csv_column_map_with_rates_units_axes_and_unix_time():
    """Rates in deg/s and accelerations in g, axes x forward y left z up, UNIX time in ms."""
    rng = np.random.default_rng(1)
    n = 500
    t_bundle = 36000.0 + np.arange(1, n + 1) * 0.005  # 200 Hz
    unix0_ms = int((dt.datetime(2024, 2, 29) - dt.datetime(1970, 1, 1)).total_seconds() * 1000)
    w_rfu = rng.normal(0, 0.01, (n, 3))  # rad/s
    f_rfu = np.column_stack([rng.normal(0, 0.1, n), rng.normal(0, 0.1, n), np.full(n, G)])
    w_flu = np.column_stack([w_rfu[:, 1], -w_rfu[:, 0], w_rfu[:, 2]])
    f_flu = np.column_stack([f_rfu[:, 1], -f_rfu[:, 0], f_rfu[:, 2]])
    text = "time_ms;gx;gy;gz;ax;ay;az\n" + "".join(
        f"{unix0_ms + int(round(t * 1000))};"
        + ";".join(repr(float(x)) for x in np.degrees(w))
        + ";"
        + ";".join(repr(float(x)) for x in a / G)
        + "\n"
        for t, w, a in zip(t_bundle, w_flu, f_flu)
    )
    partial = {
        **PARTIAL,
        "import": {
            "imu": {
                "axes": "FLU",
                "csv": {
                    "delimiter": ";",
                    "time": {"column": "time_ms", "kind": "unix", "unit": "ms"},
                    "columns": {
                        **{f"dtheta_{a}": {"column": f"g{a}", "unit": "deg/s"} for a in "xyz"},
                        **{f"dvel_{a}": {"column": f"a{a}", "unit": "g"} for a in "xyz"},
                    },
                },
            }
        },
    }
    res = build_bundle(
        [Source("imu", "csv", "imu.txt", text.encode()), Source("ldv", "native", "ldv.csv", _ldv(t_bundle[::4]))],
        partial,
    )
    log = parse_files(res.files)
    assert str(log.manifest.date) == "2024-02-29" and log.manifest.imu.rate_hz == 200.0
    np.testing.assert_allclose(log.imu.t_s, t_bundle, atol=1e-9)
    np.testing.assert_allclose(log.imu.dtheta_rad, w_rfu * 0.005, rtol=1e-12, atol=1e-18)
    np.testing.assert_allclose(log.imu.dvel_mps, f_rfu * 0.005, rtol=1e-12, atol=1e-18)


def test_csv_errors_name_file_line_field():
    partial = {
        **PARTIAL,
        "date": "2023-03-20",
        "import": {
            "imu": {
                "csv": {
                    "time": {"column": 1, "kind": "bundle"},
                    "columns": {f"dtheta_{a}": i + 2 for i, a in enumerate("xyz")}
                    | {f"dvel_{a}": i + 5 for i, a in enumerate("xyz")},
                }
            }
        },
    }
    text = b"t,a,b,c,d,e,f\n1.0,0,0,0,0,0,0.098\n1.01,0,0,zz,0,0,0.098\n"
    with pytest.raises(BundleError) as e:
        build_bundle([Source("imu", "csv", "imu.txt", text), Source("ldv", "native", "ldv.csv", _ldv([1.0]))], partial)
    assert (e.value.file, e.value.line, e.value.field) == ("imu.txt", 3, "c")
    partial["import"]["imu"]["csv"]["columns"]["dvel_q"] = 3
    with pytest.raises(BundleError) as e:
        build_bundle([Source("imu", "csv", "imu.txt", text), Source("ldv", "native", "ldv.csv", _ldv([1.0]))], partial)
    assert e.value.field == "import.imu.csv.columns.dvel_q"


def test_unknown_format_and_time_going_backwards():
    with pytest.raises(BundleError) as e:
        build_bundle([Source("imu", "sbf", "x.sbf", b"")], {})
    assert "unknown import format" in str(e.value)
    day = dt.date(2023, 3, 20)
    data = _static_kfgins([100.0, 100.01, 100.005, 100.02], day)
    with pytest.raises(BundleError) as e:
        build_bundle(
            [Source("imu", "kf-gins", "imu.txt", data), Source("ldv", "native", "ldv.csv", _ldv([100.0]))],
            {**PARTIAL, "date": "2023-03-20"},
        )
    assert (e.value.file, e.value.line) == ("imu.txt", 3)


def test_leap_table_warning_after_its_validity():
    day = gpstime.LEAP_TABLE_VALID_TO + dt.timedelta(days=10)
    t = np.round(1000.0 + np.arange(1, 301) * 0.01, 2)
    res = build_bundle(
        [
            Source("imu", "kf-gins", "imu.txt", _static_kfgins(t, day)),
            Source("ldv", "native", "ldv.csv", _ldv(t[::10])),
        ],
        {**PARTIAL, "date": day.isoformat()},
    )
    assert any("leap-second table" in w for w in res.warnings)
    assert json.loads(res.files["manifest.json"])["import"]["provenance"]["gps_minus_utc_s"] == 18
