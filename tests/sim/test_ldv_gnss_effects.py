"""LDV dropout bursts and good-flagged spikes, GNSS lever arm, convergence, outages and multipath,
each measured from the generated data against the effect's specification."""

import numpy as np
import pytest

from ldvsurvey.sim import catalog
from ldvsurvey.sim.effects import Effects, GnssEffects, LdvDropouts
from ldvsurvey.sim.scenario import simulate

A, E2 = 6378137.0, 6.69437999014e-3  # WGS-84


def _runs(mask):
    """(start, stop) index pairs of runs of True."""
    d = np.diff(np.concatenate([[0], mask.astype(int), [0]]))
    return list(zip(np.flatnonzero(d == 1), np.flatnonzero(d == -1)))


@pytest.fixture(scope="module")
def ldv_sim():
    spec = LdvDropouts(rate_per_min=10.0, burst_min_s=0.1, burst_max_s=5.0, static_bursts=2, spikes_per_min=3.0)
    sc = catalog.realistic_drive(seed=8, effects=Effects.ideal().with_(ldv_dropouts=spec), minutes=8, static_s=60)
    return simulate(sc), spec


def test_dropout_bursts(ldv_sim):
    sim, spec = ldv_sim
    t, q, v = sim.ldv_t_s, sim.ldv_quality, sim.ldv_v_fwd
    assert np.all(np.isfinite(v)) and np.all(np.isfinite(sim.ldv_v_up))  # garbage, never NaN
    runs = [(a, b) for a, b in _runs(q < 100) if b - a >= 5]  # isolated bad samples are not bursts
    minutes = (t[-1] - t[0]) / 60.0
    expected = spec.rate_per_min * minutes + spec.static_bursts
    assert abs(len(runs) - expected) < 4 * np.sqrt(expected)
    dur = np.array([(b - a) / 100.0 for a, b in runs])
    assert dur.max() <= spec.burst_max_s * 1.3  # two bursts may touch
    # durations log-uniform on [0.1, 5] s: mean of ln d is the mid-point (bursts < 0.05 s are not counted)
    assert np.mean(np.log(dur)) == pytest.approx(0.5 * (np.log(0.1) + np.log(5.0)), abs=0.35)
    # each burst holds garbage of one kind: zeros, a stale repeat, spikes ≥ 2 m/s, or ±2 m/s noise
    speed = sim.motion.truth(t)["speed_mps"]
    kinds = set()
    for a, b in runs:
        seg, ref = v[a:b], speed[a:b]
        if np.all(seg == 0.0):
            kinds.add("zeros")
        elif np.all(seg == seg[0]):
            kinds.add("stale")
        elif np.all(np.abs(seg) >= 2.0) and np.std(seg) > 2.0:
            kinds.add("spikes")
        else:
            assert np.std(seg - ref) > 0.5, "a burst with plausible values"
            kinds.add("noise")
    assert len(kinds) >= 3
    # bursts in the initial static period too (they must not split a stop)
    static_end = sim.scenario.t0_s + 60.0
    assert any(t[a] < static_end for a, _ in runs)


def test_good_flagged_spikes(ldv_sim):
    sim, spec = ldv_sim
    t, q, v = sim.ldv_t_s, sim.ldv_quality, sim.ldv_v_fwd
    speed = sim.motion.truth(t)["speed_mps"]
    spikes = (q >= 100) & (np.abs(v - speed) > 0.28)
    minutes = (t[-1] - t[0]) / 60.0
    expected = spec.spikes_per_min * minutes
    assert abs(spikes.sum() - expected) < 4 * np.sqrt(expected)
    assert np.abs(v - speed)[spikes].max() <= 5.2


@pytest.fixture(scope="module")
def gnss_sim():
    spec = GnssEffects(lever_arm_m=(0.3, 0.8, 1.6), outages_per_h=30.0, degraded_per_h=20.0, multipath_per_h=40.0)
    sc = catalog.realistic_drive(seed=9, effects=Effects.ideal().with_(gnss=spec), minutes=10, static_s=60)
    return simulate(sc), spec


