"""Strapdown mechanization from angle and velocity increments (ENU, WGS-84).

Attitude quaternion update with the two-sample (previous + current) coning correction,
velocity update with rotation and sculling corrections, navigation-frame rotation over the
interval, Coriolis and gravity at the extrapolated mid-interval state, then position by the
trapezoid rule. Compiled with numba; ``mech_step`` is shared with the filter loop.

Units: rad, m, m/s, s. State ``pos`` is [lat_rad, lon_rad, h_m]; ``q`` is C_s^n as [w,x,y,z].
"""

from __future__ import annotations

from typing import NamedTuple

import numba as nb
import numpy as np

from ldvsurvey.nav.attitude import cross, q_rotvec, q_to_c, qmul
from ldvsurvey.nav.earth import OMEGA_IE, normal_gravity_nb, radii_nb


class NavState(NamedTuple):
    """The mechanization's state at the start of an interval and what it extrapolates from, (3,)
    arrays unless said (numba passes it as a tuple; :func:`mech_step_into` updates it in place)."""

    q_sn: np.ndarray  #: (4,) quaternion [w, x, y, z] of C_s^n
    v_n_mps: np.ndarray  #: velocity ENU, m/s
    pos_rad_m: np.ndarray  #: [lat (rad), lon (rad), h (m)]
    v_prev_n_mps: np.ndarray  #: the velocity one interval earlier (mid-interval extrapolation), m/s
    pos_prev_rad_m: np.ndarray  #: the position one interval earlier, [rad, rad, m]
    dth_prev_rad: np.ndarray  #: the previous interval's angle increment (coning, sculling), rad
    dv_prev_mps: np.ndarray  #: the previous interval's velocity increment (sculling), m/s


@nb.njit(cache=True)
def mech_step(nav, dth, dv, dt, xi, eta, dg):
    """One update over an interval of length dt (s), allocating (the reference for :func:`mech_step_into`).

    Parameters
    ----------
    nav : :class:`NavState` at the start of the interval (not modified).
    dth, dv : (3,) increments of this interval in s, rad and m/s.
    dt : interval length, s.
    xi, eta : deflection of the vertical (north, east), rad, used in the gravity model.
    dg : gravity disturbance, m/s².

    Returns
    -------
    q_new, v_new, pos_new, f_n : state at the end (C_s^n quaternion, ENU m/s, [lat rad, lon rad, h m])
        and the mean specific force in n (m/s²).
    """
    q, v, pos, v_prev, pos_prev, dth_prev, dv_prev = nav
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


@nb.njit(cache=True, inline="always")
def _rotvec_sc(a0, a1, a2):
    """(c, s) of the quaternion [c, s a] of rotation vector a (as :func:`attitude.q_rotvec`)."""
    n2 = a0 * a0 + a1 * a1 + a2 * a2
    if n2 < 1e-16:
        return 1.0 - n2 / 8.0, 0.5 - n2 / 48.0
    a = np.sqrt(n2)
    return np.cos(a / 2), np.sin(a / 2) / a


