"""Shared simulation helpers for the navigation tests."""

import numpy as np

from ldvsurvey.nav.attitude import attitude_error_rad
from ldvsurvey.nav.earth import enu_offset_m
from ldvsurvey.sim.imu import simulate_imu
from ldvsurvey.sim.motion import Motion


def truth_imu(sc, dt=0.01):
    m = Motion(sc.road, sc.segments, sc.t0_s, dt_s=dt)
    n = int(round((m.t_end_s - m.t0_s) / dt))
    t = m.t0_s + np.arange(n + 1) * dt
    return m, simulate_imu(m, t, sc.ldv.c_bt())


def errors(sol, imu, idx=None):
    """Attitude (rad), velocity (m/s) and position (m, ENU) errors of a solution at sample indices."""
    idx = slice(None) if idx is None else idx
    phi = attitude_error_rad(sol.c_bn()[idx], imu.c_bn[idx])
    dv = sol.v_n[idx] - imu.v_n[idx]
    dp = enu_offset_m(
        imu.lat_rad[idx], imu.lon_rad[idx], imu.h_m[idx], sol.pos[idx, 0], sol.pos[idx, 1], sol.pos[idx, 2]
    )
    return phi, dv, dp
