"""NovAtel OEM7 round trips: messages written here from the published OEM7 message definitions
(ASCII with CRC-32, binary with header + CRC-32), read back through novatel-edie by the importer."""

from __future__ import annotations

import datetime as dt
import math
import struct
from decimal import Decimal

import numpy as np
import pytest

from ldvsurvey.errors import BundleError
from ldvsurvey.io.drivelog import parse_files
from ldvsurvey.io.importers import Source, build_bundle, detect
from ldvsurvey.sim import catalog
from ldvsurvey.sim.scenario import bundle_files, manifest, simulate
from tests.io.import_helpers import sow_of_midnight

pytest.importorskip("novatel_edie")


def _table():
    t = []
    for n in range(256):  # OEM7 documentation: CRC-32, reflected polynomial 0xEDB88320, initial value 0
        c = n
        for _ in range(8):
            c = (c >> 1) ^ 0xEDB88320 if c & 1 else c >> 1
        t.append(c)
    return t


TABLE = _table()


def crc32(data: bytes) -> int:
    c = 0
    for b in data:
        c = TABLE[(c ^ b) & 0xFF] ^ (c >> 8)
    return c


# scale factors typed from the OEM7 RAWIMUSX documentation, independently of the importer's table
HG1700_AG58 = (11, 2.0**-33, 0.3048 * 2.0**-27)
EPSON_G320 = (41, math.radians(0.008 / 65536) / 100.0, 0.2 / 65536 * 9.80665e-3 / 100.0)  # at 100 Hz


def counts(sim, c_sensor_rfu, scale):
    """Integer counts of the sensor-frame increments (rounded: the format's quantisation)."""
    _, sg, sa = scale
    th = sim.dtheta_rad @ c_sensor_rfu.T
    dv = sim.dvel_mps @ c_sensor_rfu.T
    return np.round(th / sg).astype(np.int64), np.round(dv / sa).astype(np.int64)


def ascii_log(sim, day, c_sensor_rfu, scale, n_fix=None):
    week, s0 = sow_of_midnight(day)
    g, a = counts(sim, c_sensor_rfu, scale)
    out = []
    for k, t in enumerate(sim.imu.t_s):
        sow = Decimal(repr(float(t))) + s0
        body = (
            f"RAWIMUSXA,{week},{sow:.3f};00,{scale[0]},{week},{sow:.9f},00000000,"
            f"{a[k, 2]},{-a[k, 1]},{a[k, 0]},{g[k, 2]},{-g[k, 1]},{g[k, 0]}"
        )
        out.append(f"%{body}*{crc32(body.encode()):08x}")
    for k, t in enumerate(sim.gnss_t_s[:n_fix]):
        f = int(sim.gnss_fix[k])
        ptype = {4: "NARROW_INT", 5: "NARROW_FLOAT", 2: "PSRDIFF", 1: "SINGLE", 0: "NONE"}[f]
        stat = "SOL_COMPUTED" if f else "INSUFFICIENT_OBS"
        sow = Decimal(repr(float(t))) + s0
        body = (
            f"BESTPOSA,COM1,0,70.0,FINESTEERING,{week},{sow:.3f},02000000,b1f6,16809;{stat},{ptype},"
            f"{sim.gnss_lat_deg[k]:.11f},{sim.gnss_lon_deg[k]:.11f},{sim.gnss_h_m[k] + 16.9:.4f},-16.9000,WGS84,"
            f'0.0100,0.0120,0.0150,"0",1.000,0.000,22,21,21,21,00,01,3f,37'
        )
        out.append(f"#{body}*{crc32(body.encode()):08x}")
    return ("\r\n".join(out) + "\r\n").encode()


