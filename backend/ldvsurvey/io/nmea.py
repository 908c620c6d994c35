"""NMEA 0183 text; GGA sentences give time, position and fix quality, the first RMC the date.

The one NMEA reader of the product: the bundle's ``gnss.nmea`` (strict: a defective GGA sentence
is an error naming its line and field) and the ``nmea`` importer of field recordings (``lenient``:
a defective GGA sentence is skipped, counted and the first one named in a warning) both read
through :func:`parse_nmea`.
"""

from __future__ import annotations

import datetime as dt
import math
import re
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np

from ldvsurvey.errors import BundleError

FILE = "gnss.nmea"
#: GGA fix quality as people read it: the one list the API views and the dashboard use
#: (served as ``GET /api/names``)
FIX_QUALITY_NAMES = {
    0: "0 no fix",
    1: "1 GPS",
    2: "2 DGPS",
    3: "3 PPS",
    4: "4 RTK fixed",
    5: "5 RTK float",
    6: "6 dead reckoning",
    7: "7 manual",
    8: "8 simulation",
}


@dataclass
class GnssData:
    """GGA epochs. Heights are ellipsoidal (altitude + geoid separation) at the antenna.

    Attributes
    ----------
    t_s : numpy.ndarray
        Seconds since 00:00 UTC of ``manifest.date`` (past 86400 after midnight).
    lat_deg, lon_deg, h_m : numpy.ndarray
        WGS-84 latitude, longitude (deg) and ellipsoidal height (m); NaN without a fix.
    fix : numpy.ndarray
        GGA fix quality (0 none, 1 single, 2 differential, 4 RTK fixed, 5 RTK float).
    sep_m : numpy.ndarray
        Geoid separation (m) the sentence states; NaN where its field is empty (then ``h_m`` is the
        altitude field as it stands).
    day : datetime.date or None
        UTC day of the first row, from the first valid RMC sentence, else from the first ZDA at the time of a fix
        (None without either).
    """

    t_s: np.ndarray
    lat_deg: np.ndarray
    lon_deg: np.ndarray
    h_m: np.ndarray
    fix: np.ndarray
    n_sat: np.ndarray
    hdop: np.ndarray
    line_of_row: np.ndarray
    bad_checksum: int = 0
    malformed_lines: int = 0
    duplicate_epochs: int = 0
    skipped_sentences: dict = field(default_factory=dict)
    warnings: list = field(default_factory=list)
    sep_m: np.ndarray | None = None
    day: dt.date | None = None
    day_from: str | None = None  #: the sentence that states ``day`` (``RMC line 12``, ``ZDA line 3``)
    no_fix: int = 0  #: GGA sentences without a solution (quality 0 or empty) left out
    defective: int = 0  #: (lenient) GGA sentences with a good checksum but a defective field, skipped

    def __len__(self) -> int:
        return len(self.t_s)


class GgaFields(NamedTuple):
    """The fields of one GGA sentence, or of many column by column (one array entry per sentence)."""

    tod_s: float | np.ndarray  #: UTC time of day, s
    lat_deg: float | np.ndarray  #: WGS-84 latitude, deg (NaN without a fix)
    lon_deg: float | np.ndarray  #: WGS-84 longitude, deg
    h_m: float | np.ndarray  #: ellipsoidal height (altitude + separation), m
    fix: int | np.ndarray  #: GGA fix quality
    n_sat: float | np.ndarray  #: satellites in use (NaN when empty)
    hdop: float | np.ndarray  #: horizontal dilution of precision (NaN when empty)
    sep_m: float | np.ndarray  #: geoid separation, m (NaN when empty)


_TIME = re.compile(r"\d{6}(\.\d*)?")
_DM = re.compile(r"(\d+)(\d\d\.\d+)")
_TALKER_GGA = re.compile(r"\w{2}GGA")


def _checksums(bodies: list[str]) -> np.ndarray:
    """XOR of the bytes of every sentence body (between ``$`` and ``*``), all at once."""
    enc = [b.encode("ascii", "replace") for b in bodies]
    lengths = np.fromiter((len(b) for b in enc), dtype=np.int64, count=len(enc))
    out = np.zeros(len(enc), dtype=np.int64)
    nonempty = lengths > 0
    if nonempty.any():
        arr = np.frombuffer(b"".join(enc), dtype=np.uint8)
        starts = (np.cumsum(lengths) - lengths)[nonempty]
        out[nonempty] = np.bitwise_xor.reduceat(arr, starts)
    return out


def _given_checksum(text: str) -> int:
    try:
        return int(text, 16)
    except ValueError:
        return -1  # never equals an XOR of bytes


def _num(value: str, line: int, name: str, *, allow_empty: bool = True) -> float:
    if value == "":
        if allow_empty:
            return math.nan
        raise BundleError("empty field", file=FILE, line=line, field=name)
    try:
        x = float(value)
    except ValueError:
        raise BundleError(f"'{value}' is not a number", file=FILE, line=line, field=name) from None
    if not math.isfinite(x):
        raise BundleError(f"'{value}' is not a finite number", file=FILE, line=line, field=name)
    return x


