"""NovAtel OEM4/OEM6/OEM7 logs, ASCII or binary, decoded with NovAtel's EDIE library (``novatel-edie``).

Fields are read **by meaning** through EDIE's message definitions: each message has several
definition versions in EDIE's database (keyed by the definition CRC the receiver writes in the
header), and the same quantity is named differently in some of them (BESTPOS ``height`` and
``orthometric_height``; RAWIMU ``accel_z`` and ``del_vel_body_z``). :data:`MEANINGS` lists the names
of every quantity; a definition without one is an error naming the message and the quantity.

- ``RAWIMUSX`` / ``RAWIMUX`` / ``RAWIMUS`` / ``RAWIMU``: raw IMU increments. The X variants state the
  IMU type; for the others give it as ``import.imu.imu_type`` (a name or number of :data:`SCALES`).
  The type's scale factors (OEM7 documentation, "Raw IMU scale factors") turn the counts into angle
  (rad) and velocity (m/s) increments over the sample interval. The message carries z, −y, x: the
  y fields are negated back. Axes are the IMU enclosure's (x right, y forward, z up when the IMU is
  mounted the SPAN way: ``RFU``); state another mounting with ``import.imu.axes``.
- ``CORRIMUDATA`` / ``CORRIMUDATAS`` / ``CORRIMUS`` / ``IMURATECORRIMUS`` (the corrected IMU messages of
  EDIE's database; IMURATECORRIMUS is CORRIMUS at the IMU's full rate): decoded, but refused as the IMU
  input, the refusal naming the messages the log holds. NovAtel's OEM7 manual defines them as the raw
  IMU data after the receiver's INS removed gravity, the Earth's rotation and its own estimated sensor
  errors, rotated into the receiver's output frame (vehicle by default): a strapdown mechanisation
  needs the specific force and the rotation against inertial space the IMU measured, gravity and Earth
  rate included. The refusal prints the mean specific force of IMURATECORRIMUS/CORRIMUDATA (documented
  as increments per sample, or accumulated over the logging interval): about 0 m/s² where the raw
  increments give about 9.8. An ``INSCONFIG`` message's IMU type is named with the logs to ask for.
- ``BESTGNSSPOS`` (GNSS only) is preferred over ``BESTPOS``; on a SPAN receiver BESTPOS blends the
  receiver's INS, and aiding an INS with it is circular (a warning says so). Height above mean
  sea level plus the undulation is the ellipsoidal height. Every solution type of EDIE's
  ``SolType`` is mapped to a GGA quality or left out (:data:`FIX_OF_TYPE`, :data:`NOT_MEASURED`).
- ``INSPVA`` / ``INSPVAS`` / ``INSPVAX``: the receiver's own INS solution, kept as a reference
  trajectory (:class:`~ldvsurvey.io.importers.common.Reference`) to compare against, never an input.
- The same message logged on several ports (identical content and time) is kept once and counted.
- ASCII with LF-only line ends is read (EDIE's framer wants CR LF); NMEA sentences inside the
  stream are counted as NMEA, not as undecodable frames.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from dataclasses import field as _field
from typing import NamedTuple

import numpy as np

from ldvsurvey.errors import BundleError
from ldvsurvey.io.importers.common import GnssPart, ImuPart, Reference, Stamps
from ldvsurvey.io.importers.contract import Importer, Option

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
#: position/solution type (EDIE's SolType) -> GGA fix quality
FIX_OF_TYPE = {
    "SINGLE": 1,
    "INS_PSRSP": 1,
    "PSRDIFF": 2,
    "WAAS": 2,
    "OMNISTAR": 2,
    "CDGPS": 2,
    "INS_SBAS": 2,
    "INS_PSRDIFF": 2,
    "INS_OMNISTAR": 2,
    "FLOATCONV": 5,
    "WIDELANE": 5,
    "L1_FLOAT": 5,
    "NARROW_FLOAT": 5,
    "IONOFREE_FLOAT": 5,
    "L1L2_FLOAT": 5,
    "INS_RTKFLOAT": 5,
    "OMNISTAR_HP": 5,
    "OMNISTAR_XP": 5,
    "INS_OMNISTAR_HP": 5,
    "INS_OMNISTAR_XP": 5,
    "PPP_CONVERGING": 5,
    "INS_PPP_CONVERGING": 5,
    "PPP_BASIC_CONVERGING": 5,
    "INS_PPP_BASIC_CONVERGING": 5,
    "NARROWLANE": 4,
    "L1_INT": 4,
    "WIDE_INT": 4,
    "NARROW_INT": 4,
    "L1L2_INT": 4,
    "L1L2_INT_VERIFIED": 4,
    "RTK_DIRECT_INS": 4,
    "INS_RTKFIXED": 4,
    "PPP": 4,
    "INS_PPP": 4,
    "PPP_PLUS": 4,
    "INS_PPP_PLUS": 4,
    "PPP_BASIC": 4,
    "INS_PPP_BASIC": 4,
}
#: solution types that are no measured position: left out and counted
NOT_MEASURED = {
    "NONE": "no solution",
    "FIXEDPOS": "a position entered by the operator",
    "FIXEDHEIGHT": "a height entered by the operator",
    "FIXEDVEL": "a velocity entered by the operator",
    "DOPPLER_VELOCITY": "a velocity only",
    "PROPAGATED": "propagated without new observations",
    "EXT_CONSTRAINED": "constrained by an external source",
    "OPERATIONAL": "a status, not a solution",
    "WARNING": "a status, not a solution",
    "OUT_OF_BOUNDS": "a status, not a solution",
    "MAX_DONT_USE": "not a solution type",
}

#: quantity -> its field names in EDIE's message definitions, all versions
MEANINGS = {
    "week": ("gps_week", "week"),
    "seconds": ("gps_seconds", "seconds"),
    "imu_type": ("imu_type",),
    "z_accel": ("accel_z", "del_vel_body_z"),
    "neg_y_accel": ("accel_y", "del_vel_body_y"),
    "x_accel": ("accel_x", "del_vel_body_x"),
    "z_gyro": ("gyro_z", "del_ang_body_z"),
    "neg_y_gyro": ("gyro_y", "del_ang_body_y"),
    "x_gyro": ("gyro_x", "del_ang_body_x"),
    "solution_status": ("solution_status",),
    "position_type": ("position_type",),
    "latitude": ("latitude",),
    "longitude": ("longitude",),
    "height_msl": ("orthometric_height", "height"),  # BESTPOS, BESTGNSSPOS, INSPVAX: above mean sea level
    "height_ell": ("height",),  # INSPVA, INSPVAS: ellipsoidal
    "undulation": ("undulation",),
    "num_soln_svs": ("num_soln_svs",),
    "north_vel": ("north_vel",),
    "east_vel": ("east_vel",),
    "up_vel": ("up_vel",),
    "roll": ("roll",),
    "pitch": ("pitch",),
    "azimuth": ("azimuth",),
    "ins_status": ("ins_solution_status",),
}
RAW_IMU = ("RAWIMUSX", "RAWIMUX", "RAWIMUS", "RAWIMU")
CORR_IMU = ("CORRIMUDATA", "CORRIMUDATAS", "CORRIMUS", "IMURATECORRIMUS")
POSITIONS = ("BESTGNSSPOS", "BESTPOS")  # in the order of preference
INS_PVA = ("INSPVA", "INSPVAS", "INSPVAX")
#: the messages read, and the meanings each one needs (checked against every definition in EDIE's database)
NEEDS = {
    **{m: ("week", "seconds", "z_accel", "neg_y_accel", "x_accel", "z_gyro", "neg_y_gyro", "x_gyro") for m in RAW_IMU},
    **{
        m: ("solution_status", "position_type", "latitude", "longitude", "height_msl", "undulation", "num_soln_svs")
        for m in POSITIONS
    },
    "INSPVA": ("week", "seconds", "latitude", "longitude", "height_ell", "north_vel", "east_vel", "up_vel", "roll")
    + ("pitch", "azimuth", "ins_status"),
    "INSPVAS": ("week", "seconds", "latitude", "longitude", "height_ell", "north_vel", "east_vel", "up_vel", "roll")
    + ("pitch", "azimuth", "ins_status"),
    "INSPVAX": ("ins_status", "latitude", "longitude", "height_msl", "undulation", "north_vel", "east_vel", "up_vel")
    + ("roll", "pitch", "azimuth"),
}
_SYNC_BINARY = (b"\xaa\x44\x12", b"\xaa\x44\x13", b"\xaa\x44\xb5")
_PROMPT = re.compile(rb"(?:\[?[A-Z]*COM\d*\]?|\]|<OK|\s)+")  # port prompts and replies, in pieces as EDIE cuts them


def sniff(data: bytes, name: str) -> str | None:
    """``imu`` (raw IMU logs) or ``gnss`` when the first 8 kB hold a NovAtel binary sync or ASCII log, else None."""
    head = data[:8192]
    if any(s in head for s in _SYNC_BINARY[:2]) or any(
        t in head for t in (b"#RAWIMU", b"%RAWIMU", b"#BESTPOS", b"#BESTGNSSPOS", b"#INSPVA", b"%INSPVA")
    ):
        return "imu" if (b"RAWIMU" in head or b"\xaa\x44\x13" in head) else "gnss"
    return None


def field(d: dict, meaning: str, msg: str, n: int, crc: int | None, file: str):
    """The value of a quantity in a decoded message, whatever its definition version calls it."""
    for name in MEANINGS[meaning]:
        if name in d:
            return d[name]
    crc_s = f" (definition CRC 0x{crc:04x})" if crc is not None else ""
    raise BundleError(
        f"{msg}{crc_s} has no field for '{meaning}' (looked for {', '.join(MEANINGS[meaning])}; "
        f"it has: {', '.join(k for k in d if k != 'header')})",
        file=file,
        field=f"message {n} {meaning}",
    )


def _ascii_crlf(data: bytes) -> bytes:
    """EDIE frames ASCII logs on CR LF: give LF-only text (no binary frame in it) CR LF line ends."""
    if any(s in data for s in _SYNC_BINARY):
        return data
    data = data.replace(b"\r\n", b"\n").replace(b"\n", b"\r\n")
    return data if data.endswith(b"\r\n") else data + b"\r\n"


def _messages(data: bytes, file: str, bad: list, nmea: list):
    """Yield (message number, name, decoded message) for every decoded message; undecodable frames go
    to ``bad``, NMEA sentences in the stream to ``nmea``."""
    try:
        import novatel_edie as ne
        from novatel_edie import oem
    except ImportError:  # pragma: no cover - a dependency of the package
        raise BundleError("the novatel-edie package is not installed", file=file) from None
    data = _ascii_crlf(data)
    parser = oem.Parser()
    pos, n = 0, 0
    while True:
        if pos < len(data):
            pos += parser.write(data[pos : pos + max(1, min(parser.available_space, 1 << 18))])
        for msg in parser:
            n += 1
            if isinstance(msg, ne.UnknownBytes):
                raw = bytes(msg.data)
                if raw.lstrip().startswith(b"$") and b"*" in raw:
                    nmea.append(n)
                elif raw.strip() and not _PROMPT.fullmatch(raw.strip()):  # "[ICOM1]", "<OK": port prompts
                    bad.append(n)
                continue
            yield n, type(msg).__name__.split("_")[0], msg
        if pos >= len(data):
            break
    rest = parser.flush(True)
    if rest and bytes(rest).strip():
        bad.append(n + 1)


def _imu_type(value, file: str) -> int:
    """An IMU type from ``import.imu.imu_type``: a number or a name of :data:`SCALES`."""
    if isinstance(value, int) and not isinstance(value, bool) and value in SCALES:
        return value
    names = {v[0]: k for k, v in SCALES.items()}
    if isinstance(value, str) and value.strip().upper() in names:
        return names[value.strip().upper()]
    raise BundleError(
        f"unknown IMU type {value!r} (known: {', '.join(f'{k} {v[0]}' for k, v in SCALES.items())})",
        file="manifest (partial)",
        field="import.imu.imu_type",
    )


def read(data: bytes, file: str, role: str, opts: dict):
    """Raw IMU increments or GNSS positions of a NovAtel log (see the module docstring).

    Parameters
    ----------
    data : bytes
        The file's content.
    file : str
        The file's name, for messages.
    role : str
        ``imu`` (RAWIMU family) or ``gnss`` (BESTGNSSPOS, else BESTPOS).
    opts : dict
        ``import.<role>`` of the partial manifest: ``imu_type`` (RAWIMU/RAWIMUS), ``rate_hz`` (Epson, Hz), ``axes``.

    Returns
    -------
    ImuPart or GnssPart
        Increments (rad, m/s; axes RFU unless given) or fixes (deg, ellipsoidal height m, undulation m), on GPS
        week and seconds, with INSPVA as a reference trajectory when logged.

    Raises
    ------
    BundleError
        Naming the message number and the quantity.
    """
    if role not in ROLES:
        raise BundleError(f"the novatel format has no '{role}' data (it has: imu, gnss)", file=file)
    dec = _decode(data, file, role, opts)
    notes = []
    if dec.bad:
        notes.append(
            f"{file}: {len(dec.bad)} undecodable frame(s) (bad CRC or truncated) skipped, first at message {dec.bad[0]}"
        )
    if dec.nmea:
        notes.append(f"{file}: {len(dec.nmea)} NMEA sentence(s) in the stream (read them with the nmea format)")
    if dec.repeats:
        notes.append(f"{file}: {dec.repeats} message(s) repeated on another port (same content and time) kept once")
    reference = _reference(dec.ref_rows, file, notes)
    if role == "imu":
        return _imu_part(dec, file, opts, notes, reference)
    return _gnss_part(dec, file, notes, reference)


class _Message(NamedTuple):
    """One decoded message: its number in the stream, name, field values by name, definition CRC and header time."""

    n: int
    name: str
    values: dict
    crc: int | None
    week: int  #: GPS week of the header
    ms: float  #: header time, ms of the GPS week
    file: str

    def value(self, meaning: str):
        """The value of a quantity of :data:`MEANINGS`, whatever this message's definition calls it."""
        return field(self.values, meaning, self.name, self.n, self.crc, self.file)


