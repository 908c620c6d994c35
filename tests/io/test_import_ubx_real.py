"""u-blox importer on real receivers' recordings (tests/fixtures/real/, see its README).

Every expectation comes from outside the importer: pyubx2's own field-by-field decode of the same
frames, the receiver's NAV-PVT beside its ESF data, the spec's byte layout decoded here with
``struct``, and physics (normal gravity, the sensor's sample counts per GNSS second).
"""

from __future__ import annotations

import datetime as dt
import math
import struct
from pathlib import Path

import numpy as np
import pytest

from ldvsurvey.errors import BundleError
from ldvsurvey.io.importers import Source, build_bundle, get_importer

pyubx2 = pytest.importorskip("pyubx2")
from pyubx2 import UBX_PROTOCOL, UBXReader  # noqa: E402

REAL = Path(__file__).resolve().parents[1] / "fixtures" / "real"
M8U = REAL / "ublox-neo-m8u.log"
M8L = REAL / "ublox-neo-m8l.log"
GPS_EPOCH = dt.datetime(1980, 1, 6)


def decode(path: Path) -> list:
    """(message number, pyubx2 message) of every UBX frame, by pyubx2 alone."""
    out = []
    with open(path, "rb") as fh:
        for n, (_raw, msg) in enumerate(UBXReader(fh, protfilter=UBX_PROTOCOL, quitonerror=0), start=1):
            out.append((n, msg))
    return out


def normal_gravity(lat_deg: float, h_m: float) -> float:
    """Somigliana's formula (WGS-84) with the free-air term: independent of the product's nav/earth."""
    s2 = math.sin(math.radians(lat_deg)) ** 2
    g0 = 9.7803253359 * (1 + 0.00193185265241 * s2) / math.sqrt(1 - 0.00669437999013 * s2)
    return g0 - 3.086e-6 * h_m


def ldv_csv(t0: float, t1: float) -> bytes:
    rows = ["t,v_fwd,quality"] + [f"{t:.3f},0.0,300" for t in np.arange(t0, t1, 0.1)]
    return ("\n".join(rows) + "\n").encode()


def tod_s(msg) -> float:
    return msg.hour * 3600 + msg.min * 60 + msg.second + msg.nano * 1e-9


@pytest.fixture(scope="module")
def m8u():
    if not M8U.is_file():
        pytest.skip("real u-blox fixtures not present")
    return M8U.read_bytes(), decode(M8U)


def _raw_samples(msgs):
    """pyubx2's decode of ESF-RAW: (message number, sTag, dataType, signed value) per entry."""
    out = []
    for n, msg in msgs:
        if msg is None or msg.identity != "ESF-RAW":
            continue
        k = 1
        while hasattr(msg, f"data_{k:02d}"):
            word = int.from_bytes(getattr(msg, f"data_{k:02d}"), "little")
            tag = int.from_bytes(getattr(msg, f"sTag_{k:02d}"), "little")
            v = word & 0xFFFFFF
            out.append((n, tag, word >> 24, v - (1 << 24) if v & 0x800000 else v))
            k += 1
    return out


