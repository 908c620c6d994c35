"""GPS time of the bundle clock: the leap-second table, GPS week and seconds of week.

Kept apart from the importers (``ldvsurvey.io.importers.gpstime`` re-exports it) so that the result
writers can put GPS time beside ``t_s`` without loading the importers.
"""

from __future__ import annotations

import datetime as dt

import numpy as np

GPS_EPOCH = dt.datetime(1980, 1, 6)
WEEK_S = 604800.0
DAY_S = 86400.0

#: (first UTC day with this value, GPS - UTC in s). Source: IERS Bulletin C.
LEAP_TABLE = [
    (dt.date(1981, 7, 1), 1),
    (dt.date(1982, 7, 1), 2),
    (dt.date(1983, 7, 1), 3),
    (dt.date(1985, 7, 1), 4),
    (dt.date(1988, 1, 1), 5),
    (dt.date(1990, 1, 1), 6),
    (dt.date(1991, 1, 1), 7),
    (dt.date(1992, 7, 1), 8),
    (dt.date(1993, 7, 1), 9),
    (dt.date(1994, 7, 1), 10),
    (dt.date(1996, 1, 1), 11),
    (dt.date(1997, 7, 1), 12),
    (dt.date(1999, 1, 1), 13),
    (dt.date(2006, 1, 1), 14),
    (dt.date(2009, 1, 1), 15),
    (dt.date(2012, 7, 1), 16),
    (dt.date(2015, 7, 1), 17),
    (dt.date(2017, 1, 1), 18),
]
#: the table is known complete up to this UTC day: the expiry date of the IERS leap-second file
#: (Leap_Second.dat as of November 2026, whose last step is 2017-01-01; tests/io/test_gps_time.py checks it)
LEAP_TABLE_VALID_TO = dt.date(2027, 6, 28)


def gps_minus_utc_s(day: dt.date) -> int:
    """GPS − UTC in whole seconds on the UTC day ``day`` (0 before 1981-07-01)."""
    value = 0
    for first, leap in LEAP_TABLE:
        if day >= first:
            value = leap
    return value


def bundle_to_gps(t_s: np.ndarray, day: dt.date) -> tuple[np.ndarray, np.ndarray]:
    """The bundle clock of ``day`` to GPS week and seconds of week, leap seconds per sample.

    Each sample's GPS − UTC is the table's value on its own UTC day (``day`` plus the whole days
    in ``t_s``), so a log that runs past a midnight at which a leap second was inserted gains that
    second there, and the week rolls at 00:00:00 GPS of Sunday wherever it falls. The arithmetic
    is done on whole seconds (integers) and the fraction of ``t_s`` added last, so the seconds of
    week keep every digit ``t_s`` carries; they are rounded to 1 ns to drop the float noise of the
    sum (``t_s`` itself carries about 10 ps at a day's 86400 s).

    Parameters
    ----------
    t_s : (N,) array
        s since 00:00:00 UTC of ``day`` (past 86400 after midnight; NaN stays NaN).
    day : datetime.date
        The bundle's date (UTC).

    Returns
    -------
    week : (N,) int64 array
        GPS week (absolute, from 1980-01-06; -1 where ``t_s`` is NaN).
    sow : (N,) float64 array
        GPS seconds of week, s (NaN where ``t_s`` is NaN).
    """
    t = np.asarray(t_s, dtype=np.float64)
    ok = np.isfinite(t)
    whole = np.floor(np.where(ok, t, 0.0))
    frac = np.where(ok, t, 0.0) - whole
    whole = whole.astype(np.int64)
    day_of = whole // int(DAY_S)  # whole days after ``day`` of each sample (negative before it)
    leap = np.zeros(len(t), dtype=np.int64)
    for d in np.unique(day_of):
        leap[day_of == d] = gps_minus_utc_s(day + dt.timedelta(days=int(d)))
    gps = (day - GPS_EPOCH.date()).days * int(DAY_S) + whole + leap  # whole GPS s since the epoch
    week = gps // int(WEEK_S)
    sow = np.round((gps - week * int(WEEK_S)) + frac, 9)
    over = sow >= WEEK_S  # a fraction rounded up to the next week's first second
    week, sow = week + over, np.where(over, sow - WEEK_S, sow)
    return np.where(ok, week, -1), np.where(ok, sow, np.nan)