# inlined into its caller: a call with the NavState tuple would take a reference on each of its
# arrays per sample (about a tenth of a microsecond), the cost of the filter's whole mechanization
@nb.njit(cache=True, inline="always")
def mech_step_into(nav, dth, dv, dt, xi, eta, dg, f_n):
    """:func:`mech_step` in place and without allocation (the same arithmetic, term by term).

    Parameters
    ----------
    nav : :class:`NavState`; on return its q, v, pos hold the state at the end of the interval and
        v_prev, pos_prev the state at its start (dth_prev, dv_prev are left to the caller).
    dth, dv : (3,) increments of this interval, rad and m/s.
    dt : interval length, s.
    xi, eta : deflection of the vertical (north, east), rad.
    dg : gravity disturbance, m/s².
    f_n : (3,) written: the mean specific force in n over the interval, m/s².
    """
    q, v, pos, v_prev, pos_prev, dth_prev, dv_prev = nav
    t0, t1, t2 = dth[0], dth[1], dth[2]
    u0, u1, u2 = dv[0], dv[1], dv[2]
    p0, p1, p2 = dth_prev[0], dth_prev[1], dth_prev[2]
    r0, r1, r2 = dv_prev[0], dv_prev[1], dv_prev[2]
    # coning: φ = Δθ + Δθ_prev × Δθ / 12
    ph0 = t0 + (p1 * t2 - p2 * t1) / 12.0
    ph1 = t1 + (p2 * t0 - p0 * t2) / 12.0
    ph2 = t2 + (p0 * t1 - p1 * t0) / 12.0
    # rotation and sculling: Δv + ½ Δθ × Δv + (Δθ_prev × Δv + Δv_prev × Δθ) / 12
    b0 = u0 + 0.5 * (t1 * u2 - t2 * u1) + ((p1 * u2 - p2 * u1) + (r1 * t2 - r2 * t1)) / 12.0
    b1 = u1 + 0.5 * (t2 * u0 - t0 * u2) + ((p2 * u0 - p0 * u2) + (r2 * t0 - r0 * t2)) / 12.0
    b2 = u2 + 0.5 * (t0 * u1 - t1 * u0) + ((p0 * u1 - p1 * u0) + (r0 * t1 - r1 * t0)) / 12.0
    vm0 = 1.5 * v[0] - 0.5 * v_prev[0]
    vm1 = 1.5 * v[1] - 0.5 * v_prev[1]
    vm2 = 1.5 * v[2] - 0.5 * v_prev[2]
    lat_mid = 1.5 * pos[0] - 0.5 * pos_prev[0]
    h_mid = 1.5 * pos[2] - 0.5 * pos_prev[2]
    rm, rn = radii_nb(lat_mid)
    sl, cl = np.sin(lat_mid), np.cos(lat_mid)
    wie1, wie2 = OMEGA_IE * cl, OMEGA_IE * sl
    wen0 = -vm1 / (rm + h_mid)
    wen1 = vm0 / (rn + h_mid)
    wen2 = vm0 * sl / cl / (rn + h_mid)
    wi0, wi1, wi2 = wen0, wie1 + wen1, wie2 + wen2
    gam = normal_gravity_nb(lat_mid, h_mid)
    g0, g1, g2 = -gam * eta, -gam * xi, -(gam + dg)
    w, x, y, z = q[0], q[1], q[2], q[3]
    c00 = 1 - 2 * (y * y + z * z)
    c01 = 2 * (x * y - w * z)
    c02 = 2 * (x * z + w * y)
    c10 = 2 * (x * y + w * z)
    c11 = 1 - 2 * (x * x + z * z)
    c12 = 2 * (y * z - w * x)
    c20 = 2 * (x * z - w * y)
    c21 = 2 * (y * z + w * x)
    c22 = 1 - 2 * (x * x + y * y)
    d0 = c00 * b0 + c01 * b1 + c02 * b2
    d1 = c10 * b0 + c11 * b1 + c12 * b2
    d2 = c20 * b0 + c21 * b1 + c22 * b2
    # n-frame rotation over the interval: Δv_n − ½ (ω_in dt) × Δv_n
    a0, a1, a2 = wi0 * dt, wi1 * dt, wi2 * dt
    e0 = d0 - 0.5 * (a1 * d2 - a2 * d1)
    e1 = d1 - 0.5 * (a2 * d0 - a0 * d2)
    e2 = d2 - 0.5 * (a0 * d1 - a1 * d0)
    # Coriolis: (2 ω_ie + ω_en) × v_mid
    k0, k1, k2 = wen0, 2.0 * wie1 + wen1, 2.0 * wie2 + wen2
    vn0 = v[0] + e0 + (g0 - (k1 * vm2 - k2 * vm1)) * dt
    vn1 = v[1] + e1 + (g1 - (k2 * vm0 - k0 * vm2)) * dt
    vn2 = v[2] + e2 + (g2 - (k0 * vm1 - k1 * vm0)) * dt
    vb0, vb1, vb2 = 0.5 * (v[0] + vn0), 0.5 * (v[1] + vn1), 0.5 * (v[2] + vn2)
    h_new = pos[2] + vb2 * dt
    hbar = 0.5 * (pos[2] + h_new)
    lat_new = pos[0] + vb1 / (rm + hbar) * dt
    latbar = 0.5 * (pos[0] + lat_new)
    lon_new = pos[1] + vb0 / ((rn + hbar) * np.cos(latbar)) * dt
    # q_new = q(−ω_in dt) ⊗ (q ⊗ q(φ))
    cb, sb = _rotvec_sc(ph0, ph1, ph2)
    qb0, qb1, qb2, qb3 = cb, sb * ph0, sb * ph1, sb * ph2
    m0 = w * qb0 - x * qb1 - y * qb2 - z * qb3
    m1 = w * qb1 + x * qb0 + y * qb3 - z * qb2
    m2 = w * qb2 - x * qb3 + y * qb0 + z * qb1
    m3 = w * qb3 + x * qb2 - y * qb1 + z * qb0
    ca, sa = _rotvec_sc(-a0, -a1, -a2)
    qa0, qa1, qa2, qa3 = ca, -sa * a0, -sa * a1, -sa * a2
    n0 = qa0 * m0 - qa1 * m1 - qa2 * m2 - qa3 * m3
    n1 = qa0 * m1 + qa1 * m0 + qa2 * m3 - qa3 * m2
    n2 = qa0 * m2 - qa1 * m3 + qa2 * m0 + qa3 * m1
    n3 = qa0 * m3 + qa1 * m2 - qa2 * m1 + qa3 * m0
    nq = np.sqrt(n0 * n0 + n1 * n1 + n2 * n2 + n3 * n3)
    q[0], q[1], q[2], q[3] = n0 / nq, n1 / nq, n2 / nq, n3 / nq
    for i in range(3):
        v_prev[i] = v[i]
        pos_prev[i] = pos[i]
    v[0], v[1], v[2] = vn0, vn1, vn2
    pos[0], pos[1], pos[2] = lat_new, lon_new, h_new
    f_n[0], f_n[1], f_n[2] = e0 / dt, e1 / dt, e2 / dt