@dataclass
class _Decoded:
    """The rows a log's messages give for one role, and what was left out or refused on the way."""

    #: RAWIMU family: (week, s of week, gyro x, y, z, accel x, y, z in counts, message number)
    imu_rows: list = _field(default_factory=list)
    corr: dict = _field(default_factory=dict)  #: corrected IMU messages (not usable): name -> count
    #: IMURATECORRIMUS/CORRIMUDATA(S) rows for the refusal's figure: (week, s of week, dv x, y, z in m/s)
    corr_dv: list = _field(default_factory=list)
    imu_config: set = _field(default_factory=set)  #: IMU types named by INSCONFIG messages
    ref_rows: list = _field(default_factory=list)  #: INSPVA family rows, see :func:`_ins_row`
    #: BESTGNSSPOS and BESTPOS rows: (week, s of week, lat deg, lon deg, h_ell m, undulation m, fix, n_sat, message)
    pos_rows: dict = _field(default_factory=lambda: {m: [] for m in POSITIONS})
    left_out: dict = _field(default_factory=dict)  #: "message type (why)" -> count of positions left out
    ins_types: int = 0  #: positions of an INS solution type
    types: set = _field(default_factory=set)  #: IMU types of the raw IMU messages
    type_names: set = _field(default_factory=set)  #: the raw IMU messages' names
    body_named: list = _field(default_factory=list)  #: a definition naming the fields del_vel_body_*
    bad: list = _field(default_factory=list)  #: message numbers of undecodable frames
    nmea: list = _field(default_factory=list)  #: message numbers of NMEA sentences in the stream
    repeats: int = 0  #: messages logged again on another port


