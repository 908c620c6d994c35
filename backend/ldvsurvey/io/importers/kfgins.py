"""KF-GINS text files (i2Nav-WHU, also the awesome-gins-datasets format).

IMU file, one row per sample, whitespace separated: GPS seconds of week; angle increments
x, y, z (rad); velocity increments x, y, z (m/s); axes front-right-down.
GNSS file: GPS seconds of week; latitude, longitude (deg); ellipsoidal height (m); north,
east, down 1-σ (m). Neither file states the GPS week: the manifest's ``date`` places them.
"""

from __future__ import annotations

import numpy as np

from ldvsurvey.errors import BundleError
from ldvsurvey.io.importers.common import (
    GnssPart,
    ImuPart,
    Stamps,
    check_increasing,
    fix_from_sigma,
    read_number_table,
    text_reader,
    text_sniffer,
)
from ldvsurvey.io.importers.contract import Importer

NAME = "kf-gins"
ROLES = ("imu", "gnss")
IMU_NAMES = ["gps_sow", "dtheta_x", "dtheta_y", "dtheta_z", "dvel_x", "dvel_y", "dvel_z"]
GNSS_NAMES = ["gps_sow", "lat_deg", "lon_deg", "h_m", "sigma_n_m", "sigma_e_m", "sigma_d_m"]


@text_sniffer
def sniff(data: bytes, name: str) -> str | None:
    """``imu`` or ``gnss`` when the first data row looks like a KF-GINS row, else None."""
    for line in data[:4096].decode("ascii", "replace").splitlines():
        s = line.strip()
        if not s or s.startswith("#"):
            continue
        parts = s.replace(",", " ").split()
        try:
            vals = [float(p) for p in parts]
        except ValueError:
            return None
        if not (0 <= vals[0] < 604800.0 + 86400.0):
            return None
        if len(vals) == 7 and all(abs(v) < 1.0 for v in vals[1:]):
            return "imu"
        if len(vals) in (7, 13) and -90 <= vals[1] <= 90 and -180 <= vals[2] <= 360 and abs(vals[1]) > 1e-6:
            return "gnss"
        return None
    return None


@text_reader
def read(data: bytes, file: str, role: str, opts: dict) -> ImuPart | GnssPart:
    """A KF-GINS IMU or GNSS text file (GPS seconds of week, no week).

    Parameters
    ----------
    data : bytes
        The file's content.
    file : str
        The file's name, for messages.
    role : str
        ``imu`` or ``gnss``.
    opts : dict
        ``import.<role>`` of the partial manifest (``axes`` for the IMU, FRD when not given).

    Returns
    -------
    ImuPart or GnssPart
        Increments (rad, m/s) or fixes (deg, ellipsoidal height m; fix quality from the 1-σ, m).

    Raises
    ------
    BundleError
        A row that is no number, time tags not increasing: naming the line and field.
    """
    if role == "imu":
        a, lines = read_number_table(data, file, 7, IMU_NAMES)
        check_increasing(_unwrapped(a[:, 0]), lines, file, field="gps_sow")
        return ImuPart(
            stamps=Stamps("gps", a[:, 0], lines),
            dtheta_rad=a[:, 1:4].copy(),
            dvel_mps=a[:, 4:7].copy(),
            axes=opts.get("axes", "FRD"),
        )
    if role == "gnss":
        a, lines = read_number_table(data, file, 7, GNSS_NAMES)
        check_increasing(_unwrapped(a[:, 0]), lines, file, field="gps_sow")
        for k, (name, lo, hi) in enumerate([("lat_deg", -90, 90), ("lon_deg", -180, 360)], start=1):
            bad = np.flatnonzero((a[:, k] < lo) | (a[:, k] > hi))
            if len(bad):
                raise BundleError(
                    f"{a[bad[0], k]} is outside [{lo}, {hi}] degrees", file=file, line=int(lines[bad[0]]), field=name
                )
        sig = np.flatnonzero(a[:, 4:7] < 0)
        if len(sig):
            r, c = divmod(int(sig[0]), 3)
            raise BundleError(
                "a standard deviation cannot be negative", file=file, line=int(lines[r]), field=GNSS_NAMES[4 + c]
            )
        sigma_h = np.hypot(a[:, 4], a[:, 5]) / np.sqrt(2.0)
        fix = fix_from_sigma(sigma_h)
        lon = np.where(a[:, 2] > 180.0, a[:, 2] - 360.0, a[:, 2])
        return GnssPart(
            stamps=Stamps("gps", a[:, 0], lines),
            lat_deg=a[:, 1],
            lon_deg=lon,
            h_ell_m=a[:, 3],
            fix=fix,
            notes=[
                "kf-gins GNSS: fix quality from the stated horizontal σ (≤5 cm RTK fixed, ≤30 cm "
                "float, ≤1 m differential, else single)"
            ],
        )
    raise BundleError(f"the kf-gins format has no '{role}' file (it has: imu, gnss)", file=file)


def _unwrapped(sow: np.ndarray) -> np.ndarray:
    from ldvsurvey.io.importers.gpstime import unwrap_sow

    return unwrap_sow(sow)


IMPORTER = Importer(NAME, ROLES, read, sniff, summary="KF-GINS / awesome-gins-datasets text files")
