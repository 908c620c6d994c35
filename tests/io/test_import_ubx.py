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


def esf_raw_frames(tags, rates_frd, acc_frd, per_message=10):
    """ESF-RAW messages of ``per_message`` samples, each sample six (data, sTag) pairs laid out per the
    u-blox interface description, framed by pyubx2; returns [(index of the message's last sample, frame)]."""
    out = []
    g = np.round(rates_frd / GYRO_LSB).astype(np.int64)
    a = np.round(acc_frd / ACC_LSB).astype(np.int64)
    for k0 in range(0, len(tags), per_message):
        payload = struct.pack("<I", 0)
        for k in range(k0, min(k0 + per_message, len(tags))):
            for dtype, v in ((14, g[k, 0]), (13, g[k, 1]), (5, g[k, 2]), (16, a[k, 0]), (17, a[k, 1]), (18, a[k, 2])):
                payload += struct.pack("<II", (int(v) & 0xFFFFFF) | (dtype << 24), int(tags[k]))
        out.append(
            (min(k0 + per_message, len(tags)) - 1, UBXMessage(b"\x10", b"\x03", GET, payload=payload).serialize())
        )
    return out


def receiver_stream(sim, day, tag_rate_hz=25_598.7, tag0=16_700_000, nav_latency_s=0.0, sep_m=-16.9):
    """A u-blox receiver's stream as real ones are: ESF-RAW with sensor time tags counting at
    ``tag_rate_hz`` from ``tag0`` and wrapping at 2^24 (as on the NEO-M8U, not GPS time), ten samples per
    message, interleaved in output order with NAV-PVT (GPS ms of week) ``nav_latency_s`` after its epoch."""
    _, s0 = sow_of_midnight(day)
    t = sim.imu.t_s
    tags = (tag0 + np.round((t - t[0]) * tag_rate_hz).astype(np.int64)) % (1 << 24)
    dt_s = 1.0 / sim.scenario.imu_rate_hz
    timed = [
        (float(t[k]) + 0.002, fr)
        for k, fr in esf_raw_frames(tags, rfu_to_frd(sim.dtheta_rad) / dt_s, rfu_to_frd(sim.dvel_mps) / dt_s)
    ]
    itow = np.round((sim.gnss_t_s + s0) * 1000).astype(np.int64)
    for k, fr in nav_pvt_frames(sim, day, itow, sep_m, timed=True):
        timed.append((float(sim.gnss_t_s[k]) + nav_latency_s, fr))
    timed.sort(key=lambda x: x[0])
    return b"".join(fr for _, fr in timed)


def nav_pvt_frames(sim, day, itow_ms, sep_m=-16.9, timed=False):
    out = []
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
        out.append((k, msg.serialize()))
    return out if timed else b"".join(fr for _, fr in out)


@pytest.fixture(scope="module")
def sim():
    return simulate(catalog.drive(minutes=2.0, static_s=30.0), seed=6)


def _bundle(sim, data, axes="FRD", drop_date=True):
    files = bundle_files(sim)
    m = manifest(sim)
    m.pop("format")
    if drop_date:
        m.pop("date")  # NAV-PVT states the date
    m["imu"].pop("rate_hz")
    m["import"] = {"imu": {"axes": axes}}
    return build_bundle(
        [
            Source("imu", "ubx", "rx.ubx", data),
            Source("gnss", "ubx", "rx.ubx", data),
            Source("ldv", "native", "ldv.csv", files["ldv.csv"]),
        ],
        m,
    )


