"""NMEA 0183 text from any receiver: GGA gives the fixes, RMC the date (via pynmea2).

Sentences with a bad checksum are skipped and counted; other sentence types are skipped.
"""

from __future__ import annotations

import datetime as dt

import numpy as np
import pynmea2

from ldvsurvey.errors import BundleError
from ldvsurvey.io.importers.common import GnssPart, Stamps, check_increasing

NAME = "nmea"
ROLES = ("gnss",)


def sniff(data: bytes, name: str) -> str | None:
    head = data[:4096].decode("ascii", "replace")
    return "gnss" if "GGA," in head and head.lstrip().startswith("$") else None


def _checksum_ok(line: str) -> bool:
    body, _, cks = line[1:].rpartition("*")
    acc = 0
    for ch in body.encode("ascii", "replace"):
        acc ^= ch
    try:
        return acc == int(cks.strip()[:2], 16)
    except ValueError:
        return False


def _num(value, file, line, name):
    try:
        x = float(value)
    except (TypeError, ValueError):
        raise BundleError(f"'{value}' is not a number", file=file, line=line, field=name) from None
    if not np.isfinite(x):
        raise BundleError(f"'{value}' is not a finite number", file=file, line=line, field=name)
    return x


def read(data: bytes, file: str, role: str, opts: dict) -> GnssPart:
    if role != "gnss":
        raise BundleError(f"the nmea format has only GNSS fixes, not '{role}'", file=file)
    rows, bad_cks, day, repeats = [], 0, None, 0
    prev_tod = None
    for lineno, raw in enumerate(data.decode("ascii", "replace").splitlines(), start=1):
        s = raw.strip()
        if not s.startswith("$") or "*" not in s:
            continue
        if not _checksum_ok(s):
            bad_cks += 1
            continue
        kind = s[1:].split(",", 1)[0][-3:]
        if kind not in ("GGA", "RMC"):
            continue
        try:
            msg = pynmea2.parse(s, check=False)
        except pynmea2.ParseError as exc:
            raise BundleError(f"{kind} sentence could not be parsed: {exc}", file=file, line=lineno) from None
        if kind == "RMC":
            if day is None and getattr(msg, "datestamp", None):
                day = msg.datestamp
                if rows and prev_tod is not None and msg.timestamp is not None:
                    tod = msg.timestamp.hour * 3600 + msg.timestamp.minute * 60 + msg.timestamp.second
                    if tod < rows[0][0] - 43200:  # RMC after midnight, first GGA before it
                        day = day - dt.timedelta(days=1)
            continue
        ts = msg.timestamp
        if ts is None or msg.data[0] == "":
            raise BundleError("GGA without time", file=file, line=lineno, field="time")
        tod = ts.hour * 3600 + ts.minute * 60 + ts.second + ts.microsecond * 1e-6
        fix = int(_num(msg.gps_qual, file, lineno, "fix_quality"))
        if fix <= 0:
            continue
        if msg.lat_dir not in ("N", "S") or msg.lon_dir not in ("E", "W"):
            raise BundleError("hemisphere must be N/S and E/W", file=file, line=lineno, field="lat_dir")
        lat = _num(msg.latitude, file, lineno, "latitude")
        lon = _num(msg.longitude, file, lineno, "longitude")
        alt = _num(msg.altitude, file, lineno, "altitude")
        sep = _num(msg.geo_sep, file, lineno, "geoid_separation") if msg.geo_sep not in ("", None) else 0.0
        nsat = _num(msg.num_sats, file, lineno, "num_sats") if msg.num_sats else np.nan
        hdop = _num(msg.horizontal_dil, file, lineno, "hdop") if msg.horizontal_dil else np.nan
        if rows and tod == rows[-1][0]:  # the same epoch again (e.g. GP and GN talkers): keep the first
            repeats += 1
            continue
        prev_tod = tod
        rows.append((tod, lat, lon, alt + sep, sep, fix, nsat, hdop, lineno))
    if not rows:
        raise BundleError(f"no GGA sentence with a fix ({bad_cks} with a bad checksum)", file=file)
    a = np.array(rows, dtype=np.float64)
    notes = [f"{file}: {bad_cks} sentence(s) with a bad checksum skipped"] if bad_cks else []
    if repeats:
        notes.append(f"{file}: {repeats} repeated GGA epoch(s) skipped")
    if day is None:
        notes.append(f"{file}: no RMC sentence with a date: the manifest's date is used")
    lines = a[:, 8].astype(np.int64)
    from ldvsurvey.io.importers.gpstime import tod_to_bundle

    check_increasing(tod_to_bundle(a[:, 0], dt.date(2000, 1, 1), dt.date(2000, 1, 1)), lines, file)
    return GnssPart(
        stamps=Stamps("utc_tod", a[:, 0], lines, day=day),
        lat_deg=a[:, 1],
        lon_deg=a[:, 2],
        h_ell_m=a[:, 3],
        sep_m=a[:, 4],
        fix=a[:, 5].astype(np.int16),
        n_sat=a[:, 6],
        hdop=a[:, 7],
        notes=notes,
    )
