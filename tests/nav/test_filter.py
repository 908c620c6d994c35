"""Filter consistency (NEES over a Monte Carlo), smoother gain, and GNSS-denied LDV navigation."""

import numpy as np
import pytest
from scipy.stats import chi2

from ldvsurvey.nav.align import coarse_align
from ldvsurvey.nav.attitude import q_from_c, skew
from ldvsurvey.nav.earth import ARCSEC, radii
from ldvsurvey.nav.filter import FilterConfig, GnssAid, ImuData, ImuNoise, LdvAid, NavStart, run_filter
from ldvsurvey.sim import catalog
from ldvsurvey.sim.scenario import simulate
from ldvsurvey.sim.sensors import FIX_SIGMA, ImuErrors, LdvSpecSim, gnss_fixes, ldv_measure
from tests.nav.helpers import errors, truth_imu

RAD = np.pi / 180
SEEDS = 20


@pytest.fixture(scope="module")
def mc_setup():
    sc = catalog.drive(minutes=10, static_s=60, ldv=LdvSpecSim(noise_mps=0.01, lever_arm_m=(0.0, 0.0, -0.8)))
    m, imu = truth_imu(sc)
    return sc, m, imu


def _run_seed(sc, m, imu, seed, smooth):
    rng = np.random.default_rng(100 + seed)
    noise = ImuNoise(gyro_bias_dph=0.01, accel_bias_ug=50.0, gyro_arw_dprh=0.002, accel_vrw_ug_rthz=20.0)
    err = ImuErrors(
        rng.normal(0, noise.gyro_bias_rps, 3), rng.normal(0, noise.accel_bias_mps2, 3), noise.arw_psd, noise.vrw_psd
    )
    dth, dv = err.apply(imu.dtheta_rad, imu.dvel_mps, 0.01, rng)
    cfg = FilterConfig(
        att_sigma0_rad=(60 * ARCSEC, 60 * ARCSEC, 0.2 * RAD),
        vel_sigma0_mps=0.05,
        pos_sigma0_m=1.0,
        ldv_sigma_mps=(0.01, 0.01, 0.01),
        gate_sigma=0.0,
    )
    # initial errors drawn from P0
    tr0 = m.truth(np.array([imu.t_s[0] - 0.01]))
    c_true = tr0["c_tn"][0] @ sc.ldv.c_bt()
    phi0 = rng.normal(0, 1, 3) * np.asarray(cfg.att_sigma0_rad)
    c0 = (np.eye(3) - skew(phi0)) @ c_true
    dp = rng.normal(0, cfg.pos_sigma0_m, 3)
    rm, rn = radii(tr0["lat_rad"][0])
    pos0 = np.array(
        [
            tr0["lat_rad"][0] + dp[1] / rm,
            tr0["lon_rad"][0] + dp[0] / (rn * np.cos(tr0["lat_rad"][0])),
            tr0["h_m"][0] + dp[2],
        ]
    )
    v0 = tr0["v_n"][0] + rng.normal(0, cfg.vel_sigma0_mps, 3)
    vf, vu = ldv_measure(m, imu.t_s, sc.ldv, rng)
    tg = np.arange(np.ceil(imu.t_s[0]), imu.t_s[-1], 1.0)
    glat, glon, gh, fix = gnss_fixes(
        m, tg, sc.ldv.c_bt(), sc.gnss_lever_m, lambda t: np.full(len(t), 4), rng, white_only=True
    )
    s_h, s_v = FIX_SIGMA[4]
    gnss = GnssAid(tg, glat * RAD, glon * RAD, gh, np.full(len(tg), s_h), np.full(len(tg), s_v), sc.gnss_lever_m)
    ldv = LdvAid(np.ones(len(imu.t_s), bool), vf, vu, lever_arm_m=sc.ldv.lever_arm_m)
    sol = run_filter(
        ImuData(imu.t_s, dth, dv),
        NavStart(q_from_c(c0), v0, pos0),
        noise,
        cfg,
        ldv=ldv,
        gnss=gnss,
        smooth=smooth,
        keep_cov=True,
    )
    return sol, err


def _nees(sol, imu, err):
    idx = sol.epoch_index[1::5]
    phi, dvel, dpos = errors(sol, imu, idx)
    db = np.column_stack([err.gyro_bias_rps - sol.epoch_bias[1::5, :3], err.accel_bias_mps2 - sol.epoch_bias[1::5, 3:]])
    e = np.column_stack([phi, dvel, dpos, db])
    cov = sol.epoch_cov[1::5, :15, :15]
    return np.einsum("ki,ki->k", e, np.linalg.solve(cov, e[..., None])[..., 0])