def _decode(data: bytes, file: str, role: str, opts: dict) -> _Decoded:
    """The rows of every message the role reads (and of INSPVA), each message once (a repeat on another port has
    the same content and time; a different one for the same time is refused)."""
    dec = _Decoded()
    seen: dict[tuple, int] = {}  # (name, time) -> hash of the body
    names_of: dict[type, list] = {}
    for n, name, msg in _messages(data, file, dec.bad, dec.nmea):
        want = (role == "imu" and name in (*RAW_IMU, *CORR_IMU, "INSCONFIG")) or (role == "gnss" and name in POSITIONS)
        if not want and name not in INS_PVA:
            continue
        kind = type(msg)
        if kind not in names_of:  # one definition version: its field names, once
            names_of[kind] = msg.get_field_names()
        values = msg.get_field_values()
        hdr = msg.header
        m = _Message(
            n, name, dict(zip(names_of[kind], values)), hdr.message_definition_crc, hdr.week, hdr.milliseconds, file
        )
        if name == "INSCONFIG":  # the receiver's INS configuration (logged on change): only its IMU type is read
            t = m.values.get("imu_type")
            if t is not None:
                dec.imu_config.add(f"{getattr(t, 'name', t)} (type {int(t)})")
            continue
        key = (name, m.week, m.ms, m.values.get("gps_seconds", m.values.get("seconds")))
        try:
            body = hash(tuple(values))
        except TypeError:  # array fields
            body = hash(repr(values))
        if key in seen:
            if seen[key] == body:  # the same message logged on another port
                dec.repeats += 1
                continue
            raise BundleError(
                f"two different {name} messages for the same time (week {key[1]}, {key[2]} ms)",
                file=file,
                field=f"message {n}",
            )
        seen[key] = body
        if name in RAW_IMU:
            _raw_imu(dec, m, opts)
        elif name in CORR_IMU:
            _corrected(dec, m)
        elif name in POSITIONS:
            _position(dec, m)
        elif name in INS_PVA:
            dec.ref_rows.append(_ins_row(m))
    return dec


