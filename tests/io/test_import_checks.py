"""Cross-checks at import: recording dates against the manifest, IMU/GNSS overlap, IMU rate, gravity and
Earth rate at rest. The example recordings of docs/examples (12 s of a simulated vehicle at rest in
Changsha, 2023-03-20, navigation-grade IMU) are the truth; each test breaks one thing."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from ldvsurvey.errors import BundleError
from ldvsurvey.io.importers import Source, build_bundle

EX = Path(__file__).resolve().parents[2] / "docs" / "examples"


def sources(imu=None, gnss=None):
    return [
        Source("imu", "kf-gins", "imu.txt", imu if imu is not None else (EX / "kf-gins/imu.txt").read_bytes()),
        Source("gnss", "nmea", "receiver.nmea", gnss if gnss is not None else (EX / "nmea/receiver.nmea").read_bytes()),
        Source("ldv", "native", "ldv.csv", (EX / "ldv.csv").read_bytes()),
    ]


def partial():
    return json.loads((EX / "partial.json").read_text())


def normal_gravity(lat_deg, h_m):
    """Somigliana (WGS-84) with the free-air gradient, written here independently of nav/earth."""
    s2 = math.sin(math.radians(lat_deg)) ** 2
    return 9.7803253359 * (1 + 0.00193185265241 * s2) / math.sqrt(1 - 0.00669437999013 * s2) - 3.086e-6 * h_m


def test_the_report_gives_the_figures():
    res = build_bundle(sources(), partial())
    ck = res.summary["checks"]
    g = ck["static_gravity"]
    lat, h = ck["static_gravity"]["at"]
    assert g["normal_mps2"] == pytest.approx(normal_gravity(lat, h), abs=2e-5)
    # the simulator's own gravity at rest: within its 20 µg accelerometer bias of normal gravity
    assert abs(g["error_rel"]) < 1e-4
    assert g["earth_rate_dph"] == pytest.approx(15.041, abs=1e-3)
    assert abs(g["earth_rate_error_dph"]) < 0.05  # gyro bias 0.003 °/h, ARW over 12 s
    assert ck["imu_rate"]["measured_hz"] == pytest.approx(100.0, rel=1e-6)
    assert ck["overlap"]["share"] > 0.9 and ck["dates"]["gnss"]["day"] == "2023-03-20"
    assert not any("normal gravity" in w or "Earth rate" in w for w in res.warnings)


def test_recording_dated_otherwise_than_the_manifest_is_refused():
    """The NMEA's RMC says 2023-03-20; a manifest saying 2022-03-20 put the fixes a year away (t ≈ −3e7 s)
    without a word before."""
    m = partial()
    m["date"] = "2022-03-20"
    with pytest.raises(BundleError) as e:
        build_bundle(sources(), m)
    assert e.value.file == "receiver.nmea" and e.value.field == "date" and "2023-03-20" in e.value.message


def test_no_overlap_is_refused_and_little_overlap_warned():
    text = (EX / "nmea/receiver.nmea").read_text()
    later = text.replace(",0820", ",0920")  # the same fixes an hour later (GGA/RMC times 08:20 -> 09:20)
    from tests.helpers.nmea import sentence

    fixed = "\r\n".join(sentence(s.strip()[1:].split("*")[0]) for s in later.splitlines() if s.strip()) + "\r\n"
    with pytest.raises(BundleError) as e:
        build_bundle(sources(gnss=fixed.encode()), partial())
    assert e.value.file == "receiver.nmea" and "do not overlap" in e.value.message
    half = "\r\n".join(text.splitlines()[: len(text.splitlines()) // 2]) + "\r\n"
    res = build_bundle(sources(gnss=half.encode()), partial())
    assert res.summary["checks"]["overlap"]["share"] < 0.9
    assert any("GNSS fixes cover" in w for w in res.warnings)


def _scaled_imu(gyro=1.0, acc=1.0):
    rows = []
    for line in (EX / "kf-gins/imu.txt").read_text().splitlines():
        p = line.split()
        v = [float(x) for x in p[1:]]
        rows.append(" ".join([p[0]] + [repr(x * gyro) for x in v[:3]] + [repr(x * acc) for x in v[3:]]))
    return ("\n".join(rows) + "\n").encode()


def test_gravity_far_off_is_refused_and_a_few_percent_warned():
    with pytest.raises(BundleError) as e:
        build_bundle(sources(imu=_scaled_imu(acc=1 / 9.80665)), partial())  # increments in g·s, not m/s
    assert e.value.file == "imu.txt" and "normal gravity" in e.value.message
    with pytest.raises(BundleError) as e:  # 2 % off: refused by default, naming what to set to accept it
        build_bundle(sources(imu=_scaled_imu(acc=1.02)), partial())
    assert e.value.file == "imu.txt" and "import.imu.static_gravity_tolerance" in e.value.message
    p = partial()
    p.setdefault("import", {}).setdefault("imu", {})["static_gravity_tolerance"] = 0.025
    res = build_bundle(sources(imu=_scaled_imu(acc=1.02)), p)
    assert res.summary["checks"]["static_gravity"]["error_rel"] == pytest.approx(0.02, abs=2e-4)
    assert any("normal gravity" in w and "accepted" in w for w in res.warnings)
    with pytest.raises(BundleError):  # never past 10 %, whatever is accepted
        p["import"]["imu"]["static_gravity_tolerance"] = 0.5
        build_bundle(sources(imu=_scaled_imu(acc=1.15)), p)


def test_earth_rate_for_a_navigation_grade_unit():
    res = build_bundle(sources(imu=_scaled_imu(gyro=math.pi / 180)), partial())  # gyro taken as deg, not rad
    assert any("Earth rate" in w for w in res.warnings)
    assert res.summary["checks"]["static_gravity"]["omega_dph"] == pytest.approx(15.041 * math.pi / 180, rel=0.01)


def test_declared_rate_against_measured():
    m = partial()
    m["imu"]["rate_hz"] = 200.0
    try:
        res = build_bundle(sources(), m)
    except BundleError:
        return  # the bundle validation may refuse it outright: no silent mismatch either way
    assert res.summary["checks"]["imu_rate"]["error_rel"] == pytest.approx(-0.5, abs=1e-6)
    assert any("declares 200.0 Hz" in w for w in res.warnings)


def test_axes_flag_applies_to_any_format(tmp_path, capsys):
    """--axes overrides the format's default (KF-GINS: FRD) and the manifest's import.imu.axes."""
    from ldvsurvey import cli

    args = [
        "import",
        "--imu",
        f"kf-gins:{EX / 'kf-gins/imu.txt'}",
        "--gnss",
        f"nmea:{EX / 'nmea/receiver.nmea'}",
        "--ldv",
        f"native:{EX / 'ldv.csv'}",
        "--manifest",
        str(EX / "partial.json"),
        "--out",
        str(tmp_path / "o.zip"),
    ]
    assert cli.main(args + ["--axes", "RFU"]) == 2  # z declared up, but the data's z points down
    err = capsys.readouterr().err
    assert "imu.txt" in err and "-z axis" in err and "'FLD'" not in err
    assert not (tmp_path / "o.zip").exists()
    assert cli.main(args + ["--axes", "FRD"]) == 0
    out = capsys.readouterr().out
    assert "axes FRD" in out and "check: at rest |f|" in out and "normal gravity" in out


def test_fitting_codes_are_right_handed_and_put_the_axis_up():
    from ldvsurvey.io.importers.axes import c_rfu_sensor, fitting_codes

    for j in range(3):
        for sign in (1.0, -1.0):
            codes = fitting_codes("FRD", j, sign)
            assert len(codes) == 4
            for code in codes:
                c = c_rfu_sensor(code)
                x, y, z = c[:, 0], c[:, 1], c[:, 2]
                assert np.allclose(np.cross(x, y), z)  # right-handed, checked by the cross product
                e = np.zeros(3)
                e[j] = sign
                assert (c @ e)[2] == 1.0  # the sensor axis carrying gravity's reaction points up
    assert fitting_codes("FRD", 2, 1.0)[0] in ("FLU", "BRU")  # closest to the declared FRD


def test_a_date_1024_weeks_off_is_named_as_a_week_roll_over():
    """A receiver with the GPS week roll-over bug dates its log 1024 weeks (7168 days) early; the refusal says so."""
    import datetime as dt

    m = partial()
    m["date"] = (dt.date(2023, 3, 20) - dt.timedelta(days=7168)).isoformat()  # the RMC's 2023-03-20, 1024 weeks back
    with pytest.raises(BundleError) as e:
        build_bundle(sources(), m)
    assert e.value.field == "date" and "exactly 1024 GPS weeks" in e.value.message
    m["date"] = "2022-03-20"  # a year off is no roll-over
    with pytest.raises(BundleError) as e:
        build_bundle(sources(), m)
    assert "GPS weeks" not in e.value.message
