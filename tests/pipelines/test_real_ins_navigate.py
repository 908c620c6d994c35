"""``navigate`` (GNSS aiding) on a real consumer-MEMS car drive, against its own RTK fixes (issue 34).

The first 180 s of rtklibexplorer/GNSS_IMU ``drive_0708`` (tests/fixtures/real/README.md): 33 s
standing with the engine idling (gyro bias ~630 °/h, 42 times the Earth rate: heading cannot be
found by gyrocompassing), then residential streets at 5-15 m/s; u-blox RTK fixes at 4 Hz, σ 1 cm.
The truth is independent of the solution wherever it is judged: the GNSS course (central
differences of the fixes over ±1 s, speed > 3 m/s) for the heading, and fixes WITHHELD from the
filter for the drift in an outage. Three minutes of data: each navigation takes about a second.

The bounds, from the sensor's grade and what the fixes make observable:

- heading − GNSS course RMS after the first 60 s ≤ 4°: the course over 1 s at > 3 m/s is good to
  0.2° and a car's sideslip on streets is below 1° (the smoothed solution meets the course to
  0.9° RMS here, so mounting and sideslip together are small); a start aligned on the course
  (≈ 2° σ) and the turns that follow keep a sound filter's heading within 2° σ; 4° is 2σ;
- drift at the end of a 20-s outage, RMS over three, ≤ 25 m: after 60 s of aiding, a velocity
  error ≤ 0.1 m/s (2 m), tilt ≤ 0.2° with a residual accelerometer bias ≤ 3 mg (½·0.064·20² ≈
  13 m) and heading ≤ 2° over the ~250 m driven (9 m);
- the smoothed solution inside a 20-s gap ≤ 6 m: a two-sided solution's error peaks mid-gap at
  about the forward drift after half the gap, a quarter of the end drift for errors growing as t².

KF-GINS, run by benchmarks/bench_kfgins_real.py on the same excerpt with the set's noise figures,
meets the heading bound with the standstill's noise (1.2°), not quite with the datasheet's (3.4°),
and its drift at the end of these three 20-s outages is 12.6 m RMS with the standstill's noise
(15.2, 6.7, 14.1 m), 43.9 m with the datasheet's (22.4, 12.4, 71.5 m): the bounds ask for a filter
that knows the vibration it rides on. Before issue 34 the heading came from the gyros at rest (−10°
off, 9° RMS), the outage drift was ~50 m, and without ``initial.static_s`` the drive was refused.
"""

from __future__ import annotations

import numpy as np

from ldvsurvey.nav.attitude import c_from_q, euler_from_c_bn
from ldvsurvey.pipelines.navigate import NavigateParams, run_navigation
from tests.io.test_real_ins_import import gnss_enu, import_excerpt

HEADING_RMS_DEG = 4.0
OUTAGE_END_RMS_M = 25.0
SMOOTHED_GAP_M = 6.0
OUTAGES_S = ((90.0, 110.0), (120.0, 140.0), (150.0, 170.0))  # after the first IMU sample


def navigate(log, smooth=False, with_inputs=False):
    inp, _setup, sol = run_navigation(
        log, NavigateParams(aiding="gnss", smooth=smooth), lambda *a, **k: None, aiding="gnss", smooth=smooth
    )
    return (inp, sol) if with_inputs else sol


def heading_vs_course_rms(sol, log, after_s=60.0) -> float:
    """RMS (deg) of the solution's heading minus the GNSS course, speed > 3 m/s, ``after_s`` on."""
    t = log.gnss.t_s
    e = gnss_enu(log)
    i0 = np.searchsorted(t, t - 1.0)
    i1 = np.clip(np.searchsorted(t, t + 1.0, side="right") - 1, 0, len(t) - 1)
    d = e[i1] - e[i0]
    speed = np.hypot(d[:, 0], d[:, 1]) / np.maximum(t[i1] - t[i0], 1e-9)
    course = np.degrees(np.arctan2(d[:, 0], d[:, 1]))
    k = (speed > 3.0) & (t > log.imu.t_s[0] + after_s) & (t < sol.t_s[-1] - 1.0) & (t[i1] - t[i0] > 1.5)
    heading = np.degrees(np.unwrap(euler_from_c_bn(c_from_q(sol.q_sn))[2]))
    diff = (np.interp(t[k], sol.t_s, heading) - course[k] + 180.0) % 360.0 - 180.0
    return float(np.sqrt(np.mean(diff**2)))