def _time_of_day(value: str, line: int) -> float:
    """``hhmmss[.ss]`` to seconds of the day (fraction rounded to the nearest microsecond)."""
    if value == "":
        raise BundleError("GGA without time", file=FILE, line=line, field="time")
    if not _TIME.fullmatch(value):
        raise BundleError(f"'{value}' is not a time hhmmss[.ss]", file=FILE, line=line, field="time")
    hh, mm, ss = int(value[0:2]), int(value[2:4]), int(value[4:6])
    if hh > 23 or mm > 59 or ss > 59:
        raise BundleError(f"'{value}' is not a time of day", file=FILE, line=line, field="time")
    frac = value[6:]
    us = round(float(frac) * 1_000_000) if frac not in ("", ".") else 0
    return hh * 3600 + mm * 60 + ss + us * 1e-6


def _degrees(dm: str, hemi: str, line: int, name: str, hemispheres: str) -> float:
    """NMEA ``(d)ddmm.mmmm`` plus hemisphere letter to signed degrees."""
    if dm == "0":
        deg = 0.0
    else:
        m = _DM.fullmatch(dm)
        if not m:
            raise BundleError(f"'{dm}' is not a coordinate (d)ddmm.mmmm", file=FILE, line=line, field=name)
        deg = float(m.group(1)) + float(m.group(2)) / 60
    if hemi not in hemispheres:
        raise BundleError(
            f"hemisphere must be {'/'.join(hemispheres)}, got '{hemi}'", file=FILE, line=line, field=f"{name[:3]}_dir"
        )
    return -deg if hemi in "SW" else deg


def _gga(body: str, lineno: int) -> GgaFields:
    """The fields of one GGA sentence body (time of day s, lat and lon deg, h m, fix, n_sat, hdop, sep m)."""
    f = body.split(",")
    if not _TALKER_GGA.fullmatch(f[0]) or "*" in body:
        raise BundleError(f"GGA sentence could not be parsed: '{body[:40]}'", file=FILE, line=lineno)
    if len(f) < 15:
        f += [""] * (15 - len(f))
    tod = _time_of_day(f[1], lineno)
    fix = f[6]
    if fix == "":
        raise BundleError("empty field", file=FILE, line=lineno, field="fix_quality")
    if not fix.isdigit():
        raise BundleError(f"'{fix}' is not a fix quality (integer)", file=FILE, line=lineno, field="fix_quality")
    fix = int(fix)
    if fix > 0:
        if not f[2] or not f[4]:
            raise BundleError("fix quality > 0 but no position", file=FILE, line=lineno, field="latitude")
        lat = _degrees(f[2], f[3], lineno, "latitude", "NS")
        lon = _degrees(f[4], f[5], lineno, "longitude", "EW")
        alt = _num(f[9], lineno, "altitude", allow_empty=False)
        sep = _num(f[11], lineno, "geoid_separation")
        h = alt + (0.0 if math.isnan(sep) else sep)
    else:
        lat = lon = h = sep = math.nan
    return GgaFields(tod, lat, lon, h, fix, _num(f[7], lineno, "num_sats"), _num(f[8], lineno, "hdop"), sep)


_COL_TIME = re.compile(r"(?:\d{6}(?:\.\d*)?\n)*\d{6}(?:\.\d*)?")
_COL_INT = re.compile(r"(?:\d+\n)*\d+")
_COL_DM = re.compile(r"(?:\d{3,}\.\d+\n)*\d{3,}\.\d+")


def _tof(col) -> np.ndarray:
    """Decimal strings to float64 with Arrow's (correctly rounded) parser; ValueError if one is not a number."""
    import pyarrow as pa
    import pyarrow.compute as pc

    data = "".join(col).encode("ascii", "replace")  # built from buffers: pa.array(list) would import pandas
    offsets = np.zeros(len(col) + 1, dtype=np.int32)
    np.cumsum(np.fromiter(map(len, col), dtype=np.int32, count=len(col)), out=offsets[1:])
    strings = pa.StringArray.from_buffers(len(col), pa.py_buffer(offsets), pa.py_buffer(data))
    try:
        x = pc.cast(strings, pa.float64())
        if x.null_count:
            raise ValueError("empty value")
        # from the value buffer: Array.to_numpy would import pandas (a second's start-up)
        return np.frombuffer(x.buffers()[1], dtype=np.float64, count=len(x), offset=8 * x.offset).copy()
    except (pa.ArrowInvalid, pa.ArrowTypeError) as exc:
        raise ValueError(str(exc)) from None


def _floats(col, *, empty_ok: bool) -> np.ndarray:
    """Strings to float64 (empty to NaN when allowed); ValueError on anything else than a finite number."""
    if empty_ok:
        empty = np.fromiter((v == "" for v in col), dtype=bool, count=len(col))
        x = _tof(["nan" if v == "" else v for v in col])
        if not np.isfinite(x[~empty]).all():
            raise ValueError("not finite")
        return x
    x = _tof(col)
    if not np.isfinite(x).all():
        raise ValueError("not finite")
    return x


def _dm_degrees(col) -> np.ndarray:
    """``(d)ddmm.mmmm`` strings (already checked) to degrees, as ``float(d) + float(mm.mmmm) / 60``."""
    cut = [v.index(".") - 2 for v in col]
    d = _tof([v[:k] for v, k in zip(col, cut)])
    m = _tof([v[k:] for v, k in zip(col, cut)])
    return d + m / 60


