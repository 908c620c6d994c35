"""u-blox round trips: UBX frames built by pyubx2's own generator (``UBXMessage(...).serialize()``)
from the simulator's truth, imported and compared with the native bundle."""

from __future__ import annotations

import datetime as dt
import math
import struct

import numpy as np
import pytest

from ldvsurvey.errors import BundleError
from ldvsurvey.io.drivelog import parse_files
from ldvsurvey.io.importers import Source, build_bundle, detect, get_importer
from ldvsurvey.sim import catalog
from ldvsurvey.sim.scenario import bundle_files, manifest, simulate
from tests.io.import_helpers import rfu_to_frd, sow_of_midnight

pyubx2 = pytest.importorskip("pyubx2")
from pyubx2 import GET, UBXMessage  # noqa: E402

GYRO_LSB = math.radians(2.0**-12)  # u-blox interface description: ESF data types 14/13/5, 2^-12 deg/s
ACC_LSB = 2.0**-10  # types 16/17/18, 2^-10 m/s^2


def esf_raw_frames(t_tag_ms, rates_frd, acc_frd):
    """One ESF-RAW per epoch: six (data, sTtag) pairs; payload laid out per the u-blox spec, framed by pyubx2."""
    out = bytearray()
    g = np.round(rates_frd / GYRO_LSB).astype(np.int64)
    a = np.round(acc_frd / ACC_LSB).astype(np.int64)
    for k, tag in enumerate(t_tag_ms):
        payload = struct.pack("<I", 0)
        for dtype, v in ((14, g[k, 0]), (13, g[k, 1]), (5, g[k, 2]), (16, a[k, 0]), (17, a[k, 1]), (18, a[k, 2])):
            payload += struct.pack("<II", (int(v) & 0xFFFFFF) | (dtype << 24), int(tag))
        out += UBXMessage(b"\x10", b"\x03", GET, payload=payload).serialize()
    return bytes(out)


def nav_pvt_frames(sim, day, itow_ms, sep_m=-16.9):
    out = bytearray()
    for k, t in enumerate(sim.gnss_t_s):
        f = int(sim.gnss_fix[k])
        if f == 0:
            continue
        tod = int(round(float(t)))
        hh, mm, ss = tod // 3600, tod // 60 % 60, tod % 60
        msg = UBXMessage(
            "NAV",
            "NAV-PVT",
            GET,
            iTOW=int(itow_ms[k]),
            year=day.year,
            month=day.month,
            day=day.day,
            hour=hh,
            min=mm,
            second=ss,
            validDate=1,
            validTime=1,
            fullyResolved=1,
            fixType=3,
            gnssFixOk=1,
            diffSoln=1 if f in (2, 4, 5) else 0,
            carrSoln={4: 2, 5: 1}.get(f, 0),
            numSV=20,
            lon=float(sim.gnss_lon_deg[k]),
            lat=float(sim.gnss_lat_deg[k]),
            height=int(round(sim.gnss_h_m[k] * 1000)),
            hMSL=int(round((sim.gnss_h_m[k] - sep_m) * 1000)),
            hAcc=20,
            vAcc=30,
            pDOP=1.2,
        )
        out += msg.serialize()
    return bytes(out)


@pytest.fixture(scope="module")
def sim():
    return simulate(catalog.drive(minutes=2.0, static_s=30.0), seed=6)