@pytest.mark.slow
def test_nees_within_chi2_bounds(mc_setup):
    sc, m, imu = mc_setup
    runs = [_run_seed(sc, m, imu, s, smooth=False) for s in range(SEEDS)]
    nees = np.array([_nees(sol, imu, err) for sol, err in runs])
    avg = nees.mean(axis=0)
    lo, hi = chi2.ppf([0.025, 0.975], 15 * SEEDS) / SEEDS
    inside = (avg >= lo) & (avg <= hi)
    assert inside.mean() >= 0.9, (lo, hi, np.percentile(avg, [5, 50, 95]))
    # and the time-averaged NEES is 15 within its (much tighter) bound
    assert lo <= avg.mean() <= hi


def test_smoother_beats_forward(mc_setup):
    sc, m, imu = mc_setup
    fwd, err = _run_seed(sc, m, imu, 0, smooth=False)
    smo, _ = _run_seed(sc, m, imu, 0, smooth=True)
    ef, es = errors(fwd, imu), errors(smo, imu)
    for a, b in zip(ef, es):  # attitude, velocity, position
        assert np.sqrt(np.mean(b**2)) < np.sqrt(np.mean(a**2))
    assert np.all(smo.sigma[:, :9].mean(axis=0) <= fwd.sigma[:, :9].mean(axis=0))


@pytest.mark.slow
def test_gnss_denied_30_minutes_with_2d_ldv():
    """Gravimetry-paper budget: 30 min without GNSS, horizontal ≤ 10 m, height ≤ 2 m."""
    ldv = LdvSpecSim(
        pitch_rad=0.2 * RAD, heading_rad=-0.3 * RAD, scale=1.001, scale_up=1.001, noise_mps=0.01, kind="2d"
    )
    sc = catalog.drive(
        minutes=50,
        speed_mps=12,
        ldv=ldv,
        gyro_bias_dph=0.003,
        accel_bias_ug=20.0,
        gyro_arw_dprh=0.0005,
        accel_vrw_ug_rthz=5.0,
    )
    t_out = 300.0 + 15 * 60.0
    sc.fix_schedule = [(t_out, 1e9, 0)]
    sim = simulate(sc, seed=7)
    imu = sim.imu
    static = imu.t_s < sc.t0_s + 300
    c0 = coarse_align(sim.dtheta_rad[static], sim.dvel_mps[static], sc.road.lat0_rad)
    ok = sim.ldv_quality >= 100
    aid = LdvAid(ok, sim.ldv_v_fwd, sim.ldv_v_up, lever_arm_m=ldv.lever_arm_m)
    fix = sim.gnss_fix
    sig = np.array([FIX_SIGMA.get(int(f), (np.nan, np.nan)) for f in fix])
    gnss = GnssAid(
        sim.gnss_t_s,
        sim.gnss_lat_deg * RAD,
        sim.gnss_lon_deg * RAD,
        sim.gnss_h_m,
        sig[:, 0],
        sig[:, 1],
        sc.gnss_lever_m,
    )
    cfg = FilterConfig(ldv_aug=("scale", "pitch", "heading"), att_sigma0_rad=(0.05 * RAD, 0.05 * RAD, 2 * RAD))
    pos0 = np.array([sc.road.lat0_rad, sc.road.lon0_rad, sc.road.h0_m])
    sol = run_filter(
        ImuData(imu.t_s, sim.dtheta_rad, sim.dvel_mps),
        NavStart(q_from_c(c0), np.zeros(3), pos0),
        ImuNoise(0.003, 20.0, 0.0005, 5.0),
        cfg,
        zupt_intervals=[(sc.t0_s, sc.t0_s + 300)],
        ldv=aid,
        gnss=gnss,
        smooth=False,
    )
    denied = imu.t_s > sc.t0_s + t_out
    assert imu.t_s[denied][-1] - imu.t_s[denied][0] >= 30 * 60 - 60
    _, _, dp = errors(sol, imu)
    assert np.hypot(dp[denied, 0], dp[denied, 1]).max() <= 10.0
    assert np.abs(dp[denied, 2]).max() <= 2.0
    assert sol.ldv_params["scale"][0] == pytest.approx(1.001, abs=1e-4)