def _gga_columns(bodies: list[str]) -> GgaFields | None:
    """All GGA sentences at once, column by column; None when anything is unusual (then the
    line-by-line path runs and names the exact line and field)."""
    rows = [b.split(",") for b in bodies]
    if not rows or any(len(r) != 15 for r in rows) or any("*" in b for b in bodies):
        return None
    cols = list(zip(*rows))
    if not all(_TALKER_GGA.fullmatch(v) for v in set(cols[0])):
        return None
    t_col, fix_col = cols[1], cols[6]
    if not _COL_TIME.fullmatch("\n".join(t_col)) or not _COL_INT.fullmatch("\n".join(fix_col)):
        return None
    whole = _tof([v[:6] for v in t_col]).astype(np.int64)
    hh, mm, ss = whole // 10000, whole // 100 % 100, whole % 100
    if (hh > 23).any() or (mm > 59).any() or (ss > 59).any():
        return None
    frac = _tof([v[6:] if len(v) > 7 else "0" for v in t_col])
    tod = (hh * 3600 + mm * 60 + ss) + np.rint(frac * 1_000_000).astype(np.int64) * 1e-6
    fix = _tof(fix_col).astype(np.int64)
    n = len(rows)
    lat, lon, h, sep_all = np.full(n, np.nan), np.full(n, np.nan), np.full(n, np.nan), np.full(n, np.nan)
    pos = np.flatnonzero(fix > 0)
    try:
        if len(pos):
            pick = [rows[i] for i in pos.tolist()]
            lat_s, ns, lon_s, ew, alt_s, sep_s = (
                list(c) for c in zip(*((r[2], r[3], r[4], r[5], r[9], r[11]) for r in pick))
            )
            if (
                not _COL_DM.fullmatch("\n".join(lat_s))
                or not _COL_DM.fullmatch("\n".join(lon_s))
                or not set(ns) <= {"N", "S"}
                or not set(ew) <= {"E", "W"}
            ):
                return None
            sign_lat = np.where(np.array(ns) == "S", -1.0, 1.0)
            sign_lon = np.where(np.array(ew) == "W", -1.0, 1.0)
            sep = _floats(sep_s, empty_ok=True)
            lat[pos] = sign_lat * _dm_degrees(lat_s)
            lon[pos] = sign_lon * _dm_degrees(lon_s)
            h[pos] = _floats(alt_s, empty_ok=False) + np.where(np.isnan(sep), 0.0, sep)
            sep_all[pos] = sep
        n_sat = _floats(cols[7], empty_ok=True)
        hdop = _floats(cols[8], empty_ok=True)
    except ValueError:
        return None
    return GgaFields(tod, lat, lon, h, fix, n_sat, hdop, sep_all)


_RMC_DATE = re.compile(r"\d{6}")
#: GGA qualities that are no measured position: estimated (dead reckoning), manual input, simulator
NOT_MEASURED = ("6", "7", "8")


_AIS = re.compile(r"!\w{2}VD[MO],")  #: AIS's encapsulated sentences (!AIVDM, !AIVDO...): no position of ours


def _split_sentences(text: str) -> tuple[list[int], list[str], list[str], tuple[int, int, int]]:
    """(line, body, given checksum) of every ``$...*hh`` sentence, and the counts of lines that are no sentence,
    of sentences found after other bytes on their line (e.g. a binary frame) and of AIS lines (``!AIVDM``)."""
    malformed = after_binary = ais = 0
    cand_line, cand_body, cand_cks = [], [], []
    for lineno, raw in enumerate(text.split("\n"), start=1):  # LF only: other control bytes are no line end
        line = raw.strip()
        if not line:
            continue
        k = line.rfind("$")  # a sentence right after a binary frame on the frame's "line", or "$$GNGGA"
        if k < 0 or "*" not in line[k:]:
            if _AIS.match(line):
                ais += 1
            else:
                malformed += 1
            continue
        if k:
            if line[:k].strip("$"):
                after_binary += 1
            line = line[k:]
        body, _, cks = line[1:].rpartition("*")
        cand_line.append(lineno)
        cand_body.append(body)
        cand_cks.append(cks)
    return cand_line, cand_body, cand_cks, (malformed, after_binary, ais)


def _rmc_date(body: str) -> tuple[float, dt.date] | None:
    """(UTC time of day s, date) of a valid (status A) RMC sentence body, or None."""
    f = body.split(",")
    if len(f) < 10 or f[2] != "A" or not _TIME.fullmatch(f[1]) or not _RMC_DATE.fullmatch(f[9]):
        return None  # void (V) sentences may carry a date from an unset clock
    hh, mm, ss = int(f[1][0:2]), int(f[1][2:4]), int(f[1][4:6])
    dd, mo, yy = int(f[9][0:2]), int(f[9][2:4]), int(f[9][4:6])
    if hh > 23 or mm > 59 or ss > 59:
        return None
    try:
        day = dt.date(2000 + yy if yy < 80 else 1900 + yy, mo, dd)
    except ValueError:
        return None
    return hh * 3600.0 + mm * 60.0 + ss, day


