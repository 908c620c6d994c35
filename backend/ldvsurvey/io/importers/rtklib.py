"""RTKLIB solution files (``.pos``, written by rtkpost/rnx2rtkp/rtknavi and the demo5 builds).

The header states the time system (``GPST``, ``UTC`` or ``JST`` above the time column), the
position form (``latitude(deg)``, ``latitude(d'")`` or ``x-ecef(m)``) and, in the line
``% (lat/lon/height=WGS84/ellipsoidal,Q=1:fix,...``, the datum and the height. Times are either
``yyyy/mm/dd hh:mm:ss.sss`` or ``week seconds`` (always GPST). Quality ``Q``: 1 fix → GGA 4,
2 float → 5, 3 SBAS and 4 DGPS → 2, 5 single → 1, 6 PPP → 5; other values (0, 7 dead reckoning)
are left out and counted.
"""

from __future__ import annotations

import datetime as dt
import math
import re
from dataclasses import dataclass

import numpy as np

from ldvsurvey.errors import BundleError
from ldvsurvey.io.importers.common import GnssPart, Stamps, ecef_to_lla, text_reader, text_sniffer
from ldvsurvey.io.importers.contract import Importer, Option
from ldvsurvey.io.importers.gpstime import GPS_EPOCH, WEEK_S

NAME = "rtklib"
ROLES = ("gnss",)
FIX_OF_Q = {1: 4, 2: 5, 3: 2, 4: 2, 5: 1, 6: 5}
_DATE = re.compile(r"(\d{2,4})/(\d{1,2})/(\d{1,2})")
_TIME = re.compile(r"(\d{1,2}):(\d{1,2}):(\d{1,2}(?:\.\d*)?)")


@text_sniffer
def sniff(data: bytes, name: str) -> str | None:
    """``gnss`` when the first 4 kB hold an RTKLIB header line (``% GPST latitude(deg) ...``), else None."""
    head = data[:4096].decode("ascii", "replace")
    return "gnss" if re.search(r"^%\s+(GPST|UTC|JST)\s+(latitude|x-ecef)", head, re.M) else None


def _num(tok: str, file: str, line: int, name: str) -> float:
    try:
        v = float(tok)
    except ValueError:
        raise BundleError(f"'{tok}' is not a number", file=file, line=line, field=name) from None
    if not math.isfinite(v):
        raise BundleError(f"'{tok}' is not a finite number", file=file, line=line, field=name)
    return v


@text_reader
def read(data: bytes, file: str, role: str, opts: dict) -> GnssPart:
    """GNSS fixes of an RTKLIB ``.pos`` solution file (see the module docstring).

    Parameters
    ----------
    data : bytes
        The file's content.
    file : str
        The file's name, for messages.
    role : str
        ``gnss`` only.
    opts : dict
        ``import.gnss`` of the partial manifest: ``height`` ('ellipsoidal' for a file without a header saying so).

    Returns
    -------
    GnssPart
        Fixes (deg, ellipsoidal height m) on GPS week and seconds, or UNIX seconds for UTC/JST times.

    Raises
    ------
    BundleError
        A defective line naming its line and field; a datum other than WGS84 or heights not ellipsoidal.
    """
    if role != "gnss":
        raise BundleError(f"the rtklib format has only GNSS fixes, not '{role}'", file=file)
    text = data.decode("utf-8", "replace")
    hdr = _Header()
    rows, where, left_out = [], [], {}
    for lineno, raw in enumerate(text.split("\n"), start=1):
        s = raw.strip()
        if not s:
            continue
        if s.startswith("%"):
            hdr.read_line(s, file, lineno)
            continue
        if hdr.times is None:
            raise BundleError(
                "no header line naming the time system and the columns (% GPST latitude(deg) ...): write the "
                "solution with its header (rtkpost: Output Header ON)",
                file=file,
                line=lineno,
                field="header",
            )
        kind, t, rest = _time_of(s.replace(",", " ").split(), hdr.times, file, lineno)
        n_pos = 7 if hdr.form == "dms" else 3
        if len(rest) < n_pos + 2:
            raise BundleError(f"expected {n_pos} position fields, Q and ns", file=file, line=lineno, field="Q")
        q = int(_num(rest[n_pos], file, lineno, "Q"))
        if q not in FIX_OF_Q:
            left_out[q] = left_out.get(q, 0) + 1
            continue
        lat, lon, h = _position(rest, hdr.form, file, lineno)
        ns = _num(rest[n_pos + 1], file, lineno, "ns")
        rows.append((kind, t[0], t[1], lat, lon if lon <= 180.0 else lon - 360.0, h, FIX_OF_Q[q], ns))
        where.append(lineno)
    if not rows:
        raise BundleError(f"no solution with a usable quality Q (left out: {left_out or 'none'})", file=file)
    _check_heights(hdr, opts, file)
    kinds = {r[0] for r in rows}
    if len(kinds) > 1:
        raise BundleError("time columns of several kinds", file=file, field="time")
    kind = kinds.pop()
    a = np.array([r[3:] for r in rows], dtype=np.float64)
    notes = [f"{file}: RTKLIB solution, times in {kind}, ellipsoidal heights"]
    if left_out:
        notes.append(f"{file}: solutions of quality Q {sorted(left_out)} ({sum(left_out.values())}) left out")
    return GnssPart(
        stamps=_stamps(kind, rows, np.array(where, dtype=np.int64)),
        lat_deg=a[:, 0],
        lon_deg=a[:, 1],
        h_ell_m=a[:, 2],
        fix=a[:, 3].astype(np.int16),
        n_sat=a[:, 4],
        notes=notes,
    )