@nb.njit(cache=True)
def _run(t, dth, dvel, start, gravity, hold):
    """The free-inertial loop of :func:`mechanize`: start (q0, v0, pos0), gravity (xi, eta, dg) and
    hold (h_ref, vu_ref) are tuples of arrays, the latter two of empty arrays when not given."""
    q0, v0, pos0 = start
    xi, eta, dg = gravity
    h_ref, vu_ref = hold
    n = len(t)
    q_out = np.empty((n, 4))
    v_out = np.empty((n, 3))
    p_out = np.empty((n, 3))
    q, v, pos = q0.copy(), v0.copy(), pos0.copy()
    v_prev, pos_prev = v.copy(), pos.copy()
    dth_prev, dv_prev = np.zeros(3), np.zeros(3)
    has_g = len(xi) > 0
    holding = len(h_ref) > 0
    t_prev = t[0] - (t[1] - t[0]) if n > 1 else t[0] - 0.01
    for k in range(n):
        dt = t[k] - t_prev
        t_prev = t[k]
        if k == 0:
            dth_prev, dv_prev = dth[0], dvel[0]
        gx = xi[k] if has_g else 0.0
        ge = eta[k] if has_g else 0.0
        gd = dg[k] if has_g else 0.0
        nav = NavState(q, v, pos, v_prev, pos_prev, dth_prev, dv_prev)
        q_new, v_new, p_new, _ = mech_step(nav, dth[k], dvel[k], dt, gx, ge, gd)
        if holding:
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
    return _run(
        t,
        np.ascontiguousarray(dtheta_rad, dtype=float),
        np.ascontiguousarray(dvel_mps, dtype=float),
        (np.asarray(q0, dtype=float), np.asarray(v0_n, dtype=float), np.asarray(pos0, dtype=float)),
        (xi, eta, dg),
        (h_ref, vu_ref),
    )
