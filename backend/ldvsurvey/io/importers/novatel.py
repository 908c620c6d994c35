"""NovAtel OEM7 logs, ASCII or binary, decoded with NovAtel's EDIE library (``novatel-edie``).

- ``RAWIMUSX`` / ``RAWIMUX``: raw IMU increments. Each message states the IMU type, whose scale
  factors (OEM7 documentation, RAWIMUSX "Raw IMU scale factors") turn the counts into angle (rad)
  and velocity (m/s) increments over the sample interval. The message carries z, −y, x: the y
  fields are negated back. Axes are the IMU enclosure's (x right, y forward, z up when the IMU is
  mounted the SPAN way: ``RFU``); state another mounting with ``import.imu.axes``.
- ``BESTPOS``: position fixes (height above mean sea level and the undulation, so ellipsoidal
  height = height + undulation), solution type mapped to a GGA fix quality.
- ``INSPVAX``: the receiver's own INS solution; counted and summarised only (a reference, not an
  input of the pipelines).
"""

from __future__ import annotations

import math

import numpy as np

from ldvsurvey.errors import BundleError
from ldvsurvey.io.importers.common import GnssPart, ImuPart, Stamps

NAME = "novatel"
ROLES = ("imu", "gnss")
FT_M = 0.3048
G0 = 9.80665
ARCSEC = math.pi / 180.0 / 3600.0

#: IMU type (OEM7 enum) -> (name, rad per gyro count, m/s per accel count, counts are rates x rate?)
#: The Epson units report rate-like counts: one count is the stated value divided by the data rate.
SCALES = {
    1: ("HG1700_AG11", 2.0**-33, FT_M * 2.0**-27, False),
    4: ("HG1700_AG17", 2.0**-33, FT_M * 2.0**-26, False),
    5: ("HG1900_CA29", 2.0**-33, FT_M * 2.0**-27, False),
    8: ("LN200", 2.0**-19, 2.0**-14, False),
    11: ("HG1700_AG58", 2.0**-33, FT_M * 2.0**-27, False),
    12: ("HG1700_AG62", 2.0**-33, FT_M * 2.0**-26, False),
    13: ("IMAR_FSAS", 0.1 / 2.0**8 * ARCSEC, 0.05 / 2.0**15, False),
    16: ("KVH_COTS", 0.1 / (3600.0 * 256.0), 0.05 / 2.0**15, False),
    20: ("HG1930_AA99", 2.0**-33, FT_M * 2.0**-27, False),
    26: ("ISA100C", 1.0e-9, 2.0e-8, False),
    27: ("HG1900_CA50", 2.0**-33, FT_M * 2.0**-27, False),
    28: ("HG1930_CA50", 2.0**-33, FT_M * 2.0**-27, False),
    31: ("ADIS16488", math.radians(720.0 / 2.0**31), 200.0 / 2.0**31, False),
    32: ("STIM300", math.radians(2.0**-21), 2.0**-22, False),
    33: ("KVH_1750", 0.1 / (3600.0 * 256.0), 0.05 / 2.0**15, False),
    41: ("EPSON_G320", math.radians(0.008 / 2.0**16), 0.2 / 2.0**16 * G0 / 1000.0, True),
    52: ("LITEF_MICROIMU", 1.0e-9, 2.0e-8, False),
    56: ("STIM300D", math.radians(2.0**-21), 2.0**-22, False),
    58: ("HG4930_AN01", 2.0**-33, 2.0**-29, False),
    61: ("EPSON_G370", math.radians(0.0151515 / 2.0**16), 0.4 / 2.0**16 * G0 / 1000.0, True),
    62: ("EPSON_G320_200HZ", math.radians(0.008 / 2.0**16), 0.2 / 2.0**16 * G0 / 1000.0, True),
    68: ("HG4930_AN04", 2.0**-33, 2.0**-29, False),
}
#: BESTPOS position type names -> GGA fix quality (NONE and unknown: not used)
FIX_OF_TYPE = {
    "SINGLE": 1,
    "PSRDIFF": 2,
    "WAAS": 2,
    "PROPAGATED": 1,
    "L1_FLOAT": 5,
    "NARROW_FLOAT": 5,
    "IONOFREE_FLOAT": 5,
    "L1_INT": 4,
    "WIDE_INT": 4,
    "NARROW_INT": 4,
    "RTK_DIRECT_INS": 4,
    "INS_SBAS": 2,
    "INS_PSRSP": 1,
    "INS_PSRDIFF": 2,
    "INS_RTKFLOAT": 5,
    "INS_RTKFIXED": 4,
    "PPP_CONVERGING": 5,
    "PPP": 4,
    "PPP_BASIC_CONVERGING": 5,
    "PPP_BASIC": 4,
}


def sniff(data: bytes, name: str) -> str | None:
    head = data[:8192]
    if (
        b"\xaa\x44\x12" in head
        or b"\xaa\x44\x13" in head
        or b"#RAWIMU" in head
        or b"%RAWIMU" in head
        or b"#BESTPOS" in head
    ):
        return "imu" if (b"RAWIMU" in head or b"\xaa\x44\x13" in head) else "gnss"
    return None


