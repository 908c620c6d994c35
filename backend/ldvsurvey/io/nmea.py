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
from bisect import bisect_left
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
        UTC day of the first row, from the first RMC sentence with a date (None without one).
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
    """``hhmmss[.ss]`` to seconds of the day (fraction kept to the microsecond)."""
    if value == "":
        raise BundleError("GGA without time", file=FILE, line=line, field="time")
    if not _TIME.fullmatch(value):
        raise BundleError(f"'{value}' is not a time hhmmss[.ss]", file=FILE, line=line, field="time")
    hh, mm, ss = int(value[0:2]), int(value[2:4]), int(value[4:6])
    if hh > 23 or mm > 59 or ss > 59:
        raise BundleError(f"'{value}' is not a time of day", file=FILE, line=line, field="time")
    frac = value[6:]
    us = int(float(frac) * 1_000_000) if frac not in ("", ".") else 0
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
    tod = (hh * 3600 + mm * 60 + ss) + np.trunc(frac * 1_000_000).astype(np.int64) * 1e-6
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


def _split_sentences(text: str) -> tuple[list[int], list[str], list[str], int, int]:
    """(line, body, given checksum) of every ``$...*hh`` sentence, and the counts of lines that are
    no sentence and of sentences found after other bytes on their line (e.g. a binary frame)."""
    malformed = after_binary = 0
    cand_line, cand_body, cand_cks = [], [], []
    for lineno, raw in enumerate(text.split("\n"), start=1):  # LF only: other control bytes are no line end
        line = raw.strip()
        if not line:
            continue
        k = line.rfind("$")  # a sentence right after a binary frame on the frame's "line", or "$$GNGGA"
        if k < 0 or "*" not in line[k:]:
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
    return cand_line, cand_body, cand_cks, malformed, after_binary


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
    tally = _Tally()
    gga_body, gga_line, skipped, rmc = _sort_sentences(*_checked_sentences(data, tally), lenient, tally)
    cols, gga_line = _gga_fields(gga_body, gga_line, file, lenient, tally)
    rows = _epochs(cols.tod_s.tolist(), gga_line, t_ref_s, file, lenient, tally) if cols is not None else []
    _check_epochs(len(rows), file, lenient, tally)
    keep = np.array([j for j, _ in rows], dtype=np.int64)
    t_s = np.array([t for _, t in rows], dtype=np.float64)
    got = GgaFields(*(np.asarray(c)[keep] for c in cols))
    line_of_row = np.array(gga_line, dtype=np.int64)[keep]
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
        day=_day_of(rmc, line_of_row, t_s),
        no_fix=tally.no_fix,
        defective=tally.defective,
    )


@dataclass
class _Tally:
    """What :func:`parse_nmea` left out on the way, for the warnings: counts and the first of each kind."""

    bad_checksum: int = 0
    malformed: int = 0  #: lines that are no NMEA sentence
    after_binary: int = 0  #: sentences read after other bytes on their line
    no_fix: int = 0
    not_measured: int = 0  #: GGA of quality 6, 7 or 8
    defective: int = 0
    duplicates: int = 0
    out_of_order: int = 0
    first_defect: BundleError | None = None
    first_backwards: BundleError | None = None


def _checked_sentences(data: bytes, tally: _Tally) -> tuple[list[int], list[str]]:
    """(line, body) of every sentence with a good checksum; the others and the lines that are none counted."""
    text = data.decode("ascii", "replace")
    cand_line, cand_body, cand_cks, tally.malformed, tally.after_binary = _split_sentences(text)
    ok = _checksums(cand_body) == np.fromiter(
        (_given_checksum(c.strip()[:2]) for c in cand_cks), dtype=np.int64, count=len(cand_cks)
    )
    tally.bad_checksum = int(len(ok) - np.count_nonzero(ok))
    good = np.flatnonzero(ok).tolist()
    return [cand_line[i] for i in good], [cand_body[i] for i in good]


