"""GPS week and seconds of week of the bundle clock (``gpstime.bundle_to_gps``) against independent truth.

- Real receivers that state both scales for one epoch: u-blox NAV-PVT (UTC date and time) beside
  NAV-TIMEGPS (week, time of week) of the same epoch, decoded by pyubx2; a NovAtel SPAN's TIME log (UTC in
  its body, GPS week and milliseconds in its header), decoded by novatel_edie.
- The IERS leap-second file (``Leap_Second.dat`` shipped with astropy) for GPS − UTC on every day, and
  Python's calendar arithmetic (``datetime``) from the GPS epoch 1980-01-06 for the week and seconds.
"""

import datetime as dt
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from ldvsurvey.io.importers import gpstime

REAL = Path(__file__).resolve().parents[1] / "fixtures" / "real"
GPS_EPOCH = dt.datetime(1980, 1, 6)
TAI_MINUS_GPS_S = 19  # GPS time was TAI − 19 s at its epoch and has no leap seconds since


def _iers():
    """(first UTC day, GPS − UTC s) of the IERS leap-second file, and the day it expires."""
    iers = pytest.importorskip("astropy.utils.iers")
    data = pytest.importorskip("astropy_iers_data")
    t = iers.LeapSeconds.from_iers_leap_seconds(data.IERS_LEAP_SECOND_FILE)
    steps = [(dt.date(int(r["year"]), int(r["month"]), 1), int(r["tai_utc"]) - TAI_MINUS_GPS_S) for r in t]
    return steps, t.expires.to_datetime().date()


def _calendar_gps(day: dt.date, t_us: int, leap_s: int) -> tuple[int, int]:
    """GPS (week, µs of week) by datetime arithmetic: UTC instant + leap seconds − GPS epoch."""
    utc = dt.datetime.combine(day, dt.time()) + dt.timedelta(microseconds=t_us)
    us = (utc - GPS_EPOCH) // dt.timedelta(microseconds=1) + leap_s * 1_000_000
    return divmod(us, 604_800_000_000)


def test_leap_table_is_the_iers_file_on_every_day_it_claims():
    steps, expires = _iers()
    assert gpstime.LEAP_TABLE_VALID_TO <= expires  # the table claims no more than IERS knows
    day, end = dt.date(1980, 1, 6), gpstime.LEAP_TABLE_VALID_TO
    while day <= end:
        want = max([v for first, v in steps if first <= day] or [0])
        assert gpstime.gps_minus_utc_s(day) == want, day
        day += dt.timedelta(days=1)


def _ubx_pairs(name: str) -> list[tuple]:
    """(UTC date, s of day, GPS week, GPS s of week, leapS) of every NAV-PVT whose epoch has a NAV-TIMEGPS."""
    pyubx2 = pytest.importorskip("pyubx2")
    pvt, tgps = {}, {}
    with open(REAL / name, "rb") as fh:
        for _raw, m in pyubx2.UBXReader(fh, protfilter=2, quitonerror=0):
            if m is None:
                continue
            if m.identity == "NAV-PVT" and m.validDate and m.validTime and m.fullyResolved:
                pvt[m.iTOW] = m
            elif m.identity == "NAV-TIMEGPS" and m.towValid and m.weekValid and m.leapSValid:
                tgps[m.iTOW] = m
    out = []
    for itow in sorted(set(pvt) & set(tgps)):
        p, g = pvt[itow], tgps[itow]
        tod = p.hour * 3600 + p.min * 60 + p.second + p.nano * 1e-9
        out.append((dt.date(p.year, p.month, p.day), tod, g.week, g.iTOW * 1e-3 + g.fTOW * 1e-9, g.leapS))
    return out


@pytest.mark.parametrize("name", ["ublox-neo-m8l.log", "ublox-neo-m8u.log", "pygpsdata-MIXED.log"])
def test_u_blox_utc_and_gps_of_the_same_epoch(name):
    pairs = _ubx_pairs(name)
    assert len(pairs) >= 3
    for day, tod, week, sow, leap in pairs:
        assert gpstime.gps_minus_utc_s(day) == leap
        w, s = gpstime.bundle_to_gps(np.array([tod]), day)
        assert w[0] == week
        # both to the ns, each rounded by the receiver: NAV-PVT nano and NAV-TIMEGPS fTOW differ by up to 2 ns
        assert s[0] == pytest.approx(sow, abs=3e-9)