@dataclass
class _Header:
    """What the ``%`` header lines state: the time system, the position form, the height and the datum."""

    times: str | None = None  #: GPST, UTC or JST
    form: str | None = None  #: latitude(deg), dms or ecef
    height: str | None = None  #: ellipsoidal or geodetic
    datum: str | None = None

    def read_line(self, s: str, file: str, lineno: int) -> None:
        """Take what one header line states (a position form this reader cannot read is an error)."""
        m = re.search(r"lat/lon/height=(\w+)/(\w+)", s)
        if m:
            self.datum, self.height = m.group(1), m.group(2)
        if "x/y/z-ecef=" in s:
            self.datum, self.height = "WGS84", "ellipsoidal"
        m = re.match(r"%\s+(GPST|UTC|JST)\s+(\S+)", s)
        if m:
            self.times = m.group(1)
            col = m.group(2)
            self.form = "dms" if col.startswith("latitude(d'") else "ecef" if "ecef" in col else col
            if self.form not in ("latitude(deg)", "dms", "ecef"):
                raise BundleError(
                    f"position form '{col}' is not read (rtkpost: output latitude/longitude/height or x/y/z-ecef)",
                    file=file,
                    line=lineno,
                    field="header",
                )


def _time_of(tok: list[str], times: str, file: str, lineno: int) -> tuple[str, tuple, list[str]]:
    """(time system, (whole s since the GPS epoch, s), the fields after the time) of a solution line's fields:
    ``yyyy/mm/dd hh:mm:ss.sss`` in the header's time system, or ``week seconds`` (GPST)."""
    if _DATE.fullmatch(tok[0]) if tok else False:
        if len(tok) < 2 or not _TIME.fullmatch(tok[1]):
            raise BundleError("date without a time hh:mm:ss", file=file, line=lineno, field="time")
        y, mo, d = (int(v) for v in _DATE.fullmatch(tok[0]).groups())
        y += 0 if y >= 100 else 2000 if y < 80 else 1900
        hh, mm, ss = _TIME.fullmatch(tok[1]).groups()
        try:
            day = dt.date(y, mo, d)
        except ValueError:
            raise BundleError(f"'{tok[0]}' is not a date", file=file, line=lineno, field="time") from None
        if int(hh) > 23 or int(mm) > 59 or float(ss) >= 61.0:
            raise BundleError(f"'{tok[1]}' is not a time of day", file=file, line=lineno, field="time")
        days = (day - GPS_EPOCH.date()).days
        return times, (days * 86400 + int(hh) * 3600 + int(mm) * 60, float(ss)), tok[2:]
    if len(tok) < 2:
        raise BundleError("expected a time (date and time, or week and seconds)", file=file, line=lineno)
    week = _num(tok[0], file, lineno, "week")
    sow = _num(tok[1], file, lineno, "seconds of week")
    if week != int(week) or not 0 <= week <= 9999 or not 0 <= sow < WEEK_S:
        raise BundleError(f"'{tok[0]} {tok[1]}' is not a GPS week and seconds", file=file, line=lineno)
    return "GPST", (int(week) * WEEK_S, sow), tok[2:]