def test_esf_raw_on_the_sensor_clock_round_trip(sim):
    """sTag on a 25.6 kHz sensor clock wrapping at 2^24 (as the NEO-M8U writes it): the import must find
    the tag rate and offset from the NAV-PVT epochs in the stream. Before the fix it read the tags as GPS
    ms of week: IMU at 3.9 Hz, increments 25.6x too large, days away from the fixes."""
    data = receiver_stream(sim, dt.date.fromisoformat(sim.scenario.date))
    assert detect(data, "rx.ubx") == ("ubx", "imu")
    res = _bundle(sim, data)
    log, native = parse_files(res.files), parse_files(bundle_files(sim))
    assert str(log.manifest.date) == sim.scenario.date
    dt_s = 1.0 / sim.scenario.imu_rate_hz
    assert len(log.imu.t_s) == len(native.imu.t_s)
    # each NAV-PVT lies between the ESF-RAW messages output before and after it (ten samples, 100 ms):
    # the offset is known to half of that, as the import report states
    err = log.imu.t_s - native.imu.t_s
    half = float(next(w for w in res.warnings if "ESF-RAW time base" in w).split("(±")[2].split(" ms")[0])
    assert half == pytest.approx(50.0, abs=1.0)
    assert np.max(np.abs(err)) <= half / 1000 + 1e-4
    assert np.ptp(err) < 1e-4  # and the rate is right: one offset for the whole drive
    assert abs(log.manifest.imu.rate_hz - sim.scenario.imu_rate_hz) <= 0.001 * sim.scenario.imu_rate_hz
    # quantisation: half an LSB of rate times the interval, plus the rate × the interval's own error
    err_dt = np.abs(np.diff(log.imu.t_s) - np.diff(native.imu.t_s)).max()
    rate_max = np.abs(sim.dvel_mps[1:]).max() / dt_s
    assert np.max(np.abs(log.imu.dvel_mps[1:] - sim.dvel_mps[1:])) <= 0.5 * ACC_LSB * dt_s * 1.01 + rate_max * err_dt
    w_max = np.abs(sim.dtheta_rad[1:]).max() / dt_s
    assert np.max(np.abs(log.imu.dtheta_rad[1:] - sim.dtheta_rad[1:])) <= 0.5 * GYRO_LSB * dt_s * 1.01 + w_max * err_dt
    ok = native.gnss.fix > 0
    np.testing.assert_array_equal(log.gnss.t_s, native.gnss.t_s[ok])
    np.testing.assert_array_equal(log.gnss.fix, native.gnss.fix[ok])
    np.testing.assert_allclose(log.gnss.lat_deg, native.gnss.lat_deg[ok], atol=1e-7)  # NAV-PVT keeps 1e-7 deg
    np.testing.assert_allclose(log.gnss.h_m, native.gnss.h_m[ok], atol=1e-3)  # and mm heights
    assert b"-16.900,M" in res.files["gnss.nmea"]
    assert any("ESF-RAW time base" in w and "NAV-PVT" in w for w in res.warnings)


def test_esf_raw_without_gnss_epochs_is_refused(sim):
    data = receiver_stream(sim, dt.date.fromisoformat(sim.scenario.date))
    only_esf = b"".join(fr for fr in _split(data) if fr[2:4] == b"\x10\x03")
    with pytest.raises(BundleError) as e:
        get_importer("ubx").read(only_esf, "esf.ubx", "imu", {})
    assert e.value.file == "esf.ubx" and "sensor clock" in e.value.message and "NAV-PVT" in e.value.message


def test_a_tag_reset_is_refused(sim):
    """A sensor clock that restarts mid-log leaves the line through the NAV-PVT epochs: refused, not re-timed."""
    day = dt.date.fromisoformat(sim.scenario.date)
    data = receiver_stream(sim, day, tag0=1000)
    frames = _split(data)
    cut = len(frames) // 2
    tail = b"".join(frames[cut:])
    # the second half's tags restarted 3 s later than they should (as after a sensor reset): rebuild it
    shifted = []
    for fr in frames[cut:]:
        if fr[2:4] == b"\x10\x03":
            pl = bytearray(fr[6:-2])
            for k in range(4, len(pl), 8):
                (tag,) = struct.unpack_from("<I", pl, k + 4)
                struct.pack_into("<I", pl, k + 4, (tag + 3 * 25_599) % (1 << 24))
            fr = UBXMessage(b"\x10", b"\x03", GET, payload=bytes(pl)).serialize()
        shifted.append(fr)
    assert tail
    with pytest.raises(BundleError) as e:
        get_importer("ubx").read(b"".join(frames[:cut] + shifted), "rx.ubx", "imu", {})
    assert "do not follow GPS time" in e.value.message and e.value.field.startswith("message ")


def _split(data: bytes) -> list[bytes]:
    out, k = [], 0
    while k < len(data):
        n = struct.unpack_from("<H", data, k + 4)[0]
        out.append(data[k : k + 8 + n])
        k += 8 + n
    return out