def _zda_date(body: str) -> tuple[float, dt.date] | None:
    """(UTC time of day s, date) of a ZDA sentence body (``hhmmss.ss,dd,mm,yyyy,...``), or None."""
    f = body.split(",")
    if len(f) < 5 or not _TIME.fullmatch(f[1]) or not (f[2].isdigit() and f[3].isdigit() and f[4].isdigit()):
        return None
    hh, mm, ss = int(f[1][0:2]), int(f[1][2:4]), int(f[1][4:6])
    if hh > 23 or mm > 59 or ss > 59 or len(f[4]) != 4:
        return None
    try:
        day = dt.date(int(f[4]), int(f[3]), int(f[2]))
    except ValueError:
        return None
    return hh * 3600.0 + mm * 60.0 + ss + float("0" + f[1][6:]), day


def parse_nmea(data: bytes, t_ref_s: float | None = None, *, file: str = FILE, lenient: bool = False) -> GnssData:
    """Parse NMEA text. Bad checksums are skipped and counted; non-GGA sentences skipped.

    The checksums of all sentences are computed at once (numpy); only GGA sentences are split
    into fields. GGA sentences without a solution (quality 0 or empty, e.g. the pre-fix
    ``$GPGGA,,,,,,0,,,,M,,M,,*66``) carry no epoch: left out (with ``lenient``, or when they have no
    time) and counted. A sentence after other bytes on its line (a binary frame) is read. Every
    error names the file, the line and the field.

    Parameters
    ----------
    data : bytes
        File content (CRLF or LF line ends).
    t_ref_s : float, optional
        A time near the log's start (s of day, e.g. the first IMU time) used to place
        the first GGA on the right day; later epochs keep counting past midnight.
    file : str
        The file's name in messages (default ``gnss.nmea``).
    lenient : bool
        For field recordings: a GGA sentence with a good checksum but a defective field (no
        altitude, an unreadable coordinate...) is skipped and counted, the first one named in a
        warning, instead of being an error. Only fixes (quality > 0) are returned.

    Raises
    ------
    BundleError
        Empty file, no valid GGA, (strict) a GGA field that is not a number, a time going backwards.
    """
    if not data.strip():
        raise BundleError("file is empty", file=file, line=1)
    if data.startswith(b"\xef\xbb\xbf"):  # a UTF-8 byte-order mark: the text is ASCII all the same
        data = data[3:]
    tally = _Tally()
    gga_body, gga_line, skipped, dates = _sort_sentences(*_checked_sentences(data, tally), lenient, tally)
    cols, gga_line = _gga_fields(gga_body, gga_line, file, lenient, tally)
    rows = _epochs(cols.tod_s.tolist(), gga_line, t_ref_s, file, lenient, tally) if cols is not None else []
    if lenient and rows:
        rows = _order(rows, cols, gga_line, file, tally)
    rows = [(j, t) for j, t, *_ in rows]
    _check_epochs(len(rows), file, lenient, tally, skipped)
    keep = np.array([j for j, _ in rows], dtype=np.int64)
    t_s = np.array([t for _, t in rows], dtype=np.float64)
    got = GgaFields(*(np.asarray(c)[keep] for c in cols))
    line_of_row = np.array(gga_line, dtype=np.int64)[keep]
    day, day_from = _day_of(dates, line_of_row, t_s, tally)
    return GnssData(
        t_s=t_s,
        lat_deg=got.lat_deg.astype(np.float64),
        lon_deg=got.lon_deg.astype(np.float64),
        h_m=got.h_m.astype(np.float64),
        fix=got.fix.astype(np.int16),
        n_sat=got.n_sat.astype(np.float64),
        hdop=got.hdop.astype(np.float64),
        line_of_row=line_of_row,
        bad_checksum=tally.bad_checksum,
        malformed_lines=tally.malformed,
        duplicate_epochs=tally.duplicates,
        skipped_sentences=skipped,
        warnings=_warnings(file, lenient, tally),
        sep_m=got.sep_m.astype(np.float64),
        day=day,
        day_from=day_from,
        no_fix=tally.no_fix,
        defective=tally.defective,
    )


@dataclass
class _Tally:
    """What :func:`parse_nmea` left out on the way, for the warnings: counts and the first of each kind."""

    bad_checksum: int = 0
    malformed: int = 0  #: lines that are no NMEA sentence
    after_binary: int = 0  #: sentences read after other bytes on their line
    ais: int = 0  #: AIS lines (!AIVDM, !AIVDO): ignored
    positions: dict = field(default_factory=dict)  #: RMC and GLL sentences with a valid position, by type
    first_position_line: int | None = None
    good_sentences: int = 0  #: sentences with a good checksum
    gga_seen: int = 0  #: GGA sentences with a good checksum
    no_fix: int = 0
    not_measured: int = 0  #: GGA of quality 6, 7 or 8
    defective: int = 0
    duplicates: int = 0  #: epochs of a time already seen, dropped (the first kept)
    repeats_exact: int = 0  #: of which the same fix again
    out_of_order: int = 0  #: (lenient) epochs that came after a later one, sorted into place
    date_conflict: str | None = None  #: RMC and ZDA state different days
    head_bytes: int = 0  #: bytes looked at for :attr:`control_bytes`
    control_bytes: int = 0  #: zero and control bytes among them (binary data, or text in UTF-16)
    first_defect: BundleError | None = None
    first_backwards: BundleError | None = None


