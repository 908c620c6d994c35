"""Recordings of one fix (a receiver's capture of a single epoch) import: the fix lies inside the IMU's span.

A GNSS span of zero length (first fix = last fix) was taken for no overlap ("... do not overlap in time
(-9.990 s apart)") although the fix lay inside the IMU's span. The recordings are real single-epoch
captures (tests/fixtures/real/README.md); the fix's place and time come from pynmeagps / pyubx2, the IMU
beside it stands still there (KF-GINS text, 10 Hz, from 10 s before the fix to 30 s after).
"""

from __future__ import annotations

import datetime as dt
import io
import json
import math
from pathlib import Path

import pytest
from pynmeagps import NMEAReader

from ldvsurvey.errors import BundleError
from ldvsurvey.io.importers import Source, build_bundle
from ldvsurvey.io.nmea import parse_nmea

pyubx2 = pytest.importorskip("pyubx2")
from pyubx2 import UBX_PROTOCOL, UBXReader  # noqa: E402

REAL = Path(__file__).resolve().parents[1] / "fixtures" / "real"
EX = Path(__file__).resolve().parents[2] / "docs" / "examples"
LEAP_S = 18  # GPS − UTC since 2017-01-01 (IERS Bulletin C)


def normal_gravity(lat_deg: float, h_m: float) -> float:
    """Somigliana (WGS-84) with the free-air gradient, written here independently of nav/earth."""
    s2 = math.sin(math.radians(lat_deg)) ** 2
    return 9.7803253359 * (1 + 0.00193185265241 * s2) / math.sqrt(1 - 0.00669437999013 * s2) - 3.086e-6 * h_m


def standing_imu(day: dt.date, tod_s: float, lat_deg: float, h_m: float) -> bytes:
    """KF-GINS IMU text (GPS seconds of week, dθ, dv front-right-down) at rest from tod−10 s to tod+30 s."""
    sow0 = ((day - dt.date(1980, 1, 6)).days * 86400 + LEAP_S) % 604800
    dv_down = -normal_gravity(lat_deg, h_m) * 0.1
    rows = [f"{sow0 + tod_s - 10.0 + 0.1 * k:.3f} 0 0 0 0 0 {dv_down!r}" for k in range(401)]
    return ("\n".join(rows) + "\n").encode()


def partial(lat_deg: float, lon_deg: float, h_m: float) -> dict:
    m = json.loads((EX / "partial.json").read_text())
    m.pop("date", None)  # the recordings state it
    m["initial"].update(lat_deg=lat_deg, lon_deg=lon_deg, h_m=h_m)
    return m


def test_a_single_gga_epoch_imports_at_the_receivers_position():
    path = REAL / "nmea" / "pynmeagps" / "pygpsdata-nmea4sm.log"
    data = path.read_bytes()
    msgs = [NMEAReader.parse(ln.strip(), validate=1) for ln in data.splitlines() if ln.strip()]
    gga = [m for m in msgs if m.msgID == "GGA"]
    rmc = next(m for m in msgs if m.msgID == "RMC")
    assert len(gga) == 1  # one epoch: the GNSS span has zero length
    g = gga[0]
    tod = g.time.hour * 3600 + g.time.minute * 60 + g.time.second + g.time.microsecond * 1e-6
    h = float(g.alt) + float(g.sep)
    imu = standing_imu(rmc.date, tod, g.lat, h)
    res = build_bundle(
        [Source("imu", "kf-gins", "imu.txt", imu), Source("gnss", "nmea", path.name, data)], partial(g.lat, g.lon, h)
    )
    ov = res.summary["checks"]["overlap"]
    assert ov["fixes_inside"] == 1 and ov["gnss_s"] == [round(tod, 3), round(tod, 3)]
    got = parse_nmea(res.files["gnss.nmea"])
    assert len(got) == 1 and got.t_s[0] == pytest.approx(tod, abs=1e-6)
    assert (got.lat_deg[0], got.lon_deg[0]) == (pytest.approx(g.lat, abs=1e-9), pytest.approx(g.lon, abs=1e-9))
    assert got.h_m[0] == pytest.approx(h, abs=1e-3)


def test_a_single_nav_pvt_epoch_imports_at_the_receivers_position():
    path = REAL / "pygpsdata-NAV.log"
    data = path.read_bytes()
    pvt = [m for _, m in UBXReader(io.BytesIO(data), protfilter=UBX_PROTOCOL) if m.identity == "NAV-PVT"]
    assert len(pvt) == 1 and pvt[0].fixType == 3 and pvt[0].gnssFixOk == 1
    p = pvt[0]
    day = dt.date(p.year, p.month, p.day)
    tod = p.hour * 3600 + p.min * 60 + p.second + p.nano * 1e-9
    h = p.height / 1000.0
    res = build_bundle(
        [Source("imu", "kf-gins", "imu.txt", standing_imu(day, tod, p.lat, h)), Source("gnss", "ubx", path.name, data)],
        partial(p.lat, p.lon, h),
    )
    assert res.summary["checks"]["overlap"]["fixes_inside"] == 1
    got = parse_nmea(res.files["gnss.nmea"])
    assert len(got) == 1 and got.t_s[0] == pytest.approx(round(tod), abs=0.01)  # iTOW: whole-ms epoch
    assert (got.lat_deg[0], got.lon_deg[0]) == (pytest.approx(p.lat, abs=1e-7), pytest.approx(p.lon, abs=1e-7))
    assert got.h_m[0] == pytest.approx(h, abs=1e-3)


def test_a_fix_outside_the_imu_span_is_still_refused():
    path = REAL / "nmea" / "pynmeagps" / "pygpsdata-nmea4sm.log"
    data = path.read_bytes()
    g = next(m for m in (NMEAReader.parse(ln.strip()) for ln in data.splitlines() if ln.strip()) if m.msgID == "GGA")
    tod = g.time.hour * 3600 + g.time.minute * 60 + g.time.second
    h = float(g.alt) + float(g.sep)
    imu = standing_imu(dt.date(2021, 3, 6), tod + 60.0, g.lat, h)  # the IMU starts 50 s after the fix
    with pytest.raises(BundleError) as e:
        srcs = [Source("imu", "kf-gins", "imu.txt", imu), Source("gnss", "nmea", path.name, data)]
        build_bundle(srcs, partial(g.lat, g.lon, h))
    assert (e.value.file, e.value.field) == (path.name, "time") and "50.000 s apart" in e.value.message
