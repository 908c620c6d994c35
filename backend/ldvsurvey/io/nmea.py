"""``gnss.nmea``: NMEA 0183 text; GGA sentences give time, position and fix quality."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import pynmea2

from ldvsurvey.errors import BundleError

FILE = "gnss.nmea"


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

    def __len__(self) -> int:
        return len(self.t_s)


def _checksum_ok(body: str, given: str) -> bool:
    acc = 0
    for ch in body.encode("ascii", "replace"):
        acc ^= ch
    try:
        return acc == int(given, 16)
    except ValueError:
        return False


def _num(value, line: int, name: str, *, allow_empty: bool = True) -> float:
    if value in (None, ""):
        if allow_empty:
            return math.nan
        raise BundleError("empty field", file=FILE, line=line, field=name)
    try:
        x = float(value)
    except (TypeError, ValueError):
        raise BundleError(f"'{value}' is not a number", file=FILE, line=line, field=name) from None
    if not math.isfinite(x):
        raise BundleError(f"'{value}' is not a finite number", file=FILE, line=line, field=name)
    return x


def parse_nmea(data: bytes, t_ref_s: float | None = None) -> GnssData:
    """Parse NMEA text. Bad checksums are skipped and counted; non-GGA sentences skipped.

    Parameters
    ----------
    data : bytes
        File content (CRLF or LF).
    t_ref_s : float, optional
        A time near the log's start (s of day, e.g. the first IMU time) used to place
        the first GGA on the right day; later epochs keep counting past midnight.

    Raises
    ------
    BundleError
        Empty file, no valid GGA, a GGA field that is not a number, a time going backwards.
    """
    if not data.strip():
        raise BundleError("file is empty", file=FILE, line=1)
    text = data.decode("ascii", "replace")
    rows = []
    bad_checksum = malformed = duplicates = 0
    skipped: dict[str, int] = {}
    k_day = None
    prev_t = None
    for lineno, raw in enumerate(text.splitlines(), start=1):
        line = raw.strip()
        if not line:
            continue
        if not line.startswith("$") or "*" not in line:
            malformed += 1
            continue
        body, _, cks = line[1:].rpartition("*")
        if not _checksum_ok(body, cks.strip()[:2]):
            bad_checksum += 1
            continue
        stype = body.split(",", 1)[0][-3:]
        if stype != "GGA" or body.startswith("P"):
            skipped[stype] = skipped.get(stype, 0) + 1
            continue
        try:
            msg = pynmea2.parse(line, check=False)
        except pynmea2.ParseError as exc:
            raise BundleError(f"GGA sentence could not be parsed: {exc}", file=FILE, line=lineno) from None
        ts = msg.timestamp
        if ts is None or msg.data[0] == "":
            raise BundleError("GGA without time", file=FILE, line=lineno, field="time")
        tod = ts.hour * 3600 + ts.minute * 60 + ts.second + ts.microsecond * 1e-6
        fix = int(_num(msg.gps_qual, lineno, "fix_quality", allow_empty=False))
        if fix > 0:
            try:
                lat = float(msg.latitude)
                lon = float(msg.longitude)
            except (TypeError, ValueError):
                raise BundleError("latitude/longitude are not numbers", file=FILE, line=lineno,
                                  field="latitude") from None
            if not msg.lat or not msg.lon:
                raise BundleError("fix quality > 0 but no position", file=FILE, line=lineno,
                                  field="latitude")
            if msg.lat_dir not in ("N", "S") or msg.lon_dir not in ("E", "W"):
                raise BundleError("hemisphere must be N/S and E/W", file=FILE, line=lineno,
                                  field="lat_dir")
            alt = _num(msg.altitude, lineno, "altitude", allow_empty=False)
            sep = _num(msg.geo_sep, lineno, "geoid_separation")
            if math.isnan(sep):
                sep = 0.0
            h = alt + sep
        else:
            lat = lon = h = math.nan
        if k_day is None:
            ref = t_ref_s if t_ref_s is not None else tod
            k_day = round((ref - tod) / 86400.0)
        t = tod + 86400.0 * k_day
        if prev_t is not None and t < prev_t - 43200.0:  # passed midnight
            k_day += 1
            t += 86400.0
        if prev_t is not None and t <= prev_t:
            if t == prev_t:  # the same epoch again (e.g. GP and GN talkers): keep the first
                duplicates += 1
                continue
            raise BundleError(f"GGA time goes backwards: {t:.2f} s after {prev_t:.2f} s",
                              file=FILE, line=lineno, field="time")
        prev_t = t
        rows.append((t, lat, lon, h, fix, _num(msg.num_sats, lineno, "num_sats"),
                     _num(msg.horizontal_dil, lineno, "hdop"), lineno))
    if not rows:
        raise BundleError(f"no valid GGA sentence ({bad_checksum} with bad checksum, "
                          f"{malformed} malformed lines)", file=FILE)
    a = np.array(rows, dtype=np.float64)
    warnings = []
    if bad_checksum:
        warnings.append(f"{FILE}: {bad_checksum} sentence(s) with a bad checksum skipped")
    if malformed:
        warnings.append(f"{FILE}: {malformed} line(s) that are not NMEA sentences skipped")
    if duplicates:
        warnings.append(f"{FILE}: {duplicates} repeated GGA epoch(s) skipped")
    return GnssData(t_s=a[:, 0], lat_deg=a[:, 1], lon_deg=a[:, 2], h_m=a[:, 3],
                    fix=a[:, 4].astype(np.int16), n_sat=a[:, 5], hdop=a[:, 6],
                    line_of_row=a[:, 7].astype(np.int64), bad_checksum=bad_checksum,
                    malformed_lines=malformed, duplicate_epochs=duplicates,
                    skipped_sentences=skipped, warnings=warnings)


def _ddmm(deg: float, width: int) -> str:
    d = int(deg)
    m = round((deg - d) * 60.0, 8)
    if m >= 60.0:
        d, m = d + 1, m - 60.0
    return f"{d:0{width}d}{m:011.8f}"


def format_gga(t_s: float, lat_deg: float, lon_deg: float, h_msl_m: float, sep_m: float,
               fix: int, n_sat: int = 12, hdop: float = 0.9, talker: str = "GP") -> str:
    """One GGA sentence with checksum (no line end). Time is taken modulo one day."""
    tod = t_s % 86400.0
    hh, rem = divmod(tod, 3600.0)
    mm, ss = divmod(rem, 60.0)
    tstr = f"{int(hh):02d}{int(mm):02d}{ss:05.2f}"
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