def _checked_sentences(data: bytes, tally: _Tally) -> tuple[list[int], list[str]]:
    """(line, body) of every sentence with a good checksum; the others and the lines that are none counted."""
    head = np.frombuffer(data[:65536], dtype=np.uint8)
    ctrl = (head < 32) & (head != 9) & (head != 10) & (head != 13)  # zero and control bytes: no text
    tally.head_bytes, tally.control_bytes = len(head), int(np.count_nonzero(ctrl))
    text = data.decode("ascii", "replace")
    cand_line, cand_body, cand_cks, (tally.malformed, tally.after_binary, tally.ais) = _split_sentences(text)
    ok = _checksums(cand_body) == np.fromiter(
        (_given_checksum(c.strip()[:2]) for c in cand_cks), dtype=np.int64, count=len(cand_cks)
    )
    tally.bad_checksum = int(len(ok) - np.count_nonzero(ok))
    tally.good_sentences = int(np.count_nonzero(ok))
    good = np.flatnonzero(ok).tolist()
    return [cand_line[i] for i in good], [cand_body[i] for i in good]


_GLL_VALID = re.compile(r"\w{2}GLL,\d+\.?\d*,[NS],\d+\.?\d*,[EW],[^,]*,A")  #: a GLL with a position, status A


def _count_position(tally: _Tally, kind: str, lineno: int) -> None:
    tally.positions[kind] = tally.positions.get(kind, 0) + 1
    if tally.first_position_line is None:
        tally.first_position_line = lineno


def _sort_sentences(lines: list[int], bodies: list[str], lenient: bool, tally: _Tally):
    """The GGA sentences with an epoch (bodies, lines), the other sentences counted by type, and the dates: (line,
    time of day s, date) of the first RMC with a date (or None) and of every ZDA with one; GGA without a fix or
    not measured counted."""
    skipped: dict[str, int] = {}
    gga_body, gga_line = [], []
    rmc, zda = None, []
    for lineno, body in zip(lines, bodies):
        head = body[: body.find(",")] if "," in body else body
        stype = head[-3:]
        if stype != "GGA" or body.startswith("P"):
            if stype == "RMC" and not body.startswith("P"):
                got = _rmc_date(body)
                if got is not None:
                    _count_position(tally, "RMC", lineno)
                    rmc = rmc or (lineno, *got)
            elif stype == "GLL" and not body.startswith("P") and _GLL_VALID.match(body):
                _count_position(tally, "GLL", lineno)
            elif stype == "ZDA" and not body.startswith("P") and len(zda) < 1000:
                got = _zda_date(body)
                if got is not None:
                    zda.append((lineno, *got))
            skipped[stype] = skipped.get(stype, 0) + 1
            continue
        tally.gga_seen += 1
        f = body.split(",", 7)
        quality = f[6] if len(f) > 6 else ""
        if (quality == "" and lenient) or (quality == "0" and (lenient or f[1] == "")):
            tally.no_fix += 1  # no solution: no epoch (pre-fix sentences often have no time either)
            continue
        if lenient and quality in NOT_MEASURED:
            tally.not_measured += 1
            continue
        gga_body.append(body)
        gga_line.append(lineno)
    return gga_body, gga_line, skipped, (rmc, zda)


def _gga_fields(gga_body: list[str], gga_line: list[int], file: str, lenient: bool, tally: _Tally):
    """The GGA fields column by column (None without one) and the lines they come from: all at once, or line by
    line when anything is unusual, so that an error names its line and field (lenient: defective ones skipped)."""
    cols = _gga_columns(gga_body)
    if cols is not None or not gga_body:
        return cols, gga_line
    parsed, lines_ok = [], []
    for b, ln in zip(gga_body, gga_line):
        try:
            parsed.append(_gga(b, ln))
        except BundleError as exc:
            if not lenient:
                raise BundleError(exc.message, file=file, line=exc.line, field=exc.field) from None
            tally.defective += 1
            if tally.first_defect is None:
                tally.first_defect = exc
            continue
        lines_ok.append(ln)
    return (GgaFields(*(np.array(c) for c in zip(*parsed))) if parsed else None), lines_ok


def _epochs(tod: list[float], gga_line: list[int], t_ref_s, file: str, lenient: bool, tally: _Tally) -> list:
    """(index, time s on the counting clock) of each epoch in file order: times of day (s) counted on past midnight
    from the day nearest ``t_ref_s`` (an epoch half a day or more before the latest so far is after a midnight, one
    half a day or more after it from before a midnight already passed). Strict: a repeated epoch dropped, one going
    backwards refused. Lenient: all kept, with the latest time before an epoch that comes late (else None), see
    :func:`_order`."""
    rows = []
    k_day = None
    top = None  # the latest time so far
    for j, lineno in enumerate(gga_line):
        if k_day is None:
            ref = t_ref_s if t_ref_s is not None else tod[j]
            k_day = round((ref - tod[j]) / 86400.0)
        t = tod[j] + 86400.0 * k_day
        if top is not None and t < top - 43200.0:  # passed midnight
            k_day += 1
            t += 86400.0
        elif top is not None and t > top + 43200.0:  # written late, from before a midnight already passed
            t -= 86400.0
        late = top is not None and t <= top
        if late and not lenient:
            if t == top:  # the same epoch again (e.g. GP and GN talkers): keep the first
                tally.duplicates += 1
                continue
            raise BundleError(
                f"GGA time goes backwards: {t:.2f} s after {top:.2f} s", file=file, line=lineno, field="time"
            )
        rows.append((j, t, top if late and t < top else None))  # the latest time before a late epoch
        top = t if top is None else max(top, t)
    return rows


