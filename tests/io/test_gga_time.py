"""The GGA time field the bundle writer produces: rounded to the microsecond and carried.

Truth: the exact value of the float ``t_s`` (``fractions.Fraction``), pynmeagps's decode of the
sentence (an independent NMEA parser) and the bundle's own reader (``parse_nmea``).
"""

from fractions import Fraction

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from ldvsurvey.io.nmea import format_gga, gga_time, parse_nmea
from ldvsurvey.io.writers import nmea_text

pynmeagps = pytest.importorskip("pynmeagps")

DAY_US = 86_400_000_000


def _pynmeagps_us(sentence: str) -> int:
    """Microseconds of the day of a GGA sentence as pynmeagps reads it (checksum checked)."""
    m = pynmeagps.NMEAReader.parse(sentence.encode() + b"\r\n", validate=pynmeagps.VALCKSUM)
    t = m.time
    return ((t.hour * 60 + t.minute) * 60 + t.second) * 1_000_000 + t.microsecond


def _exact_us(t_s: float) -> Fraction:
    """The float's exact value in microseconds of its day."""
    return (Fraction(t_s) * 1_000_000) % DAY_US


def _sentence(t_s: float) -> str:
    return format_gga(t_s, 48.74, 9.31, 263.7, 47.6, 4)


@pytest.mark.parametrize(
    ("t_s", "field"),
    [
        (19 * 3600 + 34 * 60 + 59.996, "193459.996"),  # the fix the old writer turned into 193460.00
        (19 * 3600 + 34 * 60 + 59.999, "193459.999"),
        (19 * 3600 + 34 * 60 + 59.9995, "193459.9995"),
        (19 * 3600 + 34 * 60 + 59.9999996, "193500.000"),  # rounds up: carried into the minute
        (19 * 3600 + 59 * 60 + 59.9999996, "200000.000"),  # ... into the hour
        (86399.9999996, "000000.000"),  # ... into the next day
        (86400.0 + 7.25, "000007.250"),  # the bundle clock past midnight: modulo one day
    ],
)
def test_gga_time_carries_and_keeps_microseconds(t_s, field):
    s = _sentence(t_s)
    assert s.split(",")[1] == field
    got = _pynmeagps_us(s)
    assert abs(got - _exact_us(t_s)) <= Fraction(1, 2) or abs(got + DAY_US - _exact_us(t_s)) <= Fraction(1, 2)


def test_fixes_at_59_999_s_and_across_midnight_are_read_back_by_the_bundle_reader():
    """The issue's drive: fixes at 4 Hz whose times fall a few µs-ms short of a minute, then a midnight.
    The old writer wrote 193460.00 and the reader refused its own file."""
    t = np.array([70499.746, 70499.996, 70499.9995, 70499.999, 70500.249, 86399.75, 86399.9999996, 86400.25])
    t.sort()
    n = len(t)
    data = nmea_text(t, np.full(n, 48.74), np.full(n, 9.31), np.full(n, 311.3), np.full(n, 4), extra_sentences=False)
    g = parse_nmea(data, t_ref_s=70000.0)
    # written to the µs and read to the nearest µs: equal up to the float's own rounding
    np.testing.assert_allclose(g.t_s, np.round(t, 6), rtol=0, atol=1e-9)
    assert g.t_s[-2] == 86400.0  # 23:59:59.9999996 is the first instant of the next day, after the midnight


@settings(max_examples=400, deadline=None)
@given(st.floats(min_value=0.0, max_value=2 * 86400.0, allow_nan=False, allow_infinity=False))
def test_random_times_round_trip_through_pynmeagps_and_our_reader(t_s):
    s = _sentence(t_s)
    exact = _exact_us(t_s)
    got = _pynmeagps_us(s)
    err = min(abs(got - exact), abs(got + DAY_US - exact))  # 23:59:59.9999996 -> 00:00:00
    assert err <= Fraction(1, 2)  # the nearest microsecond
    frac = s.split(",")[1].split(".")[1]
    assert 3 <= len(frac) <= 6  # at least milliseconds
    ours = parse_nmea((s + "\r\n").encode()).t_s[0]
    # our reader rounds the fraction to the nearest µs (it once truncated: .000249 read as 248 µs)
    assert abs(ours * 1e6 - got) <= 1e-3


def test_gga_time_of_negative_bundle_time_is_the_previous_days_clock():
    assert gga_time(-0.5) == "235959.500"
