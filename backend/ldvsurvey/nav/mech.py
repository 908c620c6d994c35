"""Strapdown mechanization from angle and velocity increments (ENU, WGS-84).

Attitude quaternion update with the two-sample (previous + current) coning correction,
velocity update with rotation and sculling corrections, navigation-frame rotation over the
interval, Coriolis and gravity at the extrapolated mid-interval state, then position by the
trapezoid rule. Compiled with numba; ``mech_step`` is shared with the filter loop.

Units: rad, m, m/s, s. State ``pos`` is [lat_rad, lon_rad, h_m]; ``q`` is C_s^n as [w,x,y,z].
"""

from __future__ import annotations

import numba as nb
import numpy as np

from ldvsurvey.nav.attitude import cross, q_rotvec, q_to_c, qmul
from ldvsurvey.nav.earth import OMEGA_IE, normal_gravity_nb, radii_nb


@nb.njit(cache=True)
def mech_step(q, v, pos, v_prev, pos_prev, dth, dv, dth_prev, dv_prev, dt, xi, eta, dg):
    """One update over an interval of length dt (s).

    Parameters
    ----------
    q, v, pos : state at the start (quaternion C_s^n, velocity ENU m/s, [lat, lon, h]).
    v_prev, pos_prev : state one interval earlier (for mid-interval extrapolation).
    dth, dv : increments of this interval in s (rad, m/s); dth_prev, dv_prev: the previous ones.
    xi, eta, dg : deflection (rad) and disturbance (m/s²) used in the gravity model.

    Returns
    -------
    q_new, v_new, pos_new, f_n : state at the end and the mean specific force in n (m/s²).
    """
    phi = dth + cross(dth_prev, dth) / 12.0
    dv_b = dv + 0.5 * cross(dth, dv) + (cross(dth_prev, dv) + cross(dv_prev, dth)) / 12.0
    v_mid = 1.5 * v - 0.5 * v_prev
    lat_mid = 1.5 * pos[0] - 0.5 * pos_prev[0]
    h_mid = 1.5 * pos[2] - 0.5 * pos_prev[2]
    rm, rn = radii_nb(lat_mid)
    sl, cl = np.sin(lat_mid), np.cos(lat_mid)
    w_ie = np.array([0.0, OMEGA_IE * cl, OMEGA_IE * sl])
    w_en = np.array([-v_mid[1] / (rm + h_mid), v_mid[0] / (rn + h_mid), v_mid[0] * sl / cl / (rn + h_mid)])
    w_in = w_ie + w_en
    gam = normal_gravity_nb(lat_mid, h_mid)
    g = np.array([-gam * eta, -gam * xi, -(gam + dg)])
    c = q_to_c(q)
    dv_n = c @ dv_b
    dv_n = dv_n - 0.5 * cross(w_in * dt, dv_n)
    v_new = v + dv_n + (g - cross(2.0 * w_ie + w_en, v_mid)) * dt
    vbar = 0.5 * (v + v_new)
    h_new = pos[2] + vbar[2] * dt
    hbar = 0.5 * (pos[2] + h_new)
    lat_new = pos[0] + vbar[1] / (rm + hbar) * dt
    latbar = 0.5 * (pos[0] + lat_new)
    lon_new = pos[1] + vbar[0] / ((rn + hbar) * np.cos(latbar)) * dt
    q_new = qmul(q_rotvec(-w_in * dt), qmul(q, q_rotvec(phi)))
    q_new = q_new / np.sqrt(np.sum(q_new * q_new))
    return q_new, v_new, np.array([lat_new, lon_new, h_new]), dv_n / dt


@nb.njit(cache=True)
def _run(t, dth, dvel, q0, v0, pos0, xi, eta, dg, h_ref, vu_ref):
    n = len(t)
    q_out = np.empty((n, 4))
    v_out = np.empty((n, 3))
    p_out = np.empty((n, 3))
    q, v, pos = q0.copy(), v0.copy(), pos0.copy()
    v_prev, pos_prev = v.copy(), pos.copy()
    dth_prev, dv_prev = np.zeros(3), np.zeros(3)
    has_g = len(xi) > 0
    hold = len(h_ref) > 0
    t_prev = t[0] - (t[1] - t[0]) if n > 1 else t[0] - 0.01
    for k in range(n):
        dt = t[k] - t_prev
        t_prev = t[k]
        if k == 0:
            dth_prev, dv_prev = dth[0], dvel[0]
        gx = xi[k] if has_g else 0.0
        ge = eta[k] if has_g else 0.0
        gd = dg[k] if has_g else 0.0
        q_new, v_new, p_new, _ = mech_step(q, v, pos, v_prev, pos_prev, dth[k], dvel[k], dth_prev, dv_prev,
                                           dt, gx, ge, gd)
        if hold:
            p_new[2] = h_ref[k]
            v_new[2] = vu_ref[k]
        v_prev, pos_prev = v, pos
        q, v, pos = q_new, v_new, p_new
        dth_prev, dv_prev = dth[k], dvel[k]
        q_out[k] = q
        v_out[k] = v
        p_out[k] = pos
    return q_out, v_out, p_out


def mechanize(t_s, dtheta_rad, dvel_mps, q0, v0_n, pos0, gravity=None, height_ref=None):
    """Free-inertial navigation over all samples.

    Parameters
    ----------
    t_s : (N,) end times of the increments, s; the first interval is assumed as long as the second.
    dtheta_rad, dvel_mps : (N, 3) increments in the sensor frame.
    q0 : initial C_s^n quaternion [w, x, y, z] at the start of the first interval.
    v0_n : initial velocity ENU, m/s. pos0 : [lat_rad, lon_rad, h_m].
    gravity : optional (xi_rad, eta_rad, dg_mps2) per sample for the gravity model.
    height_ref : optional (h_m, v_u_mps) per sample to hold the vertical channel.

    Returns
    -------
    q (N, 4), v_n (N, 3), pos (N, 3) at the sample times.
    """
    t = np.ascontiguousarray(t_s, dtype=float)
    e = np.zeros(0)
    xi, eta, dg = (e, e, e) if gravity is None else (np.ascontiguousarray(g, dtype=float) for g in gravity)
    h_ref, vu_ref = (e, e) if height_ref is None else (np.ascontiguousarray(a, dtype=float) for a in height_ref)
    return _run(t, np.ascontiguousarray(dtheta_rad, dtype=float), np.ascontiguousarray(dvel_mps, dtype=float),
                np.asarray(q0, dtype=float), np.asarray(v0_n, dtype=float), np.asarray(pos0, dtype=float),
                xi, eta, dg, h_ref, vu_ref)