#: an epoch sorted into place is no track when it leaves the path between its neighbours by more than this (m) ...
DETOUR_M = 25.0
#: ... at a speed more than this many times the rest of the log's (plus SPEED_SLACK_MPS)
SPEED_FACTOR = 3.0
SPEED_SLACK_MPS = 5.0


def _local_xy(lat_deg: np.ndarray, lon_deg: np.ndarray) -> np.ndarray:
    """Metres east and north of the first point (spherical Earth; enough to judge a track's plausibility)."""
    r = 6371000.0
    lat, lon = np.radians(lat_deg), np.radians(lon_deg)
    dlon = (lon - lon[0] + np.pi) % (2 * np.pi) - np.pi
    return np.column_stack([r * np.cos(lat[0]) * dlon, r * (lat - lat[0])])


def _order(rows: list, cols: GgaFields, gga_line: list[int], file: str, tally: _Tally) -> list:
    """(index, time) of the epochs sorted by time (lenient reading of field recordings).

    Receivers and loggers write epochs out of order (a 4-Hz receiver ...58.250 before 58.000, a handheld repeating
    epochs after a reset): the epochs are sorted by time; an epoch of a time already seen is dropped (the first in
    the file kept), counted as an exact repeat (same fix) or not. The sorted fixes must make one track: an epoch
    that came late and, sorted into place, leaves the path between its neighbours by more than ``DETOUR_M`` at a
    speed well above the rest of the log's is a clock that jumped: refused naming its line."""
    order = sorted(range(len(rows)), key=lambda k: rows[k][1])  # stable: file order among equal times
    kept = []
    for k in order:
        j, t, late = rows[k]
        if kept and t == rows[kept[-1]][1]:
            i = rows[kept[-1]][0]
            same = all(cols[c][i] == cols[c][j] for c in (1, 2, 3, 4)) or all(np.isnan(cols[c][i]) for c in (1, 2))
            tally.duplicates += 1
            tally.repeats_exact += int(bool(same))
            continue
        kept.append(k)
    late = sorted((rows[k] for k in kept if rows[k][2] is not None), key=lambda r: r[0])
    tally.out_of_order = len(late)
    if late:
        j, t, top = late[0]
        tally.first_backwards = BundleError(
            f"GGA time goes backwards: {t:.2f} s after {top:.2f} s", file=file, line=gga_line[j], field="time"
        )
    if tally.out_of_order:
        _check_track([rows[k] for k in kept], cols, gga_line, file, tally)
    return [(rows[k][0], rows[k][1]) for k in kept]


def _check_track(rows: list, cols: GgaFields, gga_line: list[int], file: str, tally: _Tally) -> None:
    """Refuse when an epoch that came late does not fit the track its neighbours in time make (see :func:`_order`)."""
    idx = np.array([j for j, _, _ in rows], dtype=np.int64)
    t = np.array([t for _, t, _ in rows])
    late = np.array([top is not None for _, _, top in rows], dtype=bool)
    lat, lon = np.asarray(cols.lat_deg, float)[idx], np.asarray(cols.lon_deg, float)[idx]
    if len(t) < 3 or not np.isfinite(lat).all() or not np.isfinite(lon).all():
        return
    xy = _local_xy(lat, lon)
    dist = np.hypot(*np.diff(xy, axis=0).T)  # between consecutive epochs in time, m
    step_v = dist / np.diff(t)
    on_time = ~late[:-1] & ~late[1:]
    v_typ = float(np.median(step_v[on_time])) if on_time.any() else float(np.median(step_v))
    v_max = SPEED_FACTOR * v_typ + SPEED_SLACK_MPS
    for k in np.flatnonzero(late):
        d_prev = dist[k - 1] if k > 0 else 0.0
        d_next = dist[k] if k < len(t) - 1 else 0.0
        through = float(np.hypot(*(xy[k + 1] - xy[k - 1]))) if 0 < k < len(t) - 1 else 0.0
        detour = d_prev + d_next - through
        v = max(step_v[k - 1] if k > 0 else 0.0, step_v[k] if k < len(t) - 1 else 0.0)
        if detour > DETOUR_M and v > v_max:
            line = gga_line[int(idx[k])]
            raise BundleError(
                f"GGA time goes backwards ({tally.out_of_order} epoch(s) out of order, the first at line "
                f"{tally.first_backwards.line}) and sorted by time the fixes make no track: the epoch of this line, "
                f"{t[k]:.2f} s, lies {detour:.0f} m off the path between its neighbours in time, at {v:.1f} m/s "
                f"against {v_typ:.1f} m/s in the rest of the log: the receiver's clock jumped",
                file=file,
                line=line,
                field="time",
            )