def _corrected(dec: _Decoded, m: _Message) -> None:
    """A corrected IMU message counted by name; of IMURATECORRIMUS and CORRIMUDATA(S) (velocity increments per
    sample, or accumulated over the logging interval: OEM7 manual) the velocity increment kept for the figure of
    the refusal. CORRIMUS (its increments with a count of accumulated samples) is counted only."""
    dec.corr[m.name] = dec.corr.get(m.name, 0) + 1
    if m.name == "CORRIMUS" or "week" not in m.values or "seconds" not in m.values:
        return
    v = m.values
    dv = v.get("corr_fb")
    if dv is None and all(k in v for k in ("lateral", "longitudinal", "vertical")):
        dv = (v["lateral"], v["longitudinal"], v["vertical"])
    if dv is not None and len(dv) == 3:
        dec.corr_dv.append((v["week"], v["seconds"], *(float(x) for x in dv)))


def _refuse_corrected(dec: _Decoded, file: str) -> BundleError:
    """The refusal of a log whose only IMU messages are corrected ones: which they are, why they cannot be the IMU
    input (with their mean specific force when the log tells it) and what to log instead."""
    held = ", ".join(f"{n} {k}" for k, n in sorted(dec.corr.items(), key=lambda kv: -kv[1]))
    figure = ""
    if len(dec.corr_dv) > 1:
        a = np.array(sorted(dec.corr_dv), dtype=np.float64)
        t = a[:, 0] * 604800.0 + a[:, 1]
        dt = float(np.median(np.diff(t)))
        if dt > 0:
            f = float(np.linalg.norm(a[:, 2:].mean(axis=0))) / dt
            figure = (
                f"; their mean specific force here is {f:.3f} m/s² over {t[-1] - t[0]:.1f} s, where raw increments "
                f"of a unit on Earth give about {G0:.1f} m/s² (gravity's reaction)"
            )
    imu = f"; its INSCONFIG names the IMU: {', '.join(sorted(dec.imu_config))}" if dec.imu_config else ""
    return BundleError(
        f"no raw IMU message, only corrected ones: {held}. NovAtel's corrected IMU messages (CORRIMUDATA, "
        "CORRIMUDATAS, CORRIMUS, IMURATECORRIMUS) are the IMU increments after the receiver's INS removed "
        "gravity, the Earth's rotation and its own sensor error estimates, rotated into its output (vehicle) "
        f"frame{figure}. A strapdown mechanisation needs the increments as the IMU measured them: log RAWIMUSXB "
        f"ONNEW (or RAWIMUXB, RAWIMUSB, RAWIMUB) on the receiver{imu}",
        file=file,
        field=f"message {max(dec.corr, key=dec.corr.get)}",
    )


