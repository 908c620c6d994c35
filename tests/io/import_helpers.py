"""Writers of foreign formats from the simulator's output, built from the formats' published
definitions (not from the importers under test). Shared by the import tests."""

from __future__ import annotations

import datetime as dt
from decimal import Decimal

import numpy as np

LEAP_2023 = 18  # GPS - UTC since 2017-01-01 (IERS Bulletin C)
GPS_EPOCH = dt.date(1980, 1, 6)


def sow_of_midnight(day: dt.date, leap: int = LEAP_2023) -> tuple[int, int]:
    """GPS week and seconds of week of 00:00 UTC of ``day`` (whole seconds)."""
    days = (day - GPS_EPOCH).days
    s = days * 86400 + leap
    return s // 604800, s % 604800


def sow_text(t_s: np.ndarray, day: dt.date) -> list[str]:
    """Bundle times (UTC s of ``day``) as exact decimal GPS seconds of week."""
    _, s0 = sow_of_midnight(day)
    return [str(Decimal(repr(float(t))) + s0) for t in t_s]


def rfu_to_frd(v: np.ndarray) -> np.ndarray:
    """Right-forward-up components to forward-right-down."""
    return np.column_stack([v[:, 1], v[:, 0], -v[:, 2]])


def kfgins_imu(t_s, dtheta_rfu, dvel_rfu, day) -> bytes:
    """KF-GINS IMU text: SOW, dθ x y z (rad), dv x y z (m/s), front-right-down axes."""
    th, dv = rfu_to_frd(dtheta_rfu), rfu_to_frd(dvel_rfu)
    rows = [
        f"{s} {a[0]!r} {a[1]!r} {a[2]!r} {b[0]!r} {b[1]!r} {b[2]!r}"
        for s, a, b in zip(sow_text(t_s, day), th.tolist(), dv.tolist())
    ]
    return ("\n".join(rows) + "\n").encode()


SIGMA_OF_FIX = {4: 0.02, 5: 0.2, 2: 0.6, 1: 3.0}


def kfgins_gnss(t_s, lat, lon, h, fix, day) -> bytes:
    """KF-GINS GNSS text: SOW, lat, lon (deg), ellipsoidal h (m), σ N E D (m); epochs without a fix left out."""
    rows = []
    for s, la, lo, hh, f in zip(sow_text(t_s, day), lat, lon, h, fix):
        if f <= 0:
            continue
        sg = SIGMA_OF_FIX[int(f)]
        rows.append(f"{s} {float(la)!r} {float(lo)!r} {float(hh)!r} {sg} {sg} {2 * sg}")
    return ("\n".join(rows) + "\n").encode()
