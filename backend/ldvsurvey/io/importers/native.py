"""Files already in the bundle's own format (``imu.csv``, ``ldv.csv``, ``gnss.nmea``)."""

from __future__ import annotations

import numpy as np

from ldvsurvey.errors import BundleError
from ldvsurvey.io.csvtable import read_numeric_csv
from ldvsurvey.io.drivelog import IMU_COLUMNS
from ldvsurvey.io.importers.common import GnssPart, ImuPart, LdvPart, Stamps, text_reader, text_sniffer
from ldvsurvey.io.importers.contract import Importer

NAME = "native"
ROLES = ("imu", "ldv", "gnss")


@text_sniffer
def sniff(data: bytes, name: str) -> str | None:
    """``imu`` or ``ldv`` when the header is the bundle's ``imu.csv`` or ``ldv.csv`` header, else None."""
    head = data[:2048].decode("utf-8", "replace")
    header = next((ln for ln in head.splitlines() if ln.strip() and not ln.startswith("#")), "")
    cols = [c.strip() for c in header.split(",")]
    if cols[:1] == ["t"] and "dtheta_x" in cols:
        return "imu"
    if cols[:1] == ["t"] and ("v_fwd" in cols or "fd_hz" in cols):
        return "ldv"
    return None


@text_reader
def read(data: bytes, file: str, role: str, opts: dict):
    """A file already in the bundle's format (``imu.csv``, ``ldv.csv`` or ``gnss.nmea``), on the bundle clock.

    Parameters
    ----------
    data : bytes
        The file's content.
    file : str
        The file's name, for messages.
    role : str
        ``imu``, ``ldv`` or ``gnss``.
    opts : dict
        ``import.<role>`` of the partial manifest (``axes`` for the IMU, RFU when not given).

    Returns
    -------
    ImuPart or LdvPart or GnssPart
        The columns as the bundle holds them (s, rad, m/s, deg, m); ``gnss.nmea`` is kept unchanged.

    Raises
    ------
    BundleError
        As the bundle reader: naming the line and field.
    """
    if role == "imu":
        tab = read_numeric_csv(data, file, IMU_COLUMNS, optional=["turntable_deg"])
        c = tab.columns
        return ImuPart(
            stamps=Stamps("bundle", c["t"], tab.line_of_row),
            dtheta_rad=np.column_stack([c["dtheta_x"], c["dtheta_y"], c["dtheta_z"]]),
            dvel_mps=np.column_stack([c["dvel_x"], c["dvel_y"], c["dvel_z"]]),
            axes=opts.get("axes", "RFU"),
            turntable_deg=c.get("turntable_deg"),
            notes=list(tab.warnings),
        )
    if role == "ldv":
        tab = read_numeric_csv(data, file, ["t"], optional=["v_up", "quality"], alternatives=[("v_fwd", "fd_hz")])
        cols = {k: v for k, v in tab.columns.items() if k != "t"}
        return LdvPart(
            stamps=Stamps("bundle", tab.columns["t"], tab.line_of_row), columns=cols, notes=list(tab.warnings)
        )
    if role == "gnss":
        from ldvsurvey.io.nmea import parse_nmea

        try:
            g = parse_nmea(data)
        except BundleError as exc:
            raise BundleError(exc.message, file=file, line=exc.line, field=exc.field) from None
        ok = g.fix > 0
        return GnssPart(
            stamps=Stamps("bundle", g.t_s[ok], g.line_of_row[ok]),
            lat_deg=g.lat_deg[ok],
            lon_deg=g.lon_deg[ok],
            h_ell_m=g.h_m[ok],
            fix=g.fix[ok],
            raw_nmea=data,
        )
    raise BundleError(f"the native format has no '{role}' file", file=file)


IMPORTER = Importer(NAME, ROLES, read, sniff, summary="imu.csv, ldv.csv or gnss.nmea already in the bundle's format")