def test_missing_axis_names_the_message(sim):
    data = receiver_stream(sim, dt.date.fromisoformat(sim.scenario.date))
    frames = _split(data)
    k = next(i for i, fr in enumerate(frames) if fr[2:4] == b"\x10\x03")
    pl = bytearray(frames[k][6:-2])
    pl = pl[:4] + pl[4 + 8 :]  # the first sample's gyro x left out
    frames[k] = UBXMessage(b"\x10", b"\x03", GET, payload=bytes(pl)).serialize()
    with pytest.raises(BundleError) as e:
        get_importer("ubx").read(b"".join(frames), "esf.ubx", "imu", {})
    assert e.value.file == "esf.ubx" and e.value.field == f"message {k + 1} dataType" and "gyro x" in e.value.message


def test_bad_checksum_frame_is_skipped(sim):
    data = receiver_stream(sim, dt.date.fromisoformat(sim.scenario.date))
    frames = _split(data)
    k = [i for i, fr in enumerate(frames) if fr[2:4] == b"\x10\x03"][3]
    bad = bytearray(frames[k])
    bad[-1] ^= 0xFF
    frames[k] = bytes(bad)
    part = get_importer("ubx").read(b"".join(frames), "esf.ubx", "imu", {})
    assert len(part.dvel_mps) == len(sim.imu.t_s) - 10 and any("checksum" in n for n in part.notes)


def test_esf_meas_accel_and_gyro_messages_joined(sim):
    """ESF-MEAS as real receivers send it: accelerometer and gyro in separate messages a few ms apart on a
    ms clock, plus tick-only messages; joined within the stated tolerance (a quarter of the 10 ms sample
    interval here), ticks ignored."""
    day = dt.date.fromisoformat(sim.scenario.date)
    _, s0 = sow_of_midnight(day)
    dt_s = 0.01
    n = len(sim.imu.t_s)
    rates = rfu_to_frd(sim.dtheta_rad) / dt_s
    acc = rfu_to_frd(sim.dvel_mps) / dt_s
    g = np.round(rates / GYRO_LSB).astype(np.int64)
    a = np.round(acc / ACC_LSB).astype(np.int64)
    t = sim.imu.t_s
    ms = 5_000_000 + np.round((t - t[0]) * 1000.7).astype(np.int64)  # a ms clock 0.07 % fast
    timed = []
    for k in range(n):
        for dtypes, vals, lag in (((16, 17, 18), a[k], 0), ((14, 13, 5, 12), list(g[k]) + [2480], -2)):
            payload = struct.pack("<IHH", int(ms[k] + lag), len(dtypes) << 11, 0) + b"".join(
                struct.pack("<I", (int(v) & 0xFFFFFF) | (d << 24)) for d, v in zip(dtypes, vals)
            )
            timed.append((t[k] + 0.003, UBXMessage(b"\x10", b"\x02", GET, payload=payload).serialize()))
        if k % 10 == 0:  # a wheel-tick message on its own
            payload = struct.pack("<IHH", int(ms[k] + 17), 1 << 11, 0) + struct.pack("<I", 10 << 24 | 5)
            timed.append((t[k] + 0.004, UBXMessage(b"\x10", b"\x02", GET, payload=payload).serialize()))
    itow = np.round((sim.gnss_t_s + s0) * 1000).astype(np.int64)
    for k, fr in nav_pvt_frames(sim, day, itow, timed=True):
        timed.append((float(sim.gnss_t_s[k]), fr))
    timed.sort(key=lambda x: x[0])
    part = get_importer("ubx").read(b"".join(fr for _, fr in timed), "meas.ubx", "imu", {})
    assert len(part.stamps.values) == n
    sow = part.stamps.values - s0
    # joined at the mean of the two tags (1 ms before the accelerometer's, whose messages tie the clock):
    # within the stated offset uncertainty (half a sample interval), that 1 ms and the 1 ms tag resolution
    stated = part.report["time_base"]["offset_uncertainty_ms"]
    assert stated == pytest.approx(5.0, abs=0.1)
    assert np.max(np.abs(sow - t)) <= (stated + 1.0 + 0.5) / 1000
    assert part.report["time_base"]["joined"] == n and part.report["time_base"]["tick_only"] == n // 10 + (n % 10 > 0)
    assert abs(part.report["time_base"]["tag_rate_hz"] / 1000.7 - 1) < 1e-3
    # the increments: half an LSB × the interval, plus the rate × one tick of the ms tags (a 1 ms interval
    # error per sample that does not accumulate: the intervals add up to the tags' span)
    f_max = np.abs(acc).max()
    err = np.abs(part.dvel_mps[1:] - rfu_to_frd(sim.dvel_mps)[1:])
    assert np.max(err) <= 0.5 * ACC_LSB * dt_s * 1.01 + f_max * 1.001e-3
    drift = np.abs(np.cumsum(part.dvel_mps[1:] - rfu_to_frd(sim.dvel_mps)[1:], axis=0)).max()
    assert drift <= f_max * 2e-3 + len(t) * 0.5 * ACC_LSB * dt_s