def _messages(data: bytes, file: str, bad: list):
    """Yield (message number, message) for every decoded message; undecodable frames go to ``bad``."""
    try:
        import novatel_edie as ne
        from novatel_edie import oem
    except ImportError:  # pragma: no cover - a dependency of the package
        raise BundleError("the novatel-edie package is not installed", file=file) from None
    parser = oem.Parser()
    pos, n = 0, 0
    while True:
        if pos < len(data):
            pos += parser.write(data[pos : pos + max(1, min(parser.available_space, 1 << 18))])
        for msg in parser:
            n += 1
            if isinstance(msg, ne.UnknownBytes):
                if bytes(msg.data).strip():
                    bad.append(n)
                continue
            yield n, msg
        if pos >= len(data):
            break
    rest = parser.flush(True)
    if rest and bytes(rest).strip():
        bad.append(n + 1)


def read(data: bytes, file: str, role: str, opts: dict):
    if role not in ROLES:
        raise BundleError(f"the novatel format has no '{role}' data (it has: imu, gnss)", file=file)
    bad: list[int] = []
    imu_rows, pos_rows, ins = [], [], 0
    types = set()
    for n, msg in _messages(data, file, bad):
        name = type(msg).__name__.split("_")[0]
        if name in ("RAWIMUSX", "RAWIMUX") and role == "imu":
            d = msg.to_dict()
            if d["imu_type"] not in SCALES:
                raise BundleError(
                    f"IMU type {d['imu_type']} has no known scale factors (known: "
                    f"{', '.join(f'{k} {v[0]}' for k, v in SCALES.items())})",
                    file=file,
                    field=f"message {n} imu_type",
                )
            types.add(d["imu_type"])
            imu_rows.append(
                (
                    d["gps_week"],
                    d["gps_seconds"],
                    d["gyro_x"],
                    -d["gyro_y"],
                    d["gyro_z"],
                    d["accel_x"],
                    -d["accel_y"],
                    d["accel_z"],
                    n,
                )
            )
        elif name == "BESTPOS" and role == "gnss":
            d = msg.to_dict()
            status, ptype = d["solution_status"].name, d["position_type"].name
            fix = FIX_OF_TYPE.get(ptype, 0)
            if status != "SOL_COMPUTED" or fix == 0:
                continue
            h = d["header"]
            pos_rows.append(
                (
                    h["week"],
                    h["milliseconds"] / 1000.0,
                    d["latitude"],
                    d["longitude"],
                    d["height"] + d["undulation"],
                    d["undulation"],
                    fix,
                    d["num_soln_svs"],
                    n,
                )
            )
        elif name == "INSPVAX":
            ins += 1
    notes = []
    if bad:
        notes.append(
            f"{file}: {len(bad)} undecodable frame(s) (bad CRC or truncated) skipped, first at message {bad[0]}"
        )
    if ins:
        notes.append(f"{file}: {ins} INSPVAX message(s) (the receiver's INS solution) kept as reference only")
    if role == "imu":
        if not imu_rows:
            raise BundleError("no RAWIMUSX or RAWIMUX message", file=file)
        if len(types) > 1:
            raise BundleError(f"messages of several IMU types {sorted(types)}", file=file, field="imu_type")
        a = np.array(imu_rows, dtype=np.float64)
        tname, s_gyro, s_acc, per_rate = SCALES[types.pop()]
        if per_rate:
            rate = float(opts.get("rate_hz") or 0) or (1.0 / float(np.median(np.diff(a[:, 1]))) if len(a) > 1 else 0.0)
            if not rate > 0:
                raise BundleError(
                    "a single RAWIMUSX message of a rate-scaled IMU: give import.imu.rate_hz",
                    file=file,
                    field="rate_hz",
                )
            rate = float(round(rate))  # the nominal data rate (the time tags' jitter must not scale the data)
            s_gyro, s_acc = s_gyro / rate, s_acc / rate
        notes.append(f"{file}: IMU type {tname}: {s_gyro:.6g} rad and {s_acc:.6g} m/s per count")
        return ImuPart(
            stamps=Stamps("gps", a[:, 1], a[:, 8].astype(np.int64), week=a[:, 0].astype(np.int64)),
            dtheta_rad=a[:, 2:5] * s_gyro,
            dvel_mps=a[:, 5:8] * s_acc,
            axes=opts.get("axes", "RFU"),
            notes=notes,
            quantum=(s_gyro, s_acc),
        )
    if not pos_rows:
        raise BundleError("no BESTPOS message with a computed solution", file=file)
    a = np.array(pos_rows, dtype=np.float64)
    return GnssPart(
        stamps=Stamps("gps", a[:, 1], a[:, 8].astype(np.int64), week=a[:, 0].astype(np.int64)),
        lat_deg=a[:, 2],
        lon_deg=a[:, 3],
        h_ell_m=a[:, 4],
        sep_m=a[:, 5],
        fix=a[:, 6].astype(np.int16),
        n_sat=a[:, 7],
        notes=notes,
    )
