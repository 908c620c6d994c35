"""u-blox UBX binary logs, read with ``pyubx2``.

- ``ESF-RAW`` and ``ESF-MEAS``: the sensor fusion's raw gyro (data types 14, 13, 5: x, y, z, in
  2^-12 deg/s) and accelerometer (16, 17, 18: x, y, z, in 2^-10 m/s²) samples, 24-bit signed.
  They are rates, turned into increments over (t_prev, t] as sample × (t − t_prev): a sample is
  read as the mean rate over the interval that ends at its time tag. Time tags are read as GPS
  milliseconds of the week (``import.imu.time_offset_s`` adds an offset in s for receivers whose
  sensor time tag runs on another clock). Axes: the u-blox frame, x forward, y right, z down
  (``FRD``), unless ``import.imu.axes`` says otherwise.
- ``NAV-PVT``: fixes with a valid date and ``gnssFixOk``; ellipsoidal height and height above
  mean sea level give the geoid separation; ``carrSoln`` fixed → 4, float → 5, ``diffSoln`` → 2,
  else 1.
"""

from __future__ import annotations

import datetime as dt
import io
import math

import numpy as np

from ldvsurvey.errors import BundleError
from ldvsurvey.io.importers.common import GnssPart, ImuPart, Stamps
from ldvsurvey.io.importers.gpstime import GPS_EPOCH, WEEK_S, gps_minus_utc_s

NAME = "ubx"
ROLES = ("imu", "gnss")
GYRO = {14: 0, 13: 1, 5: 2}
ACCEL = {16: 0, 17: 1, 18: 2}
GYRO_LSB_RPS = math.radians(2.0**-12)
ACCEL_LSB_MPS2 = 2.0**-10


def sniff(data: bytes, name: str) -> str | None:
    head = data[:8192]
    if b"\xb5\x62\x10\x03" in head or b"\xb5\x62\x10\x02" in head:
        return "imu"
    if b"\xb5\x62\x01\x07" in head:
        return "gnss"
    return None


def _signed24(v: int) -> int:
    v &= 0xFFFFFF
    return v - (1 << 24) if v & 0x800000 else v


def _messages(data: bytes, file: str, errors: list):
    try:
        from pyubx2 import UBX_PROTOCOL, UBXReader
    except ImportError:  # pragma: no cover
        raise BundleError("the pyubx2 package is not installed", file=file) from None
    reader = UBXReader(io.BytesIO(data), protfilter=UBX_PROTOCOL, quitonerror=1, errorhandler=errors.append)
    n = 0
    for _raw, msg in reader:
        if msg is None:
            continue
        n += 1
        yield n, msg


