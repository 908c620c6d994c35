"""The GGA writer's time field on real fix times: a fix 4 ms before a full minute (the u-blox RTK
solution of tests/fixtures/real/ins, 19:35:17.999 GPST = 19:34:59.999 UTC) must carry into the next
minute, and one just before midnight into 00:00:00.00 of the next day, which the bundle's own GGA
reader counts as a day wrap. Judged by calendar arithmetic, not by the writer."""

from __future__ import annotations

import datetime as dt

import pytest

from ldvsurvey.io.nmea import format_gga


def _field_seconds(sentence: str) -> float:
    """Seconds of day from the GGA time field hhmmss.ss."""
    f = sentence.split(",")[1]
    return int(f[:2]) * 3600 + int(f[2:4]) * 60 + float(f[4:])


@pytest.mark.parametrize(
    "utc",
    [
        dt.datetime(2025, 7, 8, 19, 34, 59, 999000),  # the real drive's fix
        dt.datetime(2025, 7, 8, 19, 34, 59, 999500),
        dt.datetime(2025, 7, 8, 23, 59, 59, 999500),  # midnight
        dt.datetime(2025, 7, 8, 12, 0, 0, 4000),
    ],
)
def test_gga_time_carries_into_the_minute(utc):
    t_s = (utc - dt.datetime(2025, 7, 8)).total_seconds()
    s = format_gga(t_s, 40.0966268, -105.1474483, 1601.474, 0.0, 4)
    field = s.split(",")[1]
    hh, mm, ss = int(field[:2]), int(field[2:4]), float(field[4:])
    assert hh < 24 and mm < 60 and ss < 60.0, field
    # the written time is the true one to the field's 10 ms, across the minute/day boundary
    expected = t_s % 86400.0
    got = _field_seconds(s)
    assert min(abs(got - expected), abs(got + 86400.0 - expected)) <= 0.005 + 1e-9