def test_novatel_time_log_utc_against_its_header_gps_time():
    ne = pytest.importorskip("novatel_edie")
    from novatel_edie import oem

    p = oem.Parser()
    p.write((REAL / "novatel" / "swri-span-corrimudata.gps").read_bytes())
    logs = [m.to_dict() for m in p if type(m).__name__.split("_")[0] == "TIME"]
    assert ne and len(logs) == 2
    for m in logs:
        day = dt.date(m["utc_year"], m["utc_month"], m["utc_day"])
        tod = m["utc_hour"] * 3600 + m["utc_minute"] * 60 + m["utc_millisecond"] * 1e-3
        assert gpstime.gps_minus_utc_s(day) == -m["utc_offset"]  # the receiver's UTC offset: −16 s in 2014
        w, s = gpstime.bundle_to_gps(np.array([tod]), day)
        assert (w[0], s[0]) == (m["header"]["week"], m["header"]["milliseconds"] * 1e-3)


def test_week_rolls_at_sunday_0h_gps_which_is_saturday_before_midnight_utc():
    """2024-01-06 is a Saturday; GPS week 2296 begins 2024-01-07 00:00:00 GPS = 2024-01-06 23:59:42 UTC."""
    t = np.array([86381.999999, 86382.0, 86382.000001, 86399.9995, 86400.0, 86400.5])
    w, s = gpstime.bundle_to_gps(t, dt.date(2024, 1, 6))
    np.testing.assert_array_equal(w, [2295, 2296, 2296, 2296, 2296, 2296])
    np.testing.assert_allclose(s, [604799.999999, 0.0, 1e-6, 17.9995, 18.0, 18.5], rtol=0, atol=1e-9)


def test_a_leap_second_inserted_at_the_midnight_a_log_runs_through():
    """2016-12-31 23:59:60 UTC was inserted (GPS − UTC 17 -> 18 s); the bundle clock has no 23:59:60, so
    GPS time jumps 2 s where t_s advances 1 s. 2017-01-01 00:00:00 UTC = GPS week 1930, 18 s (published:
    GPS week 1930 began on Sunday 2017-01-01 00:00:00 GPS)."""
    w, s = gpstime.bundle_to_gps(np.array([86382.0, 86383.0, 86399.0, 86400.0, 86401.0]), dt.date(2016, 12, 31))
    np.testing.assert_array_equal(w, [1929, 1930, 1930, 1930, 1930])  # Saturday 23:59:43 UTC: the new week
    np.testing.assert_allclose(s, [604799.0, 0.0, 16.0, 18.0, 19.0], rtol=0, atol=1e-9)


@settings(max_examples=300, deadline=None)
@given(
    st.dates(min_value=dt.date(1981, 1, 1), max_value=dt.date(2027, 6, 1)),
    st.integers(min_value=-3_600_000_000, max_value=3 * 86_400_000_000),
)
def test_any_day_and_time_against_calendar_arithmetic(day, t_us):
    """Times on whole µs from an hour before the date's midnight to three days after it."""
    steps, _ = _iers()
    utc_day = dt.date.fromordinal(day.toordinal() + t_us // 86_400_000_000)
    leap = max([v for first, v in steps if first <= utc_day] or [0])
    week, us = _calendar_gps(day, t_us, leap)
    w, s = gpstime.bundle_to_gps(np.array([t_us / 1e6]), day)
    assert w[0] == week
    assert abs(s[0] * 1e6 - us) <= 1e-3  # to the ns


def test_nan_times_stay_missing():
    w, s = gpstime.bundle_to_gps(np.array([np.nan, 10.0]), dt.date(2023, 3, 20))
    assert w[0] == -1 and np.isnan(s[0])
    assert (w[1], round(s[1] * 1e6)) == _calendar_gps(dt.date(2023, 3, 20), 10_000_000, 18)