def binary_imu(sim, day, c_sensor_rfu, scale):
    week, s0 = sow_of_midnight(day)
    g, a = counts(sim, c_sensor_rfu, scale)
    out = bytearray()
    for k, t in enumerate(sim.imu.t_s):
        sow = float(Decimal(repr(float(t))) + s0)
        body = struct.pack(
            "<BBHdIiiiiii", 0, scale[0], week, sow, 0, a[k, 2], -a[k, 1], a[k, 0], g[k, 2], -g[k, 1], g[k, 0]
        )
        head = b"\xaa\x44\x13" + struct.pack("<BHHi", len(body), 1462, week, int(round(sow * 1000)))
        msg = head + body
        out += msg + struct.pack("<I", crc32(msg))
    return bytes(out)


def binary_bestpos(sim, day):
    week, s0 = sow_of_midnight(day)
    out = bytearray()
    for k, t in enumerate(sim.gnss_t_s):
        f = int(sim.gnss_fix[k])
        ptype = {4: 50, 5: 34, 2: 17, 1: 16, 0: 0}[f]
        body = struct.pack(
            "<IIdddfIfff4sffBBBBBBBB",
            0 if f else 1,
            ptype,
            sim.gnss_lat_deg[k],
            sim.gnss_lon_deg[k],
            sim.gnss_h_m[k] + 16.9,
            -16.9,
            61,
            0.01,
            0.012,
            0.015,
            b"0\0\0\0",
            1.0,
            0.0,
            22,
            21,
            21,
            21,
            0,
            1,
            0x3F,
            0x37,
        )
        ms = int(round((float(t) + s0) * 1000))
        head = b"\xaa\x44\x12" + struct.pack(
            "<BHBBHHBBHIIHH", 28, 42, 0, 32, len(body), 0, 144, 180, week, ms, 0x02000000, 0xB1F6, 16809
        )
        msg = head + body
        out += msg + struct.pack("<I", crc32(msg))
    return bytes(out)


@pytest.fixture(scope="module")
def sim():
    sc = catalog.drive(minutes=2.0, static_s=30.0)
    return simulate(sc, seed=5)


def _partial(sim):
    m = manifest(sim)
    m.pop("format")
    m["imu"].pop("rate_hz")
    return m


def _check_round_trip(sim, files, scale, quantum_of_sensor=True):
    log = parse_files(files)
    native = parse_files(bundle_files(sim))
    np.testing.assert_array_equal(log.imu.t_s, native.imu.t_s)  # times exact
    _, sg, sa = scale
    # increments within half a count (one count after the axis permutation: still one count per axis)
    assert np.max(np.abs(log.imu.dtheta_rad - sim.dtheta_rad)) <= 0.5 * sg * (1 + 1e-9)
    assert np.max(np.abs(log.imu.dvel_mps - sim.dvel_mps)) <= 0.5 * sa * (1 + 1e-9)
    return log, native


def test_ascii_rawimusx_and_bestpos(sim):
    day = dt.date.fromisoformat(sim.scenario.date)
    data = ascii_log(sim, day, np.eye(3), HG1700_AG58)
    assert detect(data, "span.log")[0] == "novatel"
    files = bundle_files(sim)
    res = build_bundle(
        [
            Source("imu", "novatel", "span.log", data),
            Source("gnss", "novatel", "span.log", data),
            Source("ldv", "native", "ldv.csv", files["ldv.csv"]),
        ],
        _partial(sim),
    )
    log, native = _check_round_trip(sim, res.files, HG1700_AG58)
    ok = native.gnss.fix > 0
    np.testing.assert_array_equal(log.gnss.t_s, native.gnss.t_s[ok])
    np.testing.assert_array_equal(log.gnss.fix, native.gnss.fix[ok])
    np.testing.assert_allclose(log.gnss.h_m, native.gnss.h_m[ok], atol=2e-4)
    np.testing.assert_allclose(log.gnss.lat_deg, native.gnss.lat_deg[ok], atol=1e-9)
    assert b"-16.900,M" in res.files["gnss.nmea"]  # the undulation the receiver stated