def _known_types() -> str:
    """The IMU types of :data:`SCALES`, as ``number name`` for messages."""
    return ", ".join(f"{k} {v[0]}" for k, v in SCALES.items())


def _raw_imu(dec: _Decoded, m: _Message, opts: dict) -> None:
    """A RAWIMU-family message's row (counts in x, y, z order: the message carries z, -y, x) and its IMU type."""
    if "imu_type" in m.values:
        t = int(m.values["imu_type"])
        if t not in SCALES:
            raise BundleError(
                f"IMU type {t} has no known scale factors (known: {_known_types()})",
                file=m.file,
                field=f"message {m.n} imu_type",
            )
    elif opts.get("imu_type") is not None:
        t = _imu_type(opts["imu_type"], m.file)
    else:
        raise BundleError(
            f"{m.name} does not state the IMU type: give it as import.imu.imu_type (known: {_known_types()})",
            file=m.file,
            field=f"message {m.n} imu_type",
        )
    dec.types.add(t)
    dec.type_names.add(m.name)
    if "del_vel_body_y" in m.values and not dec.body_named:
        dec.body_named.append(f"{m.name} 0x{m.crc:04x}")
    f = m.value
    dec.imu_rows.append(
        (
            f("week"),
            f("seconds"),
            f("x_gyro"),
            -f("neg_y_gyro"),
            f("z_gyro"),
            f("x_accel"),
            -f("neg_y_accel"),
            f("z_accel"),
            m.n,
        )
    )