def test_hpposllh_preferred_over_nav_pvt(sim):
    """A receiver logging NAV-HPPOSLLH (1e-9 deg, 0.1 mm) beside NAV-PVT (1e-7 deg, mm): the high-precision
    positions are imported, with NAV-PVT's fix type of the same epoch."""
    day = dt.date.fromisoformat(sim.scenario.date)
    _, s0 = sow_of_midnight(day)
    itow = np.round((sim.gnss_t_s + s0) * 1000).astype(np.int64)
    out = bytearray()
    for k, fr in nav_pvt_frames(sim, day, itow, timed=True):
        lat, lon, h = float(sim.gnss_lat_deg[k]), float(sim.gnss_lon_deg[k]), float(sim.gnss_h_m[k])
        la, lo = round(lat * 1e7), round(lon * 1e7)
        lahp, lohp = round((lat * 1e7 - la) * 100), round((lon * 1e7 - lo) * 100)
        hmm = math.floor(h * 1000)
        hhp = round((h * 1000 - hmm) * 10)
        if hhp == 10:
            hmm, hhp = hmm + 1, 0
        payload = struct.pack(
            "<BBBBIiiiibbbbII", 0, 0, 0, 0, int(itow[k]), lo, la, hmm, hmm, lohp, lahp, hhp, hhp, 20, 30
        )
        out += fr + UBXMessage(b"\x01", b"\x14", GET, payload=payload).serialize()
    g = get_importer("ubx").read(bytes(out), "hp.ubx", "gnss", {})
    ok = sim.gnss_fix > 0
    np.testing.assert_allclose(g.lat_deg, sim.gnss_lat_deg[ok], atol=0.51e-9)
    np.testing.assert_allclose(g.lon_deg, sim.gnss_lon_deg[ok], atol=0.51e-9)
    np.testing.assert_allclose(g.h_ell_m, sim.gnss_h_m[ok], atol=0.051e-3)
    np.testing.assert_array_equal(g.fix, sim.gnss_fix[ok])
    assert any("NAV-PVT in the file left out" in n for n in g.notes)


def test_repeated_frames_are_dropped(sim):
    """The same ESF-RAW and NAV-PVT frames again later in the stream (a log fed from two ports): dropped as
    repeats, counted, the rest imported as without them. Before, the repeated tags went 'backwards'."""
    data = receiver_stream(sim, dt.date.fromisoformat(sim.scenario.date))
    frames = _split(data)
    doubled = frames[:300] + frames[100:130] + frames[300:]
    ubx = get_importer("ubx")
    a = ubx.read(data, "rx.ubx", "imu", {})
    b = ubx.read(b"".join(doubled), "rx.ubx", "imu", {})
    np.testing.assert_array_equal(a.stamps.values, b.stamps.values)
    np.testing.assert_array_equal(a.dvel_mps, b.dvel_mps)
    assert any("30 UBX frame(s) identical" in n for n in b.notes)
    g = ubx.read(b"".join(doubled), "rx.ubx", "gnss", {})
    assert len(g.lat_deg) == len(ubx.read(data, "rx.ubx", "gnss", {}).lat_deg)


def test_samples_far_from_the_gnss_epochs_are_refused(sim):
    """NAV-PVT only in the first 5 s of a 2-min log: the clock rate, known to ~0.3 % from them, would misplace
    the last samples by ~0.3 s; refused rather than extrapolated."""
    data = receiver_stream(sim, dt.date.fromisoformat(sim.scenario.date))
    frames = _split(data)
    pvt = [i for i, fr in enumerate(frames) if fr[2:4] == b"\x01\x07"]
    kept = [fr for i, fr in enumerate(frames) if fr[2:4] != b"\x01\x07" or i in pvt[:5]]
    with pytest.raises(BundleError) as e:
        get_importer("ubx").read(b"".join(kept), "rx.ubx", "imu", {})
    assert "would be off by up to" in e.value.message and e.value.field == "ESF-RAW sTag"
    part = get_importer("ubx").read(data, "rx.ubx", "imu", {})
    assert part.report["time_base"]["time_3sigma_at_ends_s"] < 0.01
