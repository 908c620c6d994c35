"""The navigation result carries the up specific force of its own mechanization step (issue 14's f_U).

Truth: the interval mean of the simulator's analytic specific force, by 3-node Gauss-Legendre
quadrature of ``rates`` (the motion model's kinematics, not the mechanization). The old
recomputation (mid-interval attitude plus ½Δθ×Δv) counts the rotation correction twice; on a
rotating IMU in curves that is tens of mGal, far above the bounds here.
"""

import numpy as np
import pytest

from ldvsurvey.nav.attitude import c_bs, q_from_c
from ldvsurvey.nav.earth import MGAL
from ldvsurvey.nav.filter import FilterConfig, GnssAid, ImuData, ImuNoise, NavStart, run_filter
from ldvsurvey.sim import catalog
from ldvsurvey.sim.imu import GL_W, GL_X, rates, simulate_imu
from ldvsurvey.sim.motion import Motion, Turntable

RAD = np.pi / 180


@pytest.fixture(scope="module")
def rotating_drive():
    sc = catalog.drive(minutes=6.5, static_s=30, speed_mps=15)
    m = Motion(sc.road, sc.segments, sc.t0_s)
    n = int(round((m.t_end_s - m.t0_s) / 0.01))
    t = m.t0_s + np.arange(n + 1) * 0.01
    c_bt = sc.ldv.c_bt()
    table = Turntable(sc.t0_s, dwell_s=10.0, rate_dps=20.0)
    alpha, beta = 4e-4, -6e-4
    imu = simulate_imu(m, t, c_bt, turntable=table, alpha_rad=alpha, beta_rad=beta)
    cbs = np.ascontiguousarray(c_bs(imu.eta_rad, alpha, beta))
    # truth: mean f_U over each interval (t_{k-1}, t_k] (for k = 0 the interval before t_0)
    tk = imu.t_s
    ta = np.r_[tk[0] - 0.01, tk[:-1]]
    f_mean = np.zeros(len(tk))
    for x, w in zip(GL_X, GL_W):
        tn = 0.5 * (ta + tk) + 0.5 * x * (tk - ta)
        f_n = rates(m, tn, c_bt)[4]
        f_mean += 0.5 * w * f_n[:, 2]
    tr0 = m.truth(np.array([tk[0] - 0.01]))
    c0_s = tr0["c_tn"][0] @ c_bt @ cbs[0].T  # C_s^n at the start: attitude of the sensor frame
    return sc, imu, cbs, f_mean, tr0, c0_s


def _moving(imu):
    return np.hypot(imu.v_n[:, 0], imu.v_n[:, 1]) > 1.0


def test_f_u_matches_truth_on_rotating_imu(rotating_drive):
    sc, imu, cbs, f_true, tr0, c0_s = rotating_drive
    pos0 = np.array([tr0["lat_rad"][0], tr0["lon_rad"][0], tr0["h_m"][0]])
    sol = run_filter(
        ImuData(imu.t_s, imu.dtheta_rad, imu.dvel_mps, cbs),
        NavStart(q_from_c(c0_s), tr0["v_n"][0], pos0),
        ImuNoise(),
        FilterConfig(),
        smooth=False,
    )
    assert sol.f_u_mps2.shape == imu.t_s.shape
    np.testing.assert_allclose(sol.f_t_s[1:], 0.5 * (imu.t_s[1:] + imu.t_s[:-1]), atol=1e-9)
    mv = _moving(imu)
    err = (sol.f_u_mps2 - f_true)[mv] / MGAL
    # the free-inertial vertical drifts a little (no aiding): the attitude stays within an arcsecond,
    # so f_U can be off by φ×f_h ≲ 5e-6 rad × 1 m/s² = 0.5 mGal at most
    assert np.sqrt(np.mean(err**2)) < 0.2, np.sqrt(np.mean(err**2))
    assert np.abs(err).max() < 1.0
    # the rotation matters here: the old recomputation (true mid-interval attitude plus ½Δθ×Δv)
    # fails the same bound
    c_sn = imu.c_bn @ np.swapaxes(cbs, 1, 2)
    c_mid = 0.5 * (c_sn[1:] + c_sn[:-1])
    dth, dv = imu.dtheta_rad[1:], imu.dvel_mps[1:]
    f_old = np.einsum("kj,kj->k", c_mid[:, 2, :], dv + 0.5 * np.cross(dth, dv)) / 0.01
    err_old = (f_old - f_true[1:])[mv[1:]] / MGAL
    assert np.abs(err_old).max() > 1.0


def test_f_u_smoothed_follows_the_smoothed_attitude(rotating_drive):
    """With a 2′ initial tilt error and GNSS aiding, the smoothed f_U is corrected with the smoothed
    attitude: its error is far below the forward one's (φ×f of the initial error)."""
    sc, imu, cbs, f_true, tr0, c0_s = rotating_drive
    rng = np.random.default_rng(3)
    phi0 = np.array([120.0, -120.0, 0.0]) * RAD / 3600
    from ldvsurvey.nav.attitude import skew

    c0 = (np.eye(3) - skew(phi0)) @ c0_s
    pos0 = np.array([tr0["lat_rad"][0], tr0["lon_rad"][0], tr0["h_m"][0]])
    tg = np.arange(np.ceil(imu.t_s[0]), imu.t_s[-1], 1.0)
    lat = np.interp(tg, imu.t_s, imu.lat_rad)
    lon = np.interp(tg, imu.t_s, imu.lon_rad)
    h = np.interp(tg, imu.t_s, imu.h_m) + rng.normal(0, 0.01, len(tg))
    gnss = GnssAid(tg, lat, lon, h, np.full(len(tg), 0.02), np.full(len(tg), 0.02))
    cfg = FilterConfig(att_sigma0_rad=(200 * RAD / 3600, 200 * RAD / 3600, 0.1 * RAD))
    noise = ImuNoise(gyro_bias_dph=0.003, accel_bias_ug=20.0, gyro_arw_dprh=0.0005, accel_vrw_ug_rthz=5.0)
    fwd = run_filter(
        ImuData(imu.t_s, imu.dtheta_rad, imu.dvel_mps, cbs),
        NavStart(q_from_c(c0), tr0["v_n"][0], pos0),
        noise,
        cfg,
        gnss=gnss,
        smooth=False,
    )
    smo = run_filter(
        ImuData(imu.t_s, imu.dtheta_rad, imu.dvel_mps, cbs),
        NavStart(q_from_c(c0), tr0["v_n"][0], pos0),
        noise,
        cfg,
        gnss=gnss,
        smooth=True,
    )
    acc = (imu.t_s < imu.t_s[0] + 150.0) & _moving(imu)  # before the GNSS has levelled the forward filter
    e_f = (fwd.f_u_mps2 - f_true)[acc] / MGAL
    e_s = (smo.f_u_mps2 - f_true)[acc] / MGAL
    assert np.sqrt(np.mean(e_s**2)) < 0.5 * np.sqrt(np.mean(e_f**2))
    # and the bias correction is reported so the raw f_U can be rebuilt
    assert smo.f_u_bias_mps2.shape == imu.t_s.shape