def _position(dec: _Decoded, m: _Message) -> None:
    """A BESTGNSSPOS/BESTPOS row (ellipsoidal height = height above mean sea level + undulation, m), or its solution
    type counted as left out when it is no computed, measured position."""
    f = m.value
    status, ptype = f("solution_status").name, f("position_type").name
    if status != "SOL_COMPUTED" or ptype not in FIX_OF_TYPE:
        why = NOT_MEASURED.get(ptype, "an unknown solution type") if status == "SOL_COMPUTED" else status
        k = f"{m.name} {ptype if status == 'SOL_COMPUTED' else status} ({why})"
        dec.left_out[k] = dec.left_out.get(k, 0) + 1
        return
    dec.ins_types += ptype.startswith("INS") or ptype == "RTK_DIRECT_INS"
    und = float(f("undulation"))
    dec.pos_rows[m.name].append(
        (
            m.week,
            m.ms / 1000.0,
            f("latitude"),
            f("longitude"),
            float(f("height_msl")) + und,
            und,
            FIX_OF_TYPE[ptype],
            f("num_soln_svs"),
            m.n,
        )
    )


def _ins_row(m: _Message) -> tuple:
    """An INSPVA-family row: week, s of week, lat and lon deg, h_ell m, v east/north/up m/s, roll, pitch and azimuth
    deg, message number, INS status."""
    f = m.value
    if m.name == "INSPVAX":
        week, sow = m.week, m.ms / 1000.0
        h_ell = float(f("height_msl")) + float(f("undulation"))
    else:
        week, sow, h_ell = f("week"), f("seconds"), float(f("height_ell"))
    return (week, sow, f("latitude"), f("longitude"), h_ell, f("east_vel"), f("north_vel"), f("up_vel")) + (
        f("roll"),
        f("pitch"),
        f("azimuth"),
        m.n,
        f("ins_status").name,
    )