def test_esf_raw_and_nav_pvt_round_trip(sim):
    day = dt.date.fromisoformat(sim.scenario.date)
    _, s0 = sow_of_midnight(day)
    dt_s = 1.0 / sim.scenario.imu_rate_hz
    tag = np.round((sim.imu.t_s + s0) * 1000).astype(np.int64)  # GPS ms of week
    imu = esf_raw_frames(tag, rfu_to_frd(sim.dtheta_rad) / dt_s, rfu_to_frd(sim.dvel_mps) / dt_s)
    gnss = nav_pvt_frames(sim, day, np.round((sim.gnss_t_s + s0) * 1000).astype(np.int64))
    assert detect(imu, "esf.ubx") == ("ubx", "imu") and detect(gnss, "pvt.ubx") == ("ubx", "gnss")
    files = bundle_files(sim)
    m = manifest(sim)
    m.pop("format")
    m.pop("date")  # NAV-PVT states the date
    m["imu"].pop("rate_hz")
    res = build_bundle(
        [
            Source("imu", "ubx", "esf.ubx", imu),
            Source("gnss", "ubx", "pvt.ubx", gnss),
            Source("ldv", "native", "ldv.csv", files["ldv.csv"]),
        ],
        m,
    )
    log, native = parse_files(res.files), parse_files(files)
    assert str(log.manifest.date) == sim.scenario.date
    np.testing.assert_array_equal(log.imu.t_s, native.imu.t_s)  # ms tags: the simulation's 10 ms steps exactly
    # quantisation: half an LSB of rate times the interval
    assert np.max(np.abs(log.imu.dtheta_rad - sim.dtheta_rad)) <= 0.5 * GYRO_LSB * dt_s * (1 + 1e-6)
    assert np.max(np.abs(log.imu.dvel_mps - sim.dvel_mps)) <= 0.5 * ACC_LSB * dt_s * (1 + 1e-6)
    ok = native.gnss.fix > 0
    np.testing.assert_array_equal(log.gnss.t_s, native.gnss.t_s[ok])
    np.testing.assert_array_equal(log.gnss.fix, native.gnss.fix[ok])
    np.testing.assert_allclose(log.gnss.lat_deg, native.gnss.lat_deg[ok], atol=1e-7)  # NAV-PVT keeps 1e-7 deg
    np.testing.assert_allclose(log.gnss.h_m, native.gnss.h_m[ok], atol=1e-3)  # and mm heights
    assert b"-16.900,M" in res.files["gnss.nmea"]


def test_missing_axis_names_the_message():
    payload = struct.pack("<I", 0) + struct.pack("<II", 5 | (14 << 24), 1000)
    data = UBXMessage(b"\x10", b"\x03", GET, payload=payload).serialize() * 1
    with pytest.raises(BundleError) as e:
        get_importer("ubx").read(data, "esf.ubx", "imu", {})
    assert e.value.file == "esf.ubx" and "message 1" in e.value.field and "gyro y" in e.value.message


def test_bad_checksum_frame_is_skipped():
    good = b"".join(
        UBXMessage(
            b"\x10",
            b"\x03",
            GET,
            payload=struct.pack("<I", 0)
            + b"".join(struct.pack("<II", (100 & 0xFFFFFF) | (d << 24), tag) for d in (14, 13, 5, 16, 17, 18)),
        ).serialize()
        for tag in (1000, 1010, 1020)
    )
    bad = bytearray(good)
    bad[len(good) // 3 - 1] ^= 0xFF  # first frame's checksum
    part = get_importer("ubx").read(bytes(bad), "esf.ubx", "imu", {})
    assert len(part.dvel_mps) == 2 and any("checksum" in n for n in part.notes)


def test_esf_meas_gives_the_same_increments(sim):
    """ESF-MEAS (one time tag per message, numMeas in the flags) read like ESF-RAW, within one LSB."""
    dt_s = 0.01
    n = 300
    rates = rfu_to_frd(sim.dtheta_rad[:n]) / dt_s
    acc = rfu_to_frd(sim.dvel_mps[:n]) / dt_s
    g = np.round(rates / GYRO_LSB).astype(np.int64)
    a = np.round(acc / ACC_LSB).astype(np.int64)
    tags = 1000 + 10 * np.arange(1, n + 1)
    out = bytearray()
    for k, tag in enumerate(tags):
        payload = struct.pack("<IHH", int(tag), 6 << 11, 0) + b"".join(
            struct.pack("<I", (int(v) & 0xFFFFFF) | (dtype << 24))
            for dtype, v in ((14, g[k, 0]), (13, g[k, 1]), (5, g[k, 2]), (16, a[k, 0]), (17, a[k, 1]), (18, a[k, 2]))
        )
        out += UBXMessage(b"\x10", b"\x02", GET, payload=payload).serialize()
    part = get_importer("ubx").read(bytes(out), "meas.ubx", "imu", {})
    np.testing.assert_array_equal(part.stamps.values, tags / 1000.0)
    assert np.max(np.abs(part.dtheta_rad - rfu_to_frd(sim.dtheta_rad[:n]))) <= 0.5 * GYRO_LSB * dt_s * (1 + 1e-6)
    assert np.max(np.abs(part.dvel_mps - rfu_to_frd(sim.dvel_mps[:n]))) <= 0.5 * ACC_LSB * dt_s * (1 + 1e-6)
