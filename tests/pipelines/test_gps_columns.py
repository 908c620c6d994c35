"""GPS week and seconds of week beside ``t_s`` in the result tables (``gps_week``, ``gps_sow_s``).

Truth: Python's calendar arithmetic from the GPS epoch (1980-01-06) with GPS − UTC = 18 s (IERS: unchanged
since 2017-01-01); the week boundary of Saturday 2024-01-06 falls at 23:59:42 UTC.
"""

import datetime as dt
import io
import json

import numpy as np
import pandas as pd
import pytest

from ldvsurvey.io.drivelog import parse_files
from ldvsurvey.io.writers import geo_export
from ldvsurvey.pipelines.base import add_gps_time, result_files, run_pipeline
from ldvsurvey.pipelines.registry import get as get_pipeline
from ldvsurvey.sim import catalog
from ldvsurvey.sim.scenario import bundle_files, simulate

GPS_EPOCH = dt.datetime(1980, 1, 6)
WEEK_US = 604_800 * 1_000_000


def _truth(day: dt.date, t_s: np.ndarray, leap_s: int = 18) -> tuple[np.ndarray, np.ndarray]:
    """(week, s of week) by datetime arithmetic, t_s taken to the µs."""
    weeks, sows = [], []
    for t in t_s.tolist():
        utc = dt.datetime.combine(day, dt.time()) + dt.timedelta(microseconds=round(t * 1e6))
        us = (utc - GPS_EPOCH) // dt.timedelta(microseconds=1) + leap_s * 1_000_000
        w, r = divmod(us, WEEK_US)
        weeks.append(w)
        sows.append(r / 1e6)
    return np.array(weeks), np.array(sows)


@pytest.fixture(scope="module")
def saturday_night():
    """A 7-min INS/GNSS drive on Saturday 2024-01-06 that starts 23:57 UTC: it passes the GPS week
    boundary (23:59:42 UTC) and midnight."""
    sc = catalog.drive(minutes=7.0, with_ldv=False, date="2024-01-06", t0_s=86400.0 - 180.0)
    files = bundle_files(simulate(sc, seed=5))
    return parse_files(files)


def test_trajectory_csv_has_gps_week_and_seconds_of_week_across_the_week_boundary(saturday_night):
    res = run_pipeline(get_pipeline("navigate"), [saturday_night], {"output_rate_hz": 1.0})
    data = result_files(res)["trajectory.csv"]
    df = pd.read_csv(io.BytesIO(data))
    assert list(df.columns[:3]) == ["t_s", "gps_week", "gps_sow_s"]
    assert df["gps_week"].dtype.kind == "i"
    t = df["t_s"].to_numpy()
    assert t[0] < 86382.0 and t[-1] > 86400.0  # the rows cover the week boundary and midnight
    week, sow = _truth(dt.date(2024, 1, 6), t)
    np.testing.assert_array_equal(df["gps_week"], week)
    assert set(week) == {2295, 2296}
    np.testing.assert_allclose(df["gps_sow_s"], sow, rtol=0, atol=1e-6)
    # the track export carries the same two instants in GPS time
    name, gj = geo_export("geojson", "trajectory", data, res.summary)
    props = json.loads(gj)["features"][0]["properties"]
    assert (props["gps_week_start"], props["gps_sow_start_s"]) == (int(week[0]), pytest.approx(sow[0], abs=1e-6))
    assert (props["gps_week_end"], props["gps_sow_end_s"]) == (int(week[-1]), pytest.approx(sow[-1], abs=1e-6))
    assert not any("gps_" in w for w in res.summary["warnings"])


def test_logs_of_different_dates_take_each_rows_date_from_the_log_column():
    days = [dt.date(2016, 12, 31), dt.date(2017, 1, 1)]  # GPS − UTC 17 s, then 18 s
    t = np.array([3600.0, 3600.0, 7200.5])
    tables = {
        "with_log": {"t_s": t, "log": np.array([1, 2, 2]), "x": np.zeros(3)},
        "without": {"t_s": t, "x": np.zeros(3)},
        "no_time": {"x": np.zeros(3)},
    }
    warnings = add_gps_time(tables, days)
    got = tables["with_log"]
    assert list(got) == ["t_s", "gps_week", "gps_sow_s", "log", "x"]
    for i, (d, leap) in enumerate([(days[0], 17), (days[1], 18), (days[1], 18)]):
        w, s = _truth(d, t[i : i + 1], leap)
        assert (got["gps_week"][i], got["gps_sow_s"][i]) == (w[0], pytest.approx(s[0], abs=1e-9))
    assert "gps_week" not in tables["without"] and "gps_week" not in tables["no_time"]
    assert warnings == ["without.csv: no gps_week/gps_sow_s (the date of its rows is not known)"]


def test_missing_times_leave_empty_cells():
    tables = {"t": {"t_s": np.array([np.nan, 0.5])}}
    add_gps_time(tables, [dt.date(2024, 1, 7)])  # a Sunday: 00:00:00.5 UTC is 18.5 s into week 2296
    text = result_files(type("R", (), {"summary": {}, "tables": tables, "files": {}})())["t.csv"].decode()
    assert text.splitlines() == ["t_s,gps_week,gps_sow_s", ",,", "0.5,2296,18.5"]


def test_a_date_past_the_leap_tables_known_end_is_warned():
    from ldvsurvey.io.leapseconds import LEAP_TABLE_VALID_TO

    late = LEAP_TABLE_VALID_TO + dt.timedelta(days=1)
    tables = {"t": {"t_s": np.array([1.0])}}
    warnings = add_gps_time(tables, [late])
    assert "gps_week" in tables["t"]
    assert len(warnings) == 1 and "leap-second table" in warnings[0] and str(late) in warnings[0]
    assert add_gps_time({"t": {"t_s": np.array([1.0])}}, [LEAP_TABLE_VALID_TO]) == []