def _imu_part(dec: _Decoded, file: str, opts: dict, notes: list, reference) -> ImuPart:
    """The raw IMU samples as increments (rad, m/s) by the IMU type's scale factors; CORRIMUDATA alone refused."""
    if not dec.imu_rows:
        if dec.corr:
            raise _refuse_corrected(dec, file)
        raise BundleError("no RAWIMUSX, RAWIMUX, RAWIMUS or RAWIMU message", file=file)
    if len(dec.types) > 1:
        raise BundleError(f"messages of several IMU types {sorted(dec.types)}", file=file, field="imu_type")
    if dec.corr:
        held = ", ".join(f"{n} {k}" for k, n in sorted(dec.corr.items()))
        notes.append(
            f"{file}: {held} message(s) ignored (corrected by the receiver's INS: gravity and the Earth's rotation "
            "removed); the raw IMU messages are read"
        )
    if dec.body_named:
        notes.append(
            f"{file}: definition {dec.body_named[0]} names the increments del_vel_body_*/del_ang_body_*; they are "
            "read in RAWIMU's documented order and signs (z, -y, x): check the y axis (the static check "
            "sees only the vertical)"
        )
    a = np.array(dec.imu_rows, dtype=np.float64)
    if len(dec.type_names) > 1:
        a = _once_per_sample(a, dec.type_names, file, notes)
    tname, s_gyro, s_acc = _scales(dec.types.pop(), a, opts, file)
    notes.append(
        f"{file}: {', '.join(sorted(dec.type_names))} of IMU type {tname}: {s_gyro:.6g} rad and {s_acc:.6g} m/s "
        "per count; time base GPS week and seconds of the IMU sample"
    )
    return ImuPart(
        stamps=Stamps("gps", a[:, 1], a[:, 8].astype(np.int64), week=a[:, 0].astype(np.int64)),
        dtheta_rad=a[:, 2:5] * s_gyro,
        dvel_mps=a[:, 5:8] * s_acc,
        axes=opts.get("axes", "RFU"),
        notes=notes,
        quantum=(s_gyro, s_acc),
        reference=reference,
    )


def _once_per_sample(a: np.ndarray, type_names: set, file: str, notes: list) -> np.ndarray:
    """Raw IMU rows of several messages (e.g. RAWIMUSX and RAWIMUX of the same samples) on one time line, each sample
    once; two different samples for the same time refused."""
    a = a[np.lexsort((a[:, 8], a[:, 1], a[:, 0]))]
    same_t = (np.diff(a[:, 0]) == 0) & (np.diff(a[:, 1]) == 0)
    differ = same_t & ~np.all(a[1:, 2:8] == a[:-1, 2:8], axis=1)
    if differ.any():
        k = int(np.flatnonzero(differ)[0]) + 1
        raise BundleError(
            f"two different raw IMU samples for the same time ({', '.join(sorted(type_names))})",
            file=file,
            field=f"message {int(a[k, 8])}",
        )
    if same_t.any():
        notes.append(
            f"{file}: {int(same_t.sum())} IMU sample(s) logged in both {' and '.join(sorted(type_names))} kept once"
        )
        a = a[np.concatenate(([True], ~same_t))]
    return a


