"""NMEA 0183 text from any receiver: GGA gives the fixes, the first RMC (else a ZDA) the date.

Read by the product's one NMEA reader, :func:`ldvsurvey.io.nmea.parse_nmea`, in its lenient mode:
sentences with a bad checksum, GGA sentences without a fix (the pre-fix ``$GPGGA,,,,,,0,,,,M,,M,,*66``)
or of a quality that is no measured position (6 dead reckoning, 7 manual, 8 simulator), and GGA
sentences with a good checksum but a defective field are skipped and counted (the first defect named
with its line and field); sentences after a binary frame on the same line are read.
"""

from __future__ import annotations

import re

import numpy as np

from ldvsurvey.errors import BundleError
from ldvsurvey.io.importers.common import GnssPart, Stamps, text_reader, text_sniffer
from ldvsurvey.io.importers.contract import Importer
from ldvsurvey.io.nmea import parse_nmea

NAME = "nmea"
ROLES = ("gnss",)


_SENTENCE = re.compile(rb"\$([A-Z0-9]{2}[A-Z]{3},[^$*\r\n]*)\*([0-9A-Fa-f]{2})")


@text_sniffer
def sniff(data: bytes, name: str) -> str | None:
    """``gnss`` when the first 64 kB hold an NMEA sentence with a good checksum (anywhere: real logs start with
    comments, a cut sentence or binary frames). Any sentence: a log without GGA is then refused saying what it
    holds (RMC or GLL positions without a height, a boat's wind and depth...), not left unrecognised."""
    for m in _SENTENCE.finditer(data[:65536]):
        acc = 0
        for b in m.group(1):
            acc ^= b
        if acc == int(m.group(2), 16):
            return "gnss"
    return None


@text_reader
def read(data: bytes, file: str, role: str, opts: dict) -> GnssPart:
    """GGA fixes of an NMEA field recording (lenient: defective sentences skipped and counted).

    Parameters
    ----------
    data : bytes
        The file's content.
    file : str
        The file's name, for messages.
    role : str
        ``gnss`` only.
    opts : dict
        ``import.gnss`` of the partial manifest (no option of its own).

    Returns
    -------
    GnssPart
        Fixes (deg, ellipsoidal height m, geoid separation m) on the UTC time of day, with the RMC's or ZDA's date.

    Raises
    ------
    BundleError
        No GGA sentence with a fix, or a clock that jumps back: naming the line and field.
    """
    if role != "gnss":
        raise BundleError(f"the nmea format has only GNSS fixes, not '{role}'", file=file)
    g = parse_nmea(data, file=file, lenient=True)
    ok = g.fix > 0
    if not ok.any():
        raise BundleError("no GGA sentence with a fix", file=file, field="fix_quality")
    notes = list(g.warnings)
    if g.day is None:
        notes.append(f"{file}: no RMC or ZDA sentence with a date: the manifest's date is used")
    elif g.day_from and g.day_from.startswith("ZDA"):
        notes.append(f"{file}: no RMC sentence with a date: the log is dated {g.day} by its {g.day_from}")
    sep = np.where(np.isnan(g.sep_m), 0.0, g.sep_m)[ok]
    return GnssPart(
        stamps=Stamps("utc_tod", g.t_s[ok], g.line_of_row[ok], day=g.day),
        lat_deg=g.lat_deg[ok],
        lon_deg=g.lon_deg[ok],
        h_ell_m=g.h_m[ok],
        sep_m=sep,
        fix=g.fix[ok],
        n_sat=g.n_sat[ok],
        hdop=g.hdop[ok],
        notes=notes,
    )


IMPORTER = Importer(NAME, ROLES, read, sniff, summary="NMEA 0183 text: GGA fixes, the first RMC (or ZDA) for the date")
