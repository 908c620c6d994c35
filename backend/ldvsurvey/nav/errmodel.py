"""SINS error model (phi-angle form, ENU) for the error-state Kalman filter.

States X = [φ (rad), δv (m/s), δp (m: East, North, Up), ε (rad/s, sensor frame),
∇ (m/s², sensor frame), then augmented LDV states]. Errors are computed − true:
C_computed = (I − [φ×]) C_true, δv = v̂ − v, δp = p̂ − p (local metres).
Closed-loop feedback: C ← (I + [φ×]) C, v ← v − δv, p ← p − δp.

φ̇ = −ω_in × φ + δω_in − C_s^n ε
δv̇ = f^n × φ − (2ω_ie + ω_en) × δv + v × (2δω_ie + δω_en) + C_s^n ∇ + δg
δṗ = δv (+ small position–velocity coupling terms)
"""

from __future__ import annotations

import numba as nb
import numpy as np

from ldvsurvey.nav.earth import OMEGA_IE, normal_gravity_nb, radii_nb

IX_PHI, IX_V, IX_P, IX_EPS, IX_NABLA, N_BASE = 0, 3, 6, 9, 12, 15


@nb.njit(cache=True)
def skew_nb(v):
    m = np.zeros((3, 3))
    m[0, 1], m[0, 2] = -v[2], v[1]
    m[1, 0], m[1, 2] = v[2], -v[0]
    m[2, 0], m[2, 1] = -v[1], v[0]
    return m


@nb.njit(cache=True)
def build_f(n, c_sn, f_n, v, lat, h):
    """Continuous-time system matrix F (n×n) at the given state.

    Parameters
    ----------
    c_sn : (3,3) C_s^n. f_n : specific force in n (m/s²). v : ENU velocity (m/s).
    lat : rad. h : m.
    """
    F = np.zeros((n, n))
    rm, rn = radii_nb(lat)
    rmh, rnh = rm + h, rn + h
    sl, cl = np.sin(lat), np.cos(lat)
    tl = sl / cl
    ve, vn, vu = v[0], v[1], v[2]
    w_ie = np.array([0.0, OMEGA_IE * cl, OMEGA_IE * sl])
    w_en = np.array([-vn / rmh, ve / rnh, ve * tl / rnh])
    w_in = w_ie + w_en
    # ∂δω_en/∂δv, ∂δω_ie/∂δp, ∂δω_en/∂δp (δp in metres E, N, U)
    m_v = np.zeros((3, 3))
    m_v[0, 1] = -1.0 / rmh
    m_v[1, 0] = 1.0 / rnh
    m_v[2, 0] = tl / rnh
    m_iep = np.zeros((3, 3))
    m_iep[1, 1] = -OMEGA_IE * sl / rmh
    m_iep[2, 1] = OMEGA_IE * cl / rmh
    m_enp = np.zeros((3, 3))
    m_enp[0, 2] = vn / rmh ** 2
    m_enp[1, 2] = -ve / rnh ** 2
    m_enp[2, 1] = ve / (cl * cl) / (rmh * rnh)
    m_enp[2, 2] = -ve * tl / rnh ** 2
    F[0:3, 0:3] = -skew_nb(w_in)
    F[0:3, 3:6] = m_v
    F[0:3, 6:9] = m_iep + m_enp
    F[0:3, 9:12] = -c_sn
    sv = skew_nb(v)
    F[3:6, 0:3] = skew_nb(f_n)
    F[3:6, 3:6] = -skew_nb(2.0 * w_ie + w_en) + sv @ m_v
    F[3:6, 6:9] = sv @ (2.0 * m_iep + m_enp)
    F[5, 8] += 2.0 * normal_gravity_nb(lat, h) / np.sqrt(rm * rn)
    F[3:6, 12:15] = c_sn
    for i in range(3):
        F[6 + i, 3 + i] = 1.0
    F[6, 6] = vu / rnh - vn * tl / rmh
    F[6, 7] = ve * tl / rmh
    F[6, 8] = -ve / rnh
    F[7, 7] = vu / rmh
    F[7, 8] = -vn / rmh
    return F


@nb.njit(cache=True)
def discretize(F, dt):
    """Φ ≈ I + F dt + (F dt)²/2."""
    n = F.shape[0]
    A = F * dt
    return np.eye(n) + A + 0.5 * (A @ A)


@nb.njit(cache=True)
def c_db(eta_l, phi_l):
    """C_d^b = R_z(φ_L) R_x(η_L): LDV head frame to body; forward column
    [−sinφ cosη, cosφ cosη, sinη] (spec eq. 3)."""
    ce, se, cp, sp = np.cos(eta_l), np.sin(eta_l), np.cos(phi_l), np.sin(phi_l)
    m = np.empty((3, 3))
    m[0, 0], m[0, 1], m[0, 2] = cp, -sp * ce, sp * se
    m[1, 0], m[1, 1], m[1, 2] = sp, cp * ce, -cp * se
    m[2, 0], m[2, 1], m[2, 2] = 0.0, se, ce
    return m