def _check_epochs(n_rows: int, file: str, lenient: bool, tally: _Tally, skipped: dict) -> None:
    """Refuse a file without an epoch, giving what it holds instead (``skipped``: the other sentences by type)."""
    if n_rows:
        return
    if not tally.good_sentences and tally.control_bytes > 0.1 * tally.head_bytes:
        raise BundleError(
            f"the file cannot be read as NMEA text: {tally.control_bytes} of its first {tally.head_bytes} bytes are "
            "zero or control bytes (binary data, or text in another encoding such as UTF-16; NMEA is ASCII text)",
            file=file,
            field="encoding",
        )
    what = "with a fix" if lenient else "with a time"
    counts = (
        f"{tally.no_fix} without a fix, "
        + (f"{tally.not_measured} of quality 6, 7 or 8 (dead reckoning, manual input, simulator), " if lenient else "")
        + f"{tally.defective} defective, {tally.bad_checksum} with a bad checksum, "
        f"{tally.malformed} lines that are no NMEA sentence" + (f", {tally.ais} AIS lines" if tally.ais else "")
    )
    if not tally.gga_seen:
        rest = [
            f"{n} {what}"
            for n, what in (
                (tally.bad_checksum, "with a bad checksum"),
                (tally.malformed, "lines that are no NMEA sentence"),
                (tally.ais, "AIS lines"),
            )
            if n
        ]
        _refuse_without_gga(file, tally, skipped, f"; besides: {', '.join(rest)}" if rest else "")
    first = tally.first_defect
    if first is not None:
        raise BundleError(
            f"no valid GGA sentence {what} ({counts}); the first defective one: {first.message}",
            file=file,
            line=first.line,
            field=first.field,
        )
    raise BundleError(f"no valid GGA sentence {what} ({counts})", file=file)


def _refuse_without_gga(file: str, tally: _Tally, skipped: dict, rest: str) -> None:
    """A file with no GGA sentence at all: say what positions (RMC, GLL) or other sentences it holds instead."""
    if tally.positions:
        held = ", ".join(f"{n} {k}" for k, n in tally.positions.items())
        raise BundleError(
            f"no GGA sentence: the file holds positions without a height ({held} with status A, the first at line "
            f"{tally.first_position_line}); RMC and GLL state no height and no fix quality, which the GNSS fixes "
            f"need: set the receiver or logger to write GGA{rest}",
            file=file,
            line=tally.first_position_line,
            field="GGA",
        )
    if skipped:
        top = sorted(skipped.items(), key=lambda kv: -kv[1])
        held = ", ".join(f"{n} {k}" for k, n in top[:6]) + (", ..." if len(top) > 6 else "")
        raise BundleError(
            f"no GGA sentence: the file holds {sum(skipped.values())} NMEA sentences of other kinds ({held}), none "
            f"with a position{rest}",
            file=file,
            field="GGA",
        )


def _day_of(dates, line_of_row: np.ndarray, t_s: np.ndarray, tally: _Tally) -> tuple[dt.date | None, str | None]:
    """UTC day of the first row (s on the counting clock) and what states it: the first valid RMC's date, else the
    first ZDA's whose time is that of a fix (a receiver's clock that is set); (None, None) without either. When
    both state a day and they differ, the RMC's is used and the conflict noted in ``tally``."""
    rmc, zda = dates
    if not len(t_s):
        return None, None
    d_rmc = _rmc_day(rmc, line_of_row, t_s) if rmc is not None else None
    z = _zda_day(zda, t_s)
    if d_rmc is not None and z is not None and z[0] != d_rmc:
        tally.date_conflict = (
            f"the RMC of line {rmc[0]} dates the log {d_rmc}, the ZDA of line {z[1]} {z[0]}: the RMC's date is used"
        )
    if d_rmc is not None:
        return d_rmc, f"RMC line {rmc[0]}"
    if z is not None:
        return z[0], f"ZDA line {z[1]}"
    return None, None