def _antenna_minus_imu_enu(sim):
    """Antenna fix minus the true IMU position, local ENU (m), exact WGS-84 radii."""
    t = sim.gnss_t_s
    k = np.searchsorted(sim.imu.t_s, t)
    k = np.clip(k, 0, len(sim.imu.t_s) - 1)
    assert np.allclose(sim.imu.t_s[k], t, atol=1e-6)
    lat, lon, h = sim.imu.lat_rad[k], sim.imu.lon_rad[k], sim.imu.h_m[k]
    w = np.sqrt(1 - E2 * np.sin(lat) ** 2)
    rn, rm = A / w, A * (1 - E2) / w**3
    d = np.column_stack(
        [
            (np.radians(sim.gnss_lon_deg) - lon) * (rn + h) * np.cos(lat),
            (np.radians(sim.gnss_lat_deg) - lat) * (rm + h),
            sim.gnss_h_m - h,
        ]
    )
    return d, sim.imu.c_bn[k]


def test_lever_arm_rotates_with_the_true_attitude(gnss_sim):
    sim, spec = gnss_sim
    d, c_bn = _antenna_minus_imu_enu(sim)
    good = sim.gnss_fix == 4
    # least-squares lever arm in body axes: l = mean of C_n^b d over the fixed epochs
    lever = np.einsum("kji,kj->ki", c_bn[good], d[good]).mean(axis=0)
    np.testing.assert_allclose(lever, spec.lever_arm_m, atol=0.04)
    # the vehicle turned, so an unrotated lever arm would not fit
    resid = d[good] - np.einsum("kij,j->ki", c_bn[good], spec.lever_arm_m)
    naive = d[good] - np.asarray(spec.lever_arm_m)
    assert np.sqrt(np.mean(resid[:, :2] ** 2)) < 0.1 < np.sqrt(np.mean(naive[:, :2] ** 2))


def test_convergence_outages_and_multipath(gnss_sim):
    sim, spec = gnss_sim
    fix = sim.gnss_fix
    t = sim.gnss_t_s - sim.scenario.t0_s
    assert set(fix[t < 20]) == {1} and set(fix[(t >= 20) & (t < 40)]) == {2} and set(fix[(t >= 40) & (t < 60)]) == {5}
    assert np.all(np.isnan(sim.gnss_lat_deg[fix == 0])) and np.all(np.isfinite(sim.gnss_lat_deg[fix > 0]))
    hours = (t[-1] - 60.0) / 3600.0
    outages = _runs(fix == 0)
    assert 1 <= len(outages) <= spec.outages_per_h * hours + 4 * np.sqrt(spec.outages_per_h * hours)
    assert min(b - a for a, b in outages) >= 10
    assert set(fix[t >= 60]) & {1, 2, 5}  # quality changes after the convergence


def test_multipath_jumps():
    """Runs of ≥ 5 s in fixed solutions off the lever-arm geometry by 0.1–0.5 m (multipath alone)."""
    spec = GnssEffects(outages_per_h=0.0, degraded_per_h=0.0, multipath_per_h=60.0)
    sc = catalog.realistic_drive(seed=9, effects=Effects.ideal().with_(gnss=spec), minutes=8, static_s=60)
    sim = simulate(sc)
    fix = sim.gnss_fix
    d, c_bn = _antenna_minus_imu_enu(sim)
    resid = np.linalg.norm(d - np.einsum("kij,j->ki", c_bn, spec.lever_arm_m), axis=1)
    jumps = [(a, b) for a, b in _runs((resid > 0.08) & (fix == 4)) if b - a >= 5]
    expected = 60.0 * (sim.gnss_t_s[-1] - sim.gnss_t_s[0] - 60.0) / 3600.0
    assert 2 <= len(jumps) <= expected + 4 * np.sqrt(expected)
    med = [np.median(resid[a:b]) for a, b in jumps]
    assert min(med) >= 0.08 and max(med) <= 0.6