def test_m8u_esf_raw_time_base_from_the_log(m8u):
    """The NEO-M8U log of the issue: before the fix the sTag was read as GPS ms of week (3.9 Hz, 3.5 days
    before the fixes). The sensor's output rate is counted independently: ESF-RAW samples between
    consecutive NAV-PVT messages, per GPS second."""
    data, msgs = m8u
    part = get_importer("ubx").read(data, "m8u.ubx", "imu", {})
    pvt = [(n, m) for n, m in msgs if m is not None and m.identity == "NAV-PVT"]
    raw = _raw_samples(msgs)
    per_second = []
    for (n0, p0), (n1, p1) in zip(pvt, pvt[1:]):
        count = len({(n, tag) for n, tag, _, _ in raw if n0 < n < n1})
        per_second.append(count / ((p1.iTOW - p0.iTOW) / 1000.0))
    counted = float(np.mean(per_second))
    assert counted == 100.0  # ten messages of ten samples in each GNSS second
    t = part.stamps.values
    rate = (len(t) - 1) / (t[-1] - t[0])
    assert abs(rate / counted - 1) < 0.01
    tb = part.report["time_base"]
    assert 25_000 < tb["tag_rate_hz"] < 26_200 and tb["tag_rate_3sigma_rel"] < 0.01 and tb["source"] == "NAV-PVT"
    # IMU times inside the GNSS span (the ESF messages run 0.3 s before the first and 0.6 s after the last fix)
    week = {int(w) for w in part.stamps.week}
    assert week == {2159}  # NAV-PVT's date, 2021-05-26
    fix_sow = [p.iTOW / 1000.0 for _, p in pvt]
    assert fix_sow[0] - 0.5 < t[0] < fix_sow[0] and fix_sow[-1] < t[-1] < fix_sow[-1] + 1.0
    # the docs' worked example: 16:52:43.66 to 16:52:46.55 UTC (GPS − UTC = 18 s)
    tod = (t - 3 * 86400 - 18.0) % 86400
    assert tod[0] == pytest.approx(16 * 3600 + 52 * 60 + 43.66, abs=0.01)
    assert tod[-1] == pytest.approx(16 * 3600 + 52 * 60 + 46.55, abs=0.01)