def _rmc_day(rmc, line_of_row: np.ndarray, t_s: np.ndarray) -> dt.date:
    """UTC day of the first row from an RMC's (line, time of day s, date), its time placed on the rows' clock by the
    row written next after it."""
    after = line_of_row >= rmc[0]  # the first row written after the RMC (rows are in time order, lines need not be)
    if after.any():
        k = int(np.argmin(np.where(after, line_of_row, np.iinfo(np.int64).max)))
    else:
        k = int(np.argmax(line_of_row))
    t_rmc = rmc[1] + 86400.0 * round((t_s[k] - rmc[1]) / 86400.0)
    return rmc[2] - dt.timedelta(days=int(t_rmc // 86400.0) - int(t_s[0] // 86400.0))


def _zda_day(zda: list, t_s: np.ndarray) -> tuple[dt.date, int] | None:
    """(UTC day of the first row, line) from the first ZDA (line, time of day s, date) whose time is within 1.5 s of
    a row's (a ZDA of a receiver whose clock is not set yet may carry any date); None without one."""
    tod = np.mod(t_s, 86400.0)
    for line, z_tod, day in zda:
        diff = np.mod(tod - z_tod + 43200.0, 86400.0) - 43200.0
        k = int(np.argmin(np.abs(diff)))
        if abs(diff[k]) <= 1.5:
            t_z = t_s[k] - diff[k]  # the ZDA's time on the rows' clock
            return day - dt.timedelta(days=int(t_z // 86400.0) - int(t_s[0] // 86400.0)), line
    return None


def _warnings(file: str, lenient: bool, tally: _Tally) -> list[str]:
    """One warning per kind of sentence or epoch left out."""
    warnings = []
    if tally.bad_checksum:
        warnings.append(f"{file}: {tally.bad_checksum} sentence(s) with a bad checksum skipped")
    if tally.malformed:
        warnings.append(f"{file}: {tally.malformed} line(s) that are not NMEA sentences skipped")
    if tally.date_conflict:
        warnings.append(f"{file}: {tally.date_conflict}")
    if tally.ais:
        warnings.append(f"{file}: {tally.ais} AIS line(s) (!AIVDM/!AIVDO: other vessels' reports) ignored")
    if tally.after_binary:
        warnings.append(
            f"{file}: {tally.after_binary} sentence(s) read after other bytes on their line (binary frames)"
        )
    if lenient and tally.no_fix:
        warnings.append(f"{file}: {tally.no_fix} GGA sentence(s) without a fix (quality 0 or empty) left out")
    if tally.not_measured:
        warnings.append(
            f"{file}: {tally.not_measured} GGA sentence(s) of quality 6, 7 or 8 (dead reckoning, manual input, "
            "simulator: no measured position) left out"
        )
    if tally.defective:
        d = tally.first_defect
        warnings.append(
            f"{file}: {tally.defective} GGA sentence(s) with a good checksum but a defective field skipped; the "
            f"first: line {d.line}, field '{d.field}': {d.message}"
        )
    if tally.duplicates:
        other = tally.duplicates - tally.repeats_exact
        how = (
            f" ({tally.repeats_exact} the same fix again, {other} another fix: the first in the file kept)"
            if other
            else ""
        )
        warnings.append(f"{file}: {tally.duplicates} repeated GGA epoch(s) skipped{how}")
    if tally.out_of_order:
        b = tally.first_backwards
        warnings.append(
            f"{file}: {tally.out_of_order} GGA epoch(s) written out of order sorted into place (they fit the track); "
            f"the first: line {b.line}, {b.message}"
        )
    return warnings


def _ddmm(deg: float, width: int) -> str:
    d = int(deg)
    m = round((deg - d) * 60.0, 8)
    if m >= 60.0:
        d, m = d + 1, m - 60.0
    return f"{d:0{width}d}{m:011.8f}"


def gga_time(t_s: float) -> str:
    """UTC seconds of the day as the GGA time field ``hhmmss.sss[sss]``: rounded to the microsecond, with at
    least three decimals (milliseconds) and the trailing zeros after the third left out.

    The rounding is done on whole microseconds and carried into seconds, minutes and hours, so
    59.9999996 s is written as the next minute (``..1000.000``, never ``..0960.000``). A time that
    rounds up to 24:00:00 is written ``000000.000``: the first instant of the next day, which a
    reader counts as a midnight passed (the bundle clock's rule: a time of day dropping by more than
    half a day). ``t_s`` is taken modulo one day (the bundle clock runs past 86400 s after midnight).
    """
    us = round(float(t_s) * 1_000_000) % 86_400_000_000
    s, us = divmod(us, 1_000_000)
    hh, rem = divmod(s, 3600)
    mm, ss = divmod(rem, 60)
    frac = f"{us:06d}"
    frac = frac[:3] + frac[3:].rstrip("0")
    return f"{hh:02d}{mm:02d}{ss:02d}.{frac}"


def format_gga(
    t_s: float,
    lat_deg: float,
    lon_deg: float,
    h_msl_m: float,
    sep_m: float,
    fix: int,
    *,
    n_sat: int = 12,
    hdop: float = 0.9,
    talker: str = "GP",
) -> str:
    """One GGA sentence with checksum (no line end).

    Parameters
    ----------
    t_s : float
        UTC time (s of day; taken modulo one day), written to the microsecond by :func:`gga_time`.
    lat_deg, lon_deg : float
        WGS-84 latitude and longitude (deg); with ``fix`` 0 or a NaN latitude the position fields stay empty.
    h_msl_m : float
        Altitude above mean sea level (m): the ellipsoidal height minus ``sep_m``.
    sep_m : float
        Geoid separation (m).
    fix : int
        GGA fix quality (0 none, 1 single, 2 differential, 4 RTK fixed, 5 RTK float).
    n_sat : int
        Satellites in use.
    hdop : float
        Horizontal dilution of precision.
    talker : str
        Two-letter talker ID (``GP``, ``GN``...).

    Returns
    -------
    str
        ``$..GGA,...*hh``, without a line end.
    """
    tstr = gga_time(t_s)
    if fix > 0 and np.isfinite(lat_deg):
        lat = _ddmm(abs(lat_deg), 2)
        lon = _ddmm(abs(lon_deg), 3)
        ns, ew = ("N" if lat_deg >= 0 else "S"), ("E" if lon_deg >= 0 else "W")
        alt, sep = f"{h_msl_m:.4f}", f"{sep_m:.3f}"
    else:
        lat = lon = ns = ew = alt = sep = ""
    body = f"{talker}GGA,{tstr},{lat},{ns},{lon},{ew},{fix},{n_sat:02d},{hdop:.1f},{alt},M,{sep},M,,"
    acc = 0
    for ch in body.encode():
        acc ^= ch
    return f"${body}*{acc:02X}"
