"""IMU rows missing, merged or out of order, and time-tag jitter (io.imutime via parse_imu).

The truth is the same simulated drive without the defect: bridged data must navigate like it.
"""

import numpy as np
import pytest

from ldvsurvey.errors import BundleError
from ldvsurvey.io.drivelog import parse_files
from ldvsurvey.io.writers import imu_csv
from ldvsurvey.nav.attitude import q_from_c
from ldvsurvey.nav.mech import mechanize
from ldvsurvey.pipelines.stages.aids import nav_inputs
from ldvsurvey.sim import catalog
from ldvsurvey.sim.scenario import bundle_files, simulate


@pytest.fixture(scope="module")
def drive():
    """A 4-minute drive (1 min static, then 15 m/s with turns and grades), 100 Hz IMU."""
    sim = simulate(catalog.drive(minutes=4.0, static_s=60.0), seed=3)
    return sim, bundle_files(sim)


def _with_imu(files, t, dth, dv):
    f = dict(files)
    f["imu.csv"] = imu_csv(t, dth, dv)
    return f


def _nav(sim, imu):
    """Free-inertial position (rad, rad, m) from the true initial state."""
    k0 = 0
    q0 = q_from_c(sim.imu.c_bn[k0])
    _, _, pos = mechanize(
        imu.t_s,
        imu.dtheta_rad,
        imu.dvel_mps,
        q0,
        sim.imu.v_n[k0],
        [sim.imu.lat_rad[k0], sim.imu.lon_rad[k0], sim.imu.h_m[k0]],
    )
    return pos


def _metres(p, q):
    return np.hypot((p[:, 0] - q[:, 0]) * 6.37e6, (p[:, 1] - q[:, 1]) * 6.37e6 * np.cos(p[:, 0])), p[:, 2] - q[:, 2]


def test_lost_rows_are_bridged_and_navigate_like_the_intact_log(drive):
    sim, files = drive
    t, dth, dv = sim.imu.t_s, sim.dtheta_rad, sim.dvel_mps
    # rows lost while driving (the row after each gap holds only its own interval)
    drop = np.r_[9000:9003, 15000:15001, 20000:20004]
    keep = np.setdiff1d(np.arange(len(t)), drop)
    log = parse_files(_with_imu(files, t[keep], dth[keep], dv[keep]))
    ref = parse_files(files)
    w = [x for x in log.warnings if "gap" in x]
    assert len(w) == 1 and "3 gap(s)" in w[0] and "8 missing row(s)" in w[0]
    assert f"t={t[8999]:.3f} s" in w[0] and f"t={t[19999]:.3f} s" in w[0]
    assert log.imu.bridged_rows == 8 and len(log.imu.t_s) == len(t)
    np.testing.assert_allclose(log.imu.t_s, t, atol=1e-9)
    p_ref, p_gap = _nav(sim, ref.imu), _nav(sim, log.imu)
    dh_naive = _nav(sim, type(ref.imu)(t[keep], dth[keep], dv[keep]))[-1, 2] - p_ref[-1, 2]
    hor, up = _metres(p_gap, p_ref)
    # 8 lost rows unbridged leave 8·g·Δt ≈ 0.8 m/s unaccounted: tens of metres within 3 min
    assert abs(dh_naive) > 10.0
    # interpolating the specific force over 40 ms while driving errs by well under 1e-3 m/s
    assert hor.max() < 0.05 and np.abs(up).max() < 0.05


def test_a_row_that_accumulated_the_gap_is_split_evenly(drive):
    sim, files = drive
    t, dth, dv = sim.imu.t_s.copy(), sim.dtheta_rad.copy(), sim.dvel_mps.copy()
    i = 12000  # rows i-2, i-1 merged into row i: its increments cover (t[i-3], t[i]]
    dth[i] += dth[i - 2] + dth[i - 1]
    dv[i] += dv[i - 2] + dv[i - 1]
    keep = np.setdiff1d(np.arange(len(t)), [i - 2, i - 1])
    log = parse_files(_with_imu(files, t[keep], dth[keep], dv[keep]))
    assert log.imu.bridged_rows == 2 and any("split evenly" in x for x in log.warnings)
    # the integrated increments are kept exactly
    np.testing.assert_allclose(log.imu.dvel_mps.sum(axis=0), sim.dvel_mps.sum(axis=0), rtol=0, atol=1e-12)
    np.testing.assert_allclose(log.imu.dvel_mps[i - 2 : i + 1], np.repeat(dv[i : i + 1] / 3, 3, axis=0), atol=1e-15)