def _scales(imu_type: int, a: np.ndarray, opts: dict, file: str) -> tuple[str, float, float]:
    """The IMU type's name and its rad per gyro count and m/s per accelerometer count; for rate-scaled (Epson) types
    divided by the nominal data rate (Hz: ``import.imu.rate_hz`` or the median of the time tags, rounded)."""
    tname, s_gyro, s_acc, per_rate = SCALES[imu_type]
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
    return tname, s_gyro, s_acc


def _gnss_part(dec: _Decoded, file: str, notes: list, reference) -> GnssPart:
    """The positions of BESTGNSSPOS, else BESTPOS (a warning when a SPAN receiver's BESTPOS blends its INS)."""
    for k, v in dec.left_out.items():
        notes.append(f"{file}: {v} {k} left out")
    use = next((m for m in POSITIONS if dec.pos_rows[m]), None)
    if use is None:
        raise BundleError("no BESTGNSSPOS or BESTPOS message with a computed, measured solution", file=file)
    if use == "BESTGNSSPOS" and dec.pos_rows["BESTPOS"]:
        notes.append(f"{file}: BESTGNSSPOS used; {len(dec.pos_rows['BESTPOS'])} BESTPOS (INS-blended on SPAN) ignored")
    if use == "BESTPOS" and (dec.ins_types or dec.ref_rows or dec.corr or dec.types):
        notes.append(
            f"{file}: BESTPOS of a SPAN receiver blends the receiver's own INS (INS solution types or INS logs "
            "in the file): aiding an INS with it is circular; log BESTGNSSPOS"
        )
    a = np.array(dec.pos_rows[use], dtype=np.float64)
    return GnssPart(
        stamps=Stamps("gps", a[:, 1], a[:, 8].astype(np.int64), week=a[:, 0].astype(np.int64)),
        lat_deg=a[:, 2],
        lon_deg=a[:, 3],
        h_ell_m=a[:, 4],
        sep_m=a[:, 5],
        fix=a[:, 6].astype(np.int16),
        n_sat=a[:, 7],
        notes=notes,
        reference=reference,
    )


def _reference(rows: list, file: str, notes: list) -> Reference | None:
    """INSPVA/INSPVAS/INSPVAX rows (one per epoch, the first message kept) as a reference trajectory."""
    if not rows:
        return None
    rows = sorted(rows, key=lambda r: (r[0], r[1], r[11]))
    keep = [r for k, r in enumerate(rows) if k == 0 or (r[0], r[1]) != (rows[k - 1][0], rows[k - 1][1])]
    a = np.array([r[:12] for r in keep], dtype=np.float64)
    notes.append(
        f"{file}: {len(keep)} INSPVA/INSPVAX epoch(s) (the receiver's own INS solution) kept as a reference "
        "trajectory, not an input"
    )
    return Reference(
        source=f"{file} INSPVA/INSPVAX",
        stamps=Stamps("gps", a[:, 1], a[:, 11].astype(np.int64), week=a[:, 0].astype(np.int64)),
        lat_deg=a[:, 2],
        lon_deg=a[:, 3],
        h_ell_m=a[:, 4],
        v_enu_mps=a[:, 5:8],
        rpy_deg=a[:, 8:11],
        status=[r[12] for r in keep],
    )


IMPORTER = Importer(
    NAME,
    ROLES,
    read,
    sniff,
    options=(
        Option("imu_type", (str, int), "IMU type (name or number) for RAWIMU/RAWIMUS, which do not state it", ("imu",)),
        Option(
            "rate_hz", (float,), "data rate of a rate-scaled IMU (Epson) when the time tags cannot tell, Hz", ("imu",)
        ),
    ),
    summary="NovAtel OEM4/6/7 logs, ASCII or binary: RAWIMU family, BESTGNSSPOS/BESTPOS, INSPVA (reference)",
)