def _sort_sentences(lines: list[int], bodies: list[str], lenient: bool, tally: _Tally):
    """The GGA sentences with an epoch (bodies, lines), the other sentences counted by type, and (line, time of
    day s, date) of the first RMC with a date (or None); GGA without a fix or not measured counted."""
    skipped: dict[str, int] = {}
    gga_body, gga_line = [], []
    rmc = None
    for lineno, body in zip(lines, bodies):
        head = body[: body.find(",")] if "," in body else body
        stype = head[-3:]
        if stype != "GGA" or body.startswith("P"):
            if stype == "RMC" and rmc is None and not body.startswith("P"):
                got = _rmc_date(body)
                if got is not None:
                    rmc = (lineno, *got)
            skipped[stype] = skipped.get(stype, 0) + 1
            continue
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
    return gga_body, gga_line, skipped, rmc


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
    """(index, time s on the counting clock) of each epoch kept: times of day (s) counted on past midnight from the
    day nearest ``t_ref_s``; a repeated epoch dropped, one going backwards refused (lenient: dropped, counted)."""
    rows = []
    k_day = None
    prev_t = None
    for j, lineno in enumerate(gga_line):
        if k_day is None:
            ref = t_ref_s if t_ref_s is not None else tod[j]
            k_day = round((ref - tod[j]) / 86400.0)
        t = tod[j] + 86400.0 * k_day
        if prev_t is not None and t < prev_t - 43200.0:  # passed midnight
            k_day += 1
            t += 86400.0
        if prev_t is not None and t <= prev_t:
            if t == prev_t:  # the same epoch again (e.g. GP and GN talkers): keep the first
                tally.duplicates += 1
                continue
            backwards = BundleError(
                f"GGA time goes backwards: {t:.2f} s after {prev_t:.2f} s", file=file, line=lineno, field="time"
            )
            if not lenient:
                raise backwards
            tally.out_of_order += 1  # a stray epoch is dropped; a clock that jumps back is refused (_check_epochs)
            tally.first_backwards = tally.first_backwards or backwards
            continue
        prev_t = t
        rows.append((j, t))
    return rows


def _check_epochs(n_rows: int, file: str, lenient: bool, tally: _Tally) -> None:
    """Refuse a clock that jumped back (more than a stray epoch in a hundred out of order) or no epoch at all."""
    if tally.out_of_order > max(1, n_rows // 100):
        first = tally.first_backwards
        raise BundleError(
            f"{first.message} ({tally.out_of_order} GGA epochs out of order: the receiver's clock jumped; "
            "only a stray one in a hundred is left out)",
            file=file,
            line=first.line,
            field="time",
        )
    if n_rows:
        return
    what = "with a fix" if lenient else "with a time"
    counts = (
        f"{tally.no_fix} without a fix, {tally.defective} defective, {tally.bad_checksum} with a bad checksum, "
        f"{tally.malformed} lines that are no NMEA sentence"
    )
    first = tally.first_defect
    if first is not None:
        raise BundleError(
            f"no valid GGA sentence {what} ({counts}); the first defective one: {first.message}",
            file=file,
            line=first.line,
            field=first.field,
        )
    raise BundleError(f"no valid GGA sentence {what} ({counts})", file=file)


def _day_of(rmc, line_of_row: np.ndarray, t_s: np.ndarray) -> dt.date | None:
    """UTC day of the first row (s on the counting clock) from the first RMC's date, its time placed on the rows'
    clock by the row nearest to it in the file; None without an RMC."""
    if rmc is None:
        return None
    k = min(bisect_left(line_of_row.tolist(), rmc[0]), len(line_of_row) - 1)
    t_rmc = rmc[1] + 86400.0 * round((t_s[k] - rmc[1]) / 86400.0)
    return rmc[2] - dt.timedelta(days=int(t_rmc // 86400.0) - int(t_s[0] // 86400.0))


def _warnings(file: str, lenient: bool, tally: _Tally) -> list[str]:
    """One warning per kind of sentence or epoch left out."""
    warnings = []
    if tally.bad_checksum:
        warnings.append(f"{file}: {tally.bad_checksum} sentence(s) with a bad checksum skipped")
    if tally.malformed:
        warnings.append(f"{file}: {tally.malformed} line(s) that are not NMEA sentences skipped")
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
        warnings.append(f"{file}: {tally.duplicates} repeated GGA epoch(s) skipped")
    if tally.out_of_order:
        b = tally.first_backwards
        warnings.append(
            f"{file}: {tally.out_of_order} GGA epoch(s) out of order left out; the first: line {b.line}, {b.message}"
        )
    return warnings


def _ddmm(deg: float, width: int) -> str:
    d = int(deg)
    m = round((deg - d) * 60.0, 8)
    if m >= 60.0:
        d, m = d + 1, m - 60.0
    return f"{d:0{width}d}{m:011.8f}"


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
        UTC time (s of day; taken modulo one day).
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
    # rounded to the field's 10 ms first, so that 59.996 s carries into the minute (and 23:59:59.996
    # into 00:00:00.00 of the next day, which the reader counts as a wrap)
    cs = int(round((t_s % 86400.0) * 100.0)) % 8640000
    hh, rem = divmod(cs, 360000)
    mm, rem = divmod(rem, 6000)
    tstr = f"{hh:02d}{mm:02d}{rem // 100:02d}.{rem % 100:02d}"
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