def test_long_gap_is_refused_naming_file_line_and_time(drive):
    sim, files = drive
    t, dth, dv = sim.imu.t_s, sim.dtheta_rad, sim.dvel_mps
    keep = np.setdiff1d(np.arange(len(t)), np.arange(10000, 10050))  # 0.5 s
    f = _with_imu(files, t[keep], dth[keep], dv[keep])
    log = parse_files(f)  # the bundle stays readable (its quality report shows the gap) ...
    assert any("too long to bridge" in w for w in log.warnings)
    with pytest.raises(BundleError) as ei:  # ... but nothing navigates across it
        nav_inputs(log)
    e = ei.value
    lines = f["imu.csv"].decode().splitlines()
    assert e.file == "imu.csv" and e.field == "t"
    assert lines[e.line - 1].startswith(repr(float(t[10050]))[:10])  # the row after the gap
    assert f"{t[9999]:.3f}" in e.message and "gap" in e.message


def test_time_tag_jitter_is_not_a_gap(drive):
    sim, files = drive
    rng = np.random.default_rng(1)
    t = sim.imu.t_s + rng.uniform(-2e-3, 2e-3, len(sim.imu.t_s))  # ±2 ms at 100 Hz
    t[[3000, 7000, 11000]] += 3.5e-3  # and a few tags off by 5.5 ms: one interval 1.6 Δt long
    log = parse_files(_with_imu(files, t, sim.dtheta_rad, sim.dvel_mps))
    assert log.imu.bridged_rows == 0 and not any("gap" in x for x in log.warnings)
    np.testing.assert_array_equal(log.imu.dvel_mps, sim.dvel_mps)


def test_rows_out_of_order_are_put_back(drive):
    sim, files = drive
    t, dth, dv = sim.imu.t_s.copy(), sim.dtheta_rad.copy(), sim.dvel_mps.copy()
    perm = np.arange(len(t))
    perm[[5000, 5001, 5002]] = [5002, 5000, 5001]
    log = parse_files(_with_imu(files, t[perm], dth[perm], dv[perm]))
    assert any("out of time order" in x for x in log.warnings)
    np.testing.assert_array_equal(log.imu.t_s, t)
    np.testing.assert_array_equal(log.imu.dvel_mps, dv)
    # a jump far back in time is refused
    perm = np.arange(len(t))
    perm[8000], perm[3000] = perm[3000], perm[8000]
    with pytest.raises(BundleError) as ei:
        parse_files(_with_imu(files, t[perm], dth[perm], dv[perm]))
    assert ei.value.file == "imu.csv" and "backwards" in ei.value.message


def test_lost_rows_under_jittered_tags_keep_the_clock_s_intervals(drive):
    """Issue 29: lost rows in a log whose tags jitter. The IMU samples on its own clock; the logger's
    tags jitter about it (the increments are those of the true intervals). A bridged row spans one
    interval of that clock: scaling it by the tagged gap length put the two edge tags' jitter into
    the gap's velocity (g·δt ≈ 3 mm/s for δt = 0.3 ms, several mGal through a 200-s FIR), which no
    later step can telescope away. The bridged increments must not depend on the tags' jitter."""
    sim, files = drive
    t, dth, dv = sim.imu.t_s, sim.dtheta_rad, sim.dvel_mps
    drop = np.r_[9000:9003, 15000:15001, 20000:20004, 21000:21005]
    keep = np.setdiff1d(np.arange(len(t)), drop)
    jit = np.clip(np.random.default_rng(7).normal(0.0, 3e-4, len(t)), -4e-3, 4e-3)
    jit[drop - 1] = 3.5e-4 * np.sign(np.arange(len(drop)) % 2 - 0.5)  # the gaps' edge tags well off
    plain = parse_files(_with_imu(files, t[keep], dth[keep], dv[keep]))
    jittered = parse_files(_with_imu(files, (t + jit)[keep], dth[keep], dv[keep]))
    assert plain.imu.bridged_rows == jittered.imu.bridged_rows == len(drop)
    np.testing.assert_allclose(jittered.imu.dvel_mps, plain.imu.dvel_mps, rtol=0, atol=1e-12)
    np.testing.assert_allclose(jittered.imu.dtheta_rad, plain.imu.dtheta_rad, rtol=0, atol=1e-14)
    # and the bridged velocity of each gap is the lost one to the interpolation error (no vibration
    # in this drive: well under 0.1 mm/s), far below the 3 mm/s the jitter used to put there
    for a, b in ((9000, 9003), (15000, 15001), (20000, 20004), (21000, 21005)):
        err = jittered.imu.dvel_mps[a:b].sum(axis=0) - dv[a:b].sum(axis=0)
        assert np.abs(err).max() < 1e-4, (a, err)
