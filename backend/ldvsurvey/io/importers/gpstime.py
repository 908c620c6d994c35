"""Time scales of field recordings and the bundle clock.

The bundle clock ``t_s`` is seconds since 00:00:00 UTC of ``manifest.date`` and keeps
counting past 86400 after midnight. Field recordings stamp samples in GPS time (week and
seconds of week, or seconds of week alone), in UTC seconds of the day, or in UNIX time.
GPS time runs ahead of UTC by the leap seconds inserted since 1980-01-06.
"""

from __future__ import annotations

import datetime as dt

import numpy as np

from ldvsurvey.io.leapseconds import (  # noqa: F401 (re-exported: the importers' names)
    DAY_S,
    GPS_EPOCH,
    LEAP_TABLE,
    LEAP_TABLE_VALID_TO,
    WEEK_S,
    bundle_to_gps,
    gps_minus_utc_s,
)


def gps_week_of(day: dt.date, leap_s: int) -> tuple[int, float]:
    """GPS week and seconds of week of 00:00:00 UTC of ``day``."""
    gps = (dt.datetime.combine(day, dt.time()) - GPS_EPOCH).total_seconds() + leap_s
    week = int(gps // WEEK_S)
    return week, gps - week * WEEK_S


def utc_day_of_gps(week: int, sow: float) -> dt.date:
    """UTC calendar day of a GPS time (leap seconds from the table)."""
    approx = GPS_EPOCH + dt.timedelta(seconds=week * WEEK_S + sow)
    leap = gps_minus_utc_s(approx.date())
    return (approx - dt.timedelta(seconds=leap)).date()


def resolve_week(week: int, near_week: int | None) -> int:
    """A 10-bit (mod 1024) week number made absolute near ``near_week`` (the manifest date's week)."""
    if week >= 1024 or near_week is None:
        return week
    k = round((near_week - week) / 1024.0)
    return week + 1024 * max(k, 0)


def unwrap_sow(sow: np.ndarray) -> np.ndarray:
    """Seconds of week made continuous across week roll-overs (a drop of more than half a week)."""
    sow = np.asarray(sow, dtype=np.float64)
    if len(sow) < 2:
        return sow.copy()
    jumps = np.concatenate(([0.0], np.cumsum(np.where(np.diff(sow) < -WEEK_S / 2, WEEK_S, 0.0))))
    return sow + jumps


def gps_to_bundle(sow: np.ndarray, day: dt.date, leap_s: int, week: np.ndarray | int | None = None) -> np.ndarray:
    """GPS seconds of week (with the week per sample, or none) to the bundle clock of ``day``.

    Without a week the samples are placed in the GPS week whose day lies nearest to ``day``
    (the first sample within half a week of that day's noon), and later week roll-overs
    (seconds of week dropping back to 0) keep counting.

    Parameters
    ----------
    sow : (N,) array
        GPS seconds of week, s.
    day : datetime.date
        The bundle's date (UTC).
    leap_s : int
        GPS − UTC, s.
    week : (N,) array or int, optional
        Absolute GPS week of each sample.

    Returns
    -------
    (N,) array
        s since 00:00 UTC of ``day``.
    """
    week0, sow_midnight = gps_week_of(day, leap_s)
    sow = np.asarray(sow, dtype=np.float64)
    if week is None:
        rel = unwrap_sow(sow) - sow_midnight
        if len(rel):
            k = np.round((DAY_S / 2 - rel[0]) / WEEK_S)
            rel = rel + k * WEEK_S
        return rel
    w = np.asarray(week, dtype=np.int64) - week0
    return w * WEEK_S + (sow - sow_midnight)


def unix_to_bundle(unix_s: np.ndarray, day: dt.date, offset_s: int = 0) -> np.ndarray:
    """UNIX time (UTC, no leap seconds counted; ``offset_s`` + ``unix_s``) to the bundle clock of ``day``."""
    midnight = int((dt.datetime.combine(day, dt.time()) - dt.datetime(1970, 1, 1)).total_seconds())
    return np.asarray(unix_s, dtype=np.float64) + float(offset_s - midnight)


def tod_to_bundle(tod_s: np.ndarray, first_day: dt.date, day: dt.date) -> np.ndarray:
    """UTC seconds of day (wrapping to 0 at midnight) to the bundle clock of ``day``.

    ``first_day`` is the UTC day of the first sample; each later drop of more than half a day
    is a midnight passed.
    """
    tod = np.asarray(tod_s, dtype=np.float64)
    if len(tod) > 1:
        tod = tod + np.concatenate(([0.0], np.cumsum(np.where(np.diff(tod) < -DAY_S / 2, DAY_S, 0.0))))
    return tod + (first_day - day).days * DAY_S
