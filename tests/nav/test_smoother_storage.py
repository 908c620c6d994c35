"""The filter's bounded-memory storage: covariances kept every CK_EVERY epochs and redone by the
smoother, attitude-only runs, and the per-row accessors of NavSolution.

Independent references: the forward pass's own 1-σ (taken from its covariance while it ran)
against the covariances redone from the checkpoints; a full run against an attitude-only one;
the former whole-log quaternion interpolation (written out here) against ``attitude_at``.
"""

import numpy as np
import pytest

from ldvsurvey.nav import kfloop
from ldvsurvey.nav.attitude import c_from_q, q_from_c, skew
from ldvsurvey.nav.earth import ARCSEC
from ldvsurvey.nav.filter import FilterConfig, GnssAid, ImuData, ImuNoise, LdvAid, NavStart, run_filter
from ldvsurvey.pipelines.stages.aids import attitude_at
from ldvsurvey.sim import catalog
from ldvsurvey.sim.sensors import (
    FIX_SIGMA,
    ImuErrors,
    LdvSpecSim,
    gnss_fixes,
    ldv_measure,
)
from tests.nav.helpers import truth_imu

RAD = np.pi / 180


@pytest.fixture(scope="module")
def case():
    """6 min: 60 s still, then driving; LDV with three calibration states, GNSS at 1 Hz, the gate on."""
    sc = catalog.drive(
        minutes=6, static_s=60, ldv=LdvSpecSim(noise_mps=0.01, pitch_rad=0.3 * RAD, heading_rad=-0.2 * RAD, scale=1.002)
    )
    m, imu = truth_imu(sc)
    rng = np.random.default_rng(3)
    noise = ImuNoise(gyro_bias_dph=0.01, accel_bias_ug=50.0, gyro_arw_dprh=0.002, accel_vrw_ug_rthz=20.0)
    err = ImuErrors(
        rng.normal(0, noise.gyro_bias_rps, 3), rng.normal(0, noise.accel_bias_mps2, 3), noise.arw_psd, noise.vrw_psd
    )
    dth, dv = err.apply(imu.dtheta_rad, imu.dvel_mps, 0.01, rng)
    tr0 = m.truth(np.array([imu.t_s[0] - 0.01]))
    c0 = (np.eye(3) - skew(np.array([30, -20, 600]) * ARCSEC)) @ tr0["c_tn"][0] @ sc.ldv.c_bt()
    pos0 = np.array([tr0["lat_rad"][0], tr0["lon_rad"][0], tr0["h_m"][0]])
    vf, vu = ldv_measure(m, imu.t_s, sc.ldv, rng)
    tg = np.arange(np.ceil(imu.t_s[0]), imu.t_s[-1], 1.0)
    glat, glon, gh, _ = gnss_fixes(
        m, tg, sc.ldv.c_bt(), sc.gnss_lever_m, lambda t: np.full(len(t), 4), rng, white_only=True
    )
    s_h, s_v = FIX_SIGMA[4]
    gnss = GnssAid(tg, glat * RAD, glon * RAD, gh, np.full(len(tg), s_h), np.full(len(tg), s_v), sc.gnss_lever_m)
    ldv = LdvAid(np.ones(len(imu.t_s), bool), vf, vu, lever_arm_m=sc.ldv.lever_arm_m)
    cfg = FilterConfig(ldv_aug=("scale", "pitch", "heading"), gate_sigma=3.0, bias_instability=0.1)
    kw = {"cfg": cfg, "ldv": ldv, "gnss": gnss, "zupt_intervals": [(imu.t_s[0], imu.t_s[0] + 60.0)]}
    return (ImuData(imu.t_s, dth, dv), NavStart(q_from_c(c0), tr0["v_n"][0], pos0), noise), kw


def test_redone_covariances_are_the_forward_ones(case):
    args, kw = case
    sol = run_filter(*args, smooth=False, keep_cov=True, **kw)
    n_ep = len(sol.epoch_t_s)
    assert n_ep > 3 * kfloop.CK_EVERY  # several checkpoint blocks
    assert sum(sol.rejected.values()) > 0  # the records carry rejected rows too
    diag = np.sqrt(np.maximum(np.einsum("kii->ki", sol.epoch_cov), 0.0))
    np.testing.assert_array_equal(diag, sol.epoch_sigma)  # bit for bit, every epoch of every block


def test_smoothed_covariance_consistent(case):
    args, kw = case
    sol = run_filter(*args, smooth=True, keep_cov=True, **kw)
    ps = sol.epoch_cov
    np.testing.assert_array_equal(np.sqrt(np.maximum(np.einsum("kii->ki", ps), 0.0)), sol.epoch_sigma)
    fwd = run_filter(*args, smooth=False, **kw)
    # smoothing never increases a variance (up to rounding)
    assert np.all(sol.epoch_sigma <= fwd.epoch_sigma * (1 + 1e-9) + 1e-15)
    # the last epoch has nothing after it: smoothed = forward
    np.testing.assert_allclose(sol.epoch_sigma[-1], fwd.epoch_sigma[-1], rtol=1e-12)


def test_attitude_only_run_has_the_same_attitude_and_parameters(case):
    args, kw = case
    full = run_filter(*args, smooth=True, **kw)
    att = run_filter(*args, smooth=True, attitude_only=True, **kw)
    np.testing.assert_array_equal(att.q_sn, full.q_sn)
    np.testing.assert_array_equal(att.epoch_sigma, full.epoch_sigma)
    assert att.ldv_params == full.ldv_params
    assert len(att.v_n) == 0 and len(att.pos) == 0 and len(att.f_u_mps2) == 0
    # the rows a pipeline asks for are the rows of the whole arrays
    idx = np.arange(5, len(full.t_s), 997)
    np.testing.assert_array_equal(full.c_bn(idx), full.c_bn()[idx])
    np.testing.assert_allclose(full.sigma_at(idx), full.sigma[idx], rtol=0, atol=0)


def _attitude_at_whole_log(sol, t_s):
    """The former implementation: every sample's quaternion, signs made continuous, then interpolated."""
    q = q_from_c(sol.c_bn())
    flip = np.cumprod(np.where(np.sum(q[1:] * q[:-1], axis=1) < 0, -1.0, 1.0))
    q[1:] *= flip[:, None]
    qi = np.column_stack([np.interp(t_s, sol.t_s, q[:, i]) for i in range(4)])
    return c_from_q(qi)


def test_attitude_at_matches_whole_log_interpolation(case):
    args, kw = case
    sol = run_filter(*args, smooth=True, **kw)
    rng = np.random.default_rng(0)
    t = np.concatenate([rng.uniform(sol.t_s[0] - 1.0, sol.t_s[-1] + 1.0, 500), sol.t_s[[0, 17, -1]]])
    np.testing.assert_allclose(attitude_at(sol, t), _attitude_at_whole_log(sol, t), rtol=0, atol=1e-13)