def _position(rest: list[str], form: str, file: str, lineno: int) -> tuple[float, float, float]:
    """Latitude, longitude (deg) and ellipsoidal height (m) from a line's position fields in the header's form."""
    if form == "dms":
        v = [_num(x, file, lineno, "position") for x in rest[:7]]
        lat = math.copysign(abs(v[0]) + v[1] / 60.0 + v[2] / 3600.0, -1.0 if rest[0].startswith("-") else 1.0)
        lon = math.copysign(abs(v[3]) + v[4] / 60.0 + v[5] / 3600.0, -1.0 if rest[3].startswith("-") else 1.0)
        h = v[6]
    elif form == "ecef":
        lat, lon, h = ecef_to_lla(*(_num(x, file, lineno, f"{a}-ecef") for x, a in zip(rest[:3], "xyz")))
    else:
        lat = _num(rest[0], file, lineno, "latitude")
        lon = _num(rest[1], file, lineno, "longitude")
        h = _num(rest[2], file, lineno, "height")
    if not (-90.0 <= lat <= 90.0 and -180.0 <= lon <= 360.0):
        raise BundleError(f"{lat}, {lon} is not a position in degrees", file=file, line=lineno, field="latitude")
    return lat, lon, h


def _check_heights(hdr: _Header, opts: dict, file: str) -> None:
    """Refuse a datum other than WGS84 and heights not ellipsoidal (a file without a header line on heights: the
    user's ``height`` option)."""
    if hdr.datum not in (None, "WGS84"):
        raise BundleError(f"datum {hdr.datum}: only WGS84 solutions are read", file=file, field="header")
    height = hdr.height if hdr.height is not None else opts.get("height")
    if height != "ellipsoidal":
        raise BundleError(
            (
                f"heights are {height} (above RTKLIB's geoid model): write ellipsoidal heights (rtkpost: Height = "
                "Ellipsoidal)"
            )
            if height
            else "the header does not say whether heights are ellipsoidal (% (lat/lon/height=WGS84/ellipsoidal...)): "
            'write the header, or state it as "import": {"gnss": {"height": "ellipsoidal"}}',
            file=file,
            field="height",
        )


def _stamps(kind: str, rows: list, lines: np.ndarray) -> Stamps:
    """The rows' times: GPS week and seconds (GPST), or UNIX seconds (UTC, JST) with the whole seconds kept apart."""
    whole = np.array([r[1] for r in rows], dtype=np.int64)
    frac = np.array([r[2] for r in rows], dtype=np.float64)
    if kind == "GPST":
        week = whole // int(WEEK_S)
        return Stamps("gps", (whole - week * int(WEEK_S)).astype(np.float64) + frac, lines, week=week)
    unix0 = int((dt.datetime(1980, 1, 6) - dt.datetime(1970, 1, 1)).total_seconds())
    whole = whole + unix0 - (9 * 3600 if kind == "JST" else 0)
    off = int(whole[0])
    return Stamps("unix", (whole - off).astype(np.float64) + frac, lines, offset_s=off)


IMPORTER = Importer(
    NAME,
    ROLES,
    read,
    sniff,
    options=(Option("height", (str,), "'ellipsoidal' when a solution file has no header saying so", ("gnss",)),),
    summary="RTKLIB .pos solutions (lat/lon/height or x/y/z-ecef; GPST, UTC or JST)",
)