def test_m8u_values_match_pyubx2_field_by_field(m8u):
    data, msgs = m8u
    part = get_importer("ubx").read(data, "m8u.ubx", "imu", {})
    by_tag: dict[int, dict] = {}
    for _n, tag, dtype, v in _raw_samples(msgs):
        by_tag.setdefault(tag, {})[dtype] = v
    tags = list(by_tag)  # no wrap inside this log
    assert len(tags) == len(part.stamps.values) == 290
    dt_s = np.diff(part.stamps.values)
    dt_s = np.concatenate(([np.median(dt_s)], dt_s))
    gyro = np.array([[by_tag[t][d] for d in (14, 13, 5)] for t in tags]) * math.radians(2.0**-12)
    acc = np.array([[by_tag[t][d] for d in (16, 17, 18)] for t in tags]) * 2.0**-10
    np.testing.assert_allclose(part.dtheta_rad / dt_s[:, None], gyro, rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(part.dvel_mps / dt_s[:, None], acc, rtol=1e-12, atol=1e-15)
    # and the sample times follow the sensor tags on one straight line
    fit = np.polyfit(np.array(tags, dtype=float), part.stamps.values, 1)
    assert np.max(np.abs(np.polyval(fit, tags) - part.stamps.values)) < 1e-6  # (float64 of 3e5 s)


def test_m8u_bundle_static_gravity_and_axes(m8u, tmp_path):
    """Built into a bundle: at rest, |f| against normal gravity at NAV-PVT's position. The raw MEMS
    accelerometer reads 2.3 % high (its own error: the receiver's ESF-MEAS says the same), more than the
    1 % accepted by default: the import refuses naming the figure and the option, and imports with a warning
    once the user accepts 3 %; without axes it refuses naming +z as up."""
    data, msgs = m8u
    pvt = [m for _, m in msgs if m is not None and m.identity == "NAV-PVT"]
    t0 = tod_s(pvt[0])
    ldv = ldv_csv(t0 - 2.0, t0 + 4.0)
    manifest = {"ldv": {"kind": "1d"}, "initial": {"static_s": 2.0}}
    sources = [
        Source("imu", "ubx", "m8u.ubx", data),
        Source("gnss", "ubx", "m8u.ubx", data),
        Source("ldv", "native", "ldv.csv", ldv),
    ]
    with pytest.raises(BundleError) as e:
        build_bundle(sources, manifest)
    assert e.value.field == "axes" and "+z axis" in e.value.message and "FLU" in e.value.message
    manifest["import"] = {"imu": {"axes": "FLU"}}
    with pytest.raises(BundleError) as e:
        build_bundle(sources, manifest)
    assert e.value.field == "dvel" and "+2.2" in e.value.message and "static_gravity_tolerance" in e.value.message
    manifest["import"]["imu"]["static_gravity_tolerance"] = 0.03
    res = build_bundle(sources, manifest)
    assert res.summary["date"] == "2021-05-26"
    assert res.summary["static_tilt_deg"] < 2.0
    checks = res.summary["checks"]
    g = normal_gravity(pvt[0].lat, pvt[0].height / 1000.0)
    assert checks["static_gravity"]["normal_mps2"] == pytest.approx(g, abs=1e-4)
    # ESF-MEAS of the same receiver (its own 10 Hz output, another clock): mean |f| over the log
    meas = [m for _, m in msgs if m is not None and m.identity == "ESF-MEAS" and m.dataType_01 == 16]

    def s24(v):
        return v - (1 << 24) if v & 0x800000 else v

    f_meas = np.mean([[s24(getattr(m, f"dataField_{k:02d}")) for k in (1, 2, 3)] for m in meas], axis=0) * 2.0**-10
    assert checks["static_gravity"]["measured_mps2"] == pytest.approx(np.linalg.norm(f_meas), rel=2e-3)
    err = checks["static_gravity"]["measured_mps2"] / g - 1
    assert 0.015 < err < 0.03  # the sensor's own error, not the import's
    assert any("normal gravity" in w for w in res.warnings)
    assert 0.99 < checks["imu_rate"]["measured_hz"] / 100.0 < 1.01


def test_m8u_esf_meas_alone_is_refused_with_the_reason(m8u):
    """ESF-MEAS of the same log (ms clock, accelerometer and gyro 5 ms apart, 10 Hz): ten times fewer samples
    around the three NAV-PVT epochs bracket them only to ±50 ms, too coarse to know the clock rate to 1 %
    over 2 s; the import says so (and how long a log would do) rather than guess."""
    data, _ = m8u
    with pytest.raises(BundleError) as e:
        get_importer("ubx").read(data, "m8u.ubx", "imu", {"esf": "meas"})
    assert e.value.field == "ESF-MEAS timeTag" and "to 1 %" in e.value.message and "s is needed" in e.value.message


def test_m8l_esf_meas_joined_and_timed():
    """NEO-M8L (ADR 4.50) driving: ESF-MEAS accelerometer, gyro and single-tick messages; HNR-PVT at 10 Hz."""
    if not M8L.is_file():
        pytest.skip("real u-blox fixtures not present")
    msgs = decode(M8L)
    part = get_importer("ubx").read(M8L.read_bytes(), "m8l.ubx", "imu", {})
    kinds = {"acc": 0, "gyro": 0, "tick": 0}
    for _, m in msgs:
        if m is not None and m.identity == "ESF-MEAS":
            types = {getattr(m, f"dataType_{k:02d}") for k in range(1, m.numMeas + 1)}
            kinds["acc" if 16 in types else "gyro" if 14 in types else "tick"] += 1
    tb = part.report["time_base"]
    assert tb["joined"] == kinds["acc"] == kinds["gyro"] == len(part.stamps.values)
    assert tb["tick_only"] == kinds["tick"] > 0
    # the sensor's output rate, counted: accelerometer messages between the first and last NAV-PVT
    pvt = [(n, m) for n, m in msgs if m is not None and m.identity == "NAV-PVT"]
    (n0, p0), (n1, p1) = pvt[0], pvt[-1]
    acc_n = [n for n, m in msgs if m is not None and m.identity == "ESF-MEAS" and m.dataType_01 == 16]
    counted = sum(n0 < n < n1 for n in acc_n) / ((p1.iTOW - p0.iTOW) / 1000.0)
    t = part.stamps.values
    rate = (len(t) - 1) / (t[-1] - t[0])
    assert abs(rate / counted - 1) < 0.01
    assert p0.iTOW / 1000 - 1.0 < t[0] and t[-1] < p1.iTOW / 1000 + 1.0


def test_esf_without_gnss_epochs_is_refused():
    """pyubx2's ESF-MEAS sample: messages of several sessions, no NAV message: refused, naming the message."""
    path = REAL / "pygpsdata-ESF.log"
    if not path.is_file():
        pytest.skip("real u-blox fixtures not present")
    with pytest.raises(BundleError) as e:
        get_importer("ubx").read(path.read_bytes(), path.name, "imu", {})
    assert e.value.file == path.name and e.value.field and "message" in e.value.field


def _payloads(path: Path, cls_id: bytes):
    data = path.read_bytes()
    k = 0
    while True:
        k = data.find(b"\xb5\x62" + cls_id, k)
        if k < 0:
            return
        n = struct.unpack_from("<H", data, k + 4)[0]
        yield data[k + 6 : k + 6 + n]
        k += 8 + n


def test_hpposllh_decoded_to_the_spec():
    """NAV-HPPOSLLH: lat/lon in 1e-7° + 1e-9° (I4 + I1), heights in mm + 0.1 mm, decoded here from the bytes."""
    path = REAL / "pygpsdata-NAVHPPOS.log"
    if not path.is_file():
        pytest.skip("real u-blox fixtures not present")
    g = get_importer("ubx").read(path.read_bytes(), path.name, "gnss", {})
    want = []
    for pl in _payloads(path, b"\x01\x14"):
        _v, _r0, _r1, _f, itow, lon, lat, h, hmsl, lonhp, lathp, hhp, hmslhp, hacc, _vacc = struct.unpack(
            "<BBBBIiiiibbbbII", pl
        )
        want.append(
            (
                itow / 1000,
                lat * 1e-7 + lathp * 1e-9,
                lon * 1e-7 + lonhp * 1e-9,
                (h + 0.1 * hhp) / 1000,
            )
        )
    want = np.array(want)
    np.testing.assert_allclose(g.stamps.values, want[:, 0])
    np.testing.assert_allclose(g.lat_deg, want[:, 1], atol=1e-10)
    np.testing.assert_allclose(g.lon_deg, want[:, 2], atol=1e-10)
    np.testing.assert_allclose(g.h_ell_m, want[:, 3], atol=1e-5)


def test_nav_sol_and_posllh_agree_with_the_receivers_nav_pvt():
    """pyubx2's mixed log (a receiver with NAV-PVT, NAV-SOL and NAV-POSLLH): each older message read alone
    gives the positions the receiver's NAV-PVT states for the same epochs."""
    path = REAL / "pygpsdata-MIXED.log"
    if not path.is_file():
        pytest.skip("real u-blox fixtures not present")
    data = path.read_bytes()
    ubx = get_importer("ubx")
    pvt = ubx.read(data, path.name, "gnss", {})
    by_tow = {round(float(t), 3): k for k, t in enumerate(pvt.stamps.values)}

    def only(cls_id):
        return b"".join(
            b"\xb5\x62" + cls_id + struct.pack("<H", len(p)) + p + _ck(cls_id, p) for p in _payloads(path, cls_id)
        )

    for cls_id, tol_deg, tol_h in ((b"\x01\x06", 3e-7, 0.05), (b"\x01\x02", 1.1e-7, 0.002)):
        part = ubx.read(only(cls_id), path.name, "gnss", {"date": "2020-10-24"})
        common = [
            (k, by_tow[round(float(t), 3)]) for k, t in enumerate(part.stamps.values) if round(float(t), 3) in by_tow
        ]
        assert len(common) >= 5
        a, b = np.array(common).T
        np.testing.assert_allclose(part.lat_deg[a], pvt.lat_deg[b], atol=tol_deg)
        np.testing.assert_allclose(part.lon_deg[a], pvt.lon_deg[b], atol=tol_deg)
        np.testing.assert_allclose(part.h_ell_m[a], pvt.h_ell_m[b], atol=tol_h)


def _ck(cls_id: bytes, payload: bytes) -> bytes:
    a = b = 0
    for x in cls_id + struct.pack("<H", len(payload)) + payload:
        a = (a + x) & 0xFF
        b = (b + a) & 0xFF
    return bytes((a, b))


def test_hnr_pvt_only_warns_that_it_is_fused():
    path = REAL / "pygpsdata-HNR.log"
    if not path.is_file():
        pytest.skip("real u-blox fixtures not present")
    g = get_importer("ubx").read(path.read_bytes(), path.name, "gnss", {})
    msgs = [m for _, m in decode(path) if m is not None and m.identity == "HNR-PVT" and m.GPSfixOK]
    assert len(g.lat_deg) == len(msgs)
    np.testing.assert_allclose(g.lat_deg, [m.lat for m in msgs])
    assert any("circular" in n for n in g.notes)


def test_real_files_cut_anywhere_never_crash():
    """Every real fixture cut at many points: a part, or a typed error naming the file."""
    ubx = get_importer("ubx")
    for path in sorted(REAL.glob("*.log")):
        data = path.read_bytes()
        for cut in np.linspace(0, len(data), 23).astype(int)[1:-1]:
            for role in ("imu", "gnss"):
                try:
                    ubx.read(data[:cut], path.name, role, {})
                except BundleError as exc:
                    assert exc.file == path.name


def test_m8u_esf_raw_only_is_not_silently_wrong(m8u):
    """The issue's case: the M8U log with its ESF-RAW and NAV-PVT only. Before the fix it imported at 3.9 Hz,
    3.5 days before the fixes, with increments 25.6x too large (sTag read as GPS ms of week)."""
    data, _ = m8u
    frames = []
    k = data.find(b"\xb5\x62")
    while 0 <= k < len(data):
        n = struct.unpack_from("<H", data, k + 4)[0]
        if data[k + 2 : k + 4] != b"\x10\x02":
            frames.append(data[k : k + 8 + n])
        k = data.find(b"\xb5\x62", k + 8 + n)
    raw_only = b"".join(frames)
    part = get_importer("ubx").read(raw_only, "m8u.ubx", "imu", {})
    gnss = get_importer("ubx").read(raw_only, "m8u.ubx", "gnss", {})
    t = part.stamps.values
    assert abs((len(t) - 1) / (t[-1] - t[0]) / 100.0 - 1) < 0.01
    assert gnss.stamps.values[0] - 1.0 < t[0] < gnss.stamps.values[-1] + 1.0
    f = np.linalg.norm(part.dvel_mps, axis=1) * 100.0  # per-sample specific force at the 100 Hz output rate
    # ~10 m/s² at rest (the sensor's own 10.03), not 25.6x that; single samples scatter with the sensor's
    # noise and the tags' one-tick (0.4 %) resolution
    assert np.median(f) == pytest.approx(10.03, rel=0.01) and f.max() < 12.0


def test_m8l_driving_start_is_refused_with_the_reason_then_imports():
    """The M8L log starts while driving: the static check must say so (not suggest the same axes again);
    allowed a larger tilt it imports with the ESF-MEAS rate and the report's figures."""
    if not M8L.is_file():
        pytest.skip("real u-blox fixtures not present")
    data = M8L.read_bytes()
    msgs = decode(M8L)
    pvt = [m for _, m in msgs if m is not None and m.identity == "NAV-PVT"]
    t0 = tod_s(pvt[0])
    sources = [
        Source("imu", "ubx", "m8l.ubx", data),
        Source("gnss", "ubx", "m8l.ubx", data),
        Source("ldv", "native", "ldv.csv", ldv_csv(t0 - 2.0, t0 + 20.0)),
    ]
    manifest = {"ldv": {"kind": "1d"}, "initial": {"static_s": 2.0}, "import": {"imu": {"axes": "FLU"}}}
    with pytest.raises(BundleError) as e:
        build_bundle(sources, manifest)
    assert e.value.field == "axes" and "not at rest" in e.value.message
    manifest["import"]["imu"]["max_static_tilt_deg"] = 15.0
    res = build_bundle(sources, manifest)
    ck = res.summary["checks"]
    assert ck["imu_source"]["time_base"]["message"] == "ESF-MEAS"
    assert ck["imu_rate"]["measured_hz"] == pytest.approx(11.1, abs=0.1)
    assert ck["overlap"]["share"] > 0.9
    assert res.summary["date"] == "2024-01-30"
