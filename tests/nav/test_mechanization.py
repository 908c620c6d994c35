"""Strapdown mechanization with perfect increments reproduces the true trajectory."""

import numpy as np
import pytest

from ldvsurvey.nav.attitude import attitude_error_rad, c_bs, c_from_q, q_from_c
from ldvsurvey.nav.earth import ARCSEC, enu_offset_m
from ldvsurvey.nav.mech import mechanize
from ldvsurvey.sim import catalog
from ldvsurvey.sim.imu import simulate_imu
from ldvsurvey.sim.motion import Motion, Turntable


def _truth_start(m, c_bt, t0):
    tr = m.truth(np.array([t0]))
    return tr["c_tn"][0] @ c_bt, tr["v_n"][0], np.array([tr["lat_rad"][0], tr["lon_rad"][0], tr["h_m"][0]])


@pytest.mark.slow
def test_one_hour_perfect_sensors_vehicle_dynamics():
    sc = catalog.drive(minutes=60, speed_mps=16)
    m = Motion(sc.road, sc.segments, sc.t0_s)
    n = int(round((m.t_end_s - m.t0_s) / 0.01))
    assert n >= 0.99 * 360_000  # one hour at 100 Hz
    t = m.t0_s + np.arange(n + 1) * 0.01
    c_bt = sc.ldv.c_bt()
    imu = simulate_imu(m, t, c_bt)
    c0, v0, p0 = _truth_start(m, c_bt, t[0])
    q, v, p = mechanize(
        imu.t_s, imu.dtheta_rad, imu.dvel_mps, q_from_c(c0), v0, p0, height_ref=(imu.h_m, imu.v_n[:, 2])
    )
    att_err = attitude_error_rad(c_from_q(q), imu.c_bn)
    assert np.abs(att_err).max() < 1.0 * ARCSEC
    d = enu_offset_m(imu.lat_rad, imu.lon_rad, imu.h_m, p[:, 0], p[:, 1], p[:, 2])
    assert np.hypot(d[:, 0], d[:, 1]).max() < 1.0


def test_rotating_imu_mechanizes_in_the_sensor_frame():
    sc = catalog.height(minutes=12, length_m=3000.0)
    m = Motion(sc.road, sc.segments, sc.t0_s)
    n = int(round((m.t_end_s - m.t0_s) / 0.01))
    t = m.t0_s + np.arange(n + 1) * 0.01
    c_bt = sc.ldv.c_bt()
    table = Turntable(sc.t0_s, dwell_s=30.0)
    imu = simulate_imu(m, t, c_bt, turntable=table, alpha_rad=sc.alpha_rad, beta_rad=sc.beta_rad)
    c0, v0, p0 = _truth_start(m, c_bt, t[0])
    c0_s = c0 @ c_bs(0.0, sc.alpha_rad, sc.beta_rad).T  # C_s^n = C_b^n C_s^b
    q, v, p = mechanize(
        imu.t_s, imu.dtheta_rad, imu.dvel_mps, q_from_c(c0_s), v0, p0, height_ref=(imu.h_m, imu.v_n[:, 2])
    )
    assert np.ptp(np.unwrap(imu.eta_rad)) > 3.0  # it did rotate
    c_bn = c_from_q(q) @ c_bs(imu.eta_rad, sc.alpha_rad, sc.beta_rad)
    assert np.abs(attitude_error_rad(c_bn, imu.c_bn)).max() < 0.2 * ARCSEC
    d = enu_offset_m(imu.lat_rad, imu.lon_rad, imu.h_m, p[:, 0], p[:, 1], p[:, 2])
    assert np.abs(d).max() < 0.05