def test_binary_epson_rate_scaled_with_flu_axes(sim):
    """Binary short-header RAWIMUSXB of an Epson G320 (counts scaled by the data rate), IMU mounted
    x forward, y left, z up; binary long-header BESTPOSB."""
    day = dt.date.fromisoformat(sim.scenario.date)
    c_flu_rfu = np.array([[0, 1, 0], [-1, 0, 0], [0, 0, 1]], float)  # RFU -> FLU components
    data = binary_imu(sim, day, c_flu_rfu, EPSON_G320)
    files = bundle_files(sim)
    m = _partial(sim)
    m["import"] = {"imu": {"axes": "FLU"}}
    res = build_bundle(
        [
            Source("imu", "novatel", "imu.gps", data),
            Source("gnss", "novatel", "pos.gps", binary_bestpos(sim, day)),
            Source("ldv", "native", "ldv.csv", files["ldv.csv"]),
        ],
        m,
    )
    _check_round_trip(sim, res.files, EPSON_G320)


def test_bad_crc_is_skipped_and_counted(sim):
    day = dt.date.fromisoformat(sim.scenario.date)
    data = bytearray(ascii_log(sim, day, np.eye(3), HG1700_AG58, n_fix=5))
    k = data.index(b"*", 5000)
    data[k + 1 : k + 9] = b"00000000"
    from ldvsurvey.io.importers import get_importer

    part = get_importer("novatel").read(bytes(data), "span.log", "imu", {})
    assert len(part.dvel_mps) == len(sim.imu.t_s) - 1
    assert any("undecodable" in n for n in part.notes)


def test_unknown_imu_type_names_the_message(sim):
    day = dt.date.fromisoformat(sim.scenario.date)
    data = ascii_log(sim, day, np.eye(3), (99, 1e-9, 1e-9), n_fix=0)[:2000]
    from ldvsurvey.io.importers import get_importer

    with pytest.raises(BundleError) as e:
        get_importer("novatel").read(data, "span.log", "imu", {})
    assert e.value.file == "span.log" and "message 1" in e.value.field and "imu_type" in e.value.field


def test_rawimux_long_header_ascii_and_inspvax_counted(sim):
    """RAWIMUXA (long ASCII header) reads like RAWIMUSXA; an INSPVAXA in the stream is counted only."""
    from ldvsurvey.io.importers import get_importer

    day = dt.date.fromisoformat(sim.scenario.date)
    week, s0 = sow_of_midnight(day)
    _, sg, sa = HG1700_AG58
    out = []
    for k in range(50):
        sow = Decimal(repr(float(sim.imu.t_s[k]))) + s0
        g = np.round(sim.dtheta_rad[k] / sg).astype(int)
        a = np.round(sim.dvel_mps[k] / sa).astype(int)
        body = (
            f"RAWIMUXA,COM1,0,80.0,FINESTEERING,{week},{sow:.3f},02000000,0000,16809;00,11,{week},{sow:.9f},"
            f"00000000,{a[2]},{-a[1]},{a[0]},{g[2]},{-g[1]},{g[0]}"
        )
        out.append(f"#{body}*{crc32(body.encode()):08x}")
    body = (
        f"INSPVAXA,COM1,0,80.0,FINESTEERING,{week},{s0 + 30000}.000,02000000,0000,16809;INS_SOLUTION_GOOD,"
        f"INS_RTKFIXED,28.4861,113.0623,120.0,-16.9,0.0,0.0,0.0,0.0,0.0,30.0,0.01,0.01,0.02,0.01,0.01,0.01,"
        f"0.1,0.1,0.2,00000000,0"
    )
    out.insert(10, f"#{body}*{crc32(body.encode()):08x}")
    part = get_importer("novatel").read(("\r\n".join(out) + "\r\n").encode(), "span.log", "imu", {})
    assert len(part.dvel_mps) == 50
    assert np.max(np.abs(part.dvel_mps - sim.dvel_mps[:50])) <= 0.5 * sa * (1 + 1e-9)
    assert np.max(np.abs(part.dtheta_rad - sim.dtheta_rad[:50])) <= 0.5 * sg * (1 + 1e-9)
    assert any("INSPVAX" in n for n in part.notes)