def read(data: bytes, file: str, role: str, opts: dict):
    if role not in ROLES:
        raise BundleError(f"the ubx format has no '{role}' data (it has: imu, gnss)", file=file)
    errs: list = []
    samples: dict[int, list] = {}  # time tag -> [gyro xyz, accel xyz, message number]
    fixes = []
    for n, msg in _messages(data, file, errs):
        ident = msg.identity
        if role == "imu" and ident == "ESF-RAW":
            k = 1
            while hasattr(msg, f"data_{k:02d}"):
                raw = int.from_bytes(getattr(msg, f"data_{k:02d}"), "little")
                tag = int.from_bytes(getattr(msg, f"sTag_{k:02d}"), "little")
                _put(samples, tag, raw >> 24, _signed24(raw), n)
                k += 1
        elif role == "imu" and ident == "ESF-MEAS":
            for k in range(1, int(msg.numMeas) + 1):
                field = getattr(msg, f"dataField_{k:02d}")
                value = int.from_bytes(field, "little") if isinstance(field, bytes) else int(field)
                _put(samples, int(msg.timeTag), int(getattr(msg, f"dataType_{k:02d}")), _signed24(value), n)
        elif role == "gnss" and ident == "NAV-PVT":
            if not (msg.validDate and msg.validTime and msg.gnssFixOk) or msg.fixType not in (2, 3, 4):
                continue
            day = dt.date(msg.year, msg.month, msg.day)
            utc = dt.datetime(msg.year, msg.month, msg.day, msg.hour, msg.min, msg.second)
            gps_s = (utc - GPS_EPOCH).total_seconds() + gps_minus_utc_s(day)
            week = int((gps_s + 1.0) // WEEK_S)
            itow_s = msg.iTOW / 1000.0
            if itow_s < 1.0 and (gps_s - week * WEEK_S) > WEEK_S - 2.0:
                week += 1
            fix = 4 if msg.carrSoln == 2 else 5 if msg.carrSoln == 1 else 2 if msg.diffSoln else 1
            fixes.append(
                (
                    week,
                    itow_s,
                    msg.lat,
                    msg.lon,
                    msg.height / 1000.0,
                    (msg.height - msg.hMSL) / 1000.0,
                    fix,
                    msg.numSV,
                    msg.pDOP,
                    n,
                )
            )
    notes = []
    if errs:
        notes.append(f"{file}: {len(errs)} UBX frame(s) with a bad checksum or length skipped ({errs[0]})")
    if role == "gnss":
        if not fixes:
            raise BundleError("no NAV-PVT message with a valid date and a fix", file=file)
        a = np.array(fixes, dtype=np.float64)
        return GnssPart(
            stamps=Stamps("gps", a[:, 1], a[:, 9].astype(np.int64), week=a[:, 0].astype(np.int64)),
            lat_deg=a[:, 2],
            lon_deg=a[:, 3],
            h_ell_m=a[:, 4],
            sep_m=a[:, 5],
            fix=a[:, 6].astype(np.int16),
            n_sat=a[:, 7],
            hdop=a[:, 8],
            notes=notes,
        )
    if not samples:
        raise BundleError("no ESF-RAW or ESF-MEAS message", file=file)
    tags = np.array(sorted(samples), dtype=np.float64)
    rows = np.array([samples[int(t)][:6] for t in tags], dtype=np.float64)
    where = np.array([samples[int(t)][6] for t in tags], dtype=np.int64)
    missing = np.isnan(rows).any(axis=1)
    if missing.any():
        k = int(np.flatnonzero(missing)[0])
        which = ["gyro x (14)", "gyro y (13)", "gyro z (5)", "accel x (16)", "accel y (17)", "accel z (18)"]
        gaps = [w for w, v in zip(which, rows[k]) if np.isnan(v)]
        raise BundleError(
            f"time tag {int(tags[k])} lacks {', '.join(gaps)}", file=file, field=f"message {where[k]} dataType"
        )
    # ms time tags wrap at 2^32 ms (49.7 days): unwrap, then seconds
    t_s = tags / 1000.0 + float(opts.get("time_offset_s", 0.0))
    if len(t_s) < 2:
        raise BundleError("fewer than two sensor samples", file=file)
    dt_s = np.diff(t_s)
    dt_s = np.concatenate(([np.median(dt_s)], dt_s))
    notes.append(f"{file}: ESF time tags read as GPS ms of week; rates × interval give the increments")
    return ImuPart(
        stamps=Stamps("gps", t_s[:], where),
        dtheta_rad=rows[:, 0:3] * GYRO_LSB_RPS * dt_s[:, None],
        dvel_mps=rows[:, 3:6] * ACCEL_LSB_MPS2 * dt_s[:, None],
        axes=opts.get("axes", "FRD"),
        notes=notes,
    )


def _put(samples, tag, dtype, value, n):
    row = samples.get(tag)
    if row is None:
        row = samples[tag] = [np.nan] * 6 + [n]
    if dtype in GYRO:
        row[GYRO[dtype]] = value
    elif dtype in ACCEL:
        row[3 + ACCEL[dtype]] = value