def horizontal_errors(sol, truth_log, t_from, t_to) -> np.ndarray:
    """Horizontal distance (m) between the solution's antenna and the fixes of ``truth_log`` in [t_from, t_to)."""
    g = truth_log.gnss
    k = (g.t_s >= t_from) & (g.t_s < t_to)
    lever_n = np.einsum("kij,j->ki", c_from_q(sol.q_sn), np.asarray(truth_log.manifest.gnss.lever_arm_m, float))
    lat = np.interp(g.t_s[k], sol.t_s, sol.pos[:, 0])
    lon = np.interp(g.t_s[k], sol.t_s, sol.pos[:, 1])
    de = (lon - np.radians(g.lon_deg[k])) * 6378137.0 * np.cos(lat) + np.interp(g.t_s[k], sol.t_s, lever_n[:, 0])
    dn = (lat - np.radians(g.lat_deg[k])) * 6378137.0 + np.interp(g.t_s[k], sol.t_s, lever_n[:, 1])
    return np.hypot(de, dn)


def test_navigates_without_a_hand_given_static_period(tmp_path):
    """The GNSS shows the car standing for 33 s: no ``initial.static_s`` needed, heading within the bound."""
    log = import_excerpt(tmp_path)
    inp, sol = navigate(log, with_inputs=True)
    assert heading_vs_course_rms(sol, log) <= HEADING_RMS_DEG
    # what the run states: heading from the course (a 630 °/h gyro cannot find north), its σ, and the
    # standstill it found, judged by the fixes' own speed (below 0.1 m/s until about 33 s in)
    al = inp.alignment
    assert al.method == "gnss_course"
    assert al.gyrocompass_sigma_rad is None or np.degrees(al.gyrocompass_sigma_rad) > 10.0
    assert 0.2 <= np.degrees(al.heading_sigma_rad) <= 4.0
    e, t = gnss_enu(log), log.gnss.t_s
    speed = np.hypot(*np.gradient(e[:, :2], t, axis=0).T)
    moving_from = t[np.flatnonzero(speed > 0.1)[0]]
    assert al.standstill_s[0] <= log.imu.t_s[0] + 1.0
    assert moving_from - 6.0 <= al.standstill_s[1] <= moving_from + 0.5


def test_forward_heading_against_the_gnss_course(tmp_path):
    log = import_excerpt(tmp_path, static_s=30.0)
    sol = navigate(log)
    assert heading_vs_course_rms(sol, log) <= HEADING_RMS_DEG


def test_forward_drift_in_20_s_outages_against_the_withheld_fixes(tmp_path):
    (tmp_path / "all").mkdir()
    truth = import_excerpt(tmp_path / "all", static_s=30.0)
    t0 = truth.imu.t_s[0]
    ends = []
    for a, b in OUTAGES_S:
        d = tmp_path / f"out{a:.0f}"
        d.mkdir()
        sol = navigate(import_excerpt(d, outages=[(a, b)], static_s=30.0))
        ends.append(horizontal_errors(sol, truth, t0 + a, t0 + b)[-1])
    assert np.sqrt(np.mean(np.square(ends))) <= OUTAGE_END_RMS_M


def test_smoothed_bridges_a_20_s_gap(tmp_path):
    (tmp_path / "all").mkdir()
    (tmp_path / "out").mkdir()
    truth = import_excerpt(tmp_path / "all", static_s=30.0)
    a, b = OUTAGES_S[1]
    sol = navigate(import_excerpt(tmp_path / "out", outages=[(a, b)], static_s=30.0), smooth=True)
    t0 = truth.imu.t_s[0]
    assert horizontal_errors(sol, truth, t0 + a, t0 + b).max() <= SMOOTHED_GAP_M
    # where every fix aids it, the smoothed solution lies on them to a few times their σ (1 cm)
    assert np.sqrt(np.mean(horizontal_errors(sol, truth, t0 + 60.0, t0 + a) ** 2)) <= 0.3


def test_the_run_states_its_alignment_in_summary_and_headlines(tmp_path):
    """``ldv-survey run navigate`` on the real drive: summary.json and the job page's headline figures
    say how the heading was found and how well, and the warnings say the gyros could not find north."""
    import json

    from ldvsurvey.api.headlines import headlines
    from ldvsurvey.cli import main

    import_excerpt(tmp_path)
    assert main(["run", "navigate", str(tmp_path / "bundle.zip"), "--out", str(tmp_path / "out")]) == 0
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert summary["alignment_method"] == "gnss_course"
    assert 0.2 <= summary["alignment_heading_sigma_deg"] <= 4.0
    assert any("north" in w for w in summary["warnings"]), summary["warnings"]
    h = {x["key"]: x for x in headlines("navigate", summary)}
    assert h["alignment_method"]["text"] == "gnss_course"
    assert h["alignment_heading_sigma_deg"]["unit"] == "°"
