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

#: first index of each 3-vector block of the state: φ (rad, ENU), δv (m/s, ENU), δp (m: East, North,
#: Up), ε (rad/s, sensor frame), ∇ (m/s², sensor frame); N_BASE states in all
IX_PHI, IX_V, IX_P, IX_EPS, IX_NABLA, N_BASE = 0, 3, 6, 9, 12, 15
#: the first augmented state: the navigation filter's LDV states (in the order of
#: ``ldvsurvey.nav.filter.AUG_NAMES``, those enabled), then the z-gyro scale factor; the damping
#: filter's one LDV state δs (the inverse-scale error)
IX_AUG = N_BASE
#: the number of LDV calibration states the navigation filter knows (s_f, η_L, φ_L, s_u, k_η)
N_LDV_PAR = 5


@nb.njit(cache=True)
def skew_nb(v):
    """[v×] (3×3) of a 3-vector v (any unit), allocated: [v×] u = v × u."""
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
    build_f_into(F, c_sn, f_n, v, lat, h)
    return F


@nb.njit(cache=True)
def build_f_into(F, c_sn, f_n_mps2, v_n_mps, lat_rad, h_m):
    """Write the 15 base-state block of F (see :func:`build_f`) into ``F``, which holds zeros there
    (no allocation: the filter builds one F per epoch).

    Parameters
    ----------
    F : (n, n) system matrix (1/s), written in rows and columns 0..14.
    c_sn : (3, 3) C_s^n.
    f_n_mps2 : (3,) specific force in n, m/s².
    v_n_mps : (3,) velocity ENU, m/s.
    lat_rad : latitude, rad.
    h_m : ellipsoidal height, m.
    """
    f0, f1, f2 = f_n_mps2[0], f_n_mps2[1], f_n_mps2[2]
    ve, vn, vu = v_n_mps[0], v_n_mps[1], v_n_mps[2]
    lat, h = lat_rad, h_m
    rm, rn = radii_nb(lat)
    rmh, rnh = rm + h, rn + h
    sl, cl = np.sin(lat), np.cos(lat)
    tl = sl / cl
    wie1, wie2 = OMEGA_IE * cl, OMEGA_IE * sl
    wen0, wen1, wen2 = -vn / rmh, ve / rnh, ve * tl / rnh
    wi0, wi1, wi2 = wen0, wie1 + wen1, wie2 + wen2
    # ∂δω_en/∂δv (m_v), ∂δω_ie/∂δp (m_iep), ∂δω_en/∂δp (m_enp), δp in metres E, N, U
    mv01, mv10, mv20 = -1.0 / rmh, 1.0 / rnh, tl / rnh
    mi11, mi21 = -OMEGA_IE * sl / rmh, OMEGA_IE * cl / rmh
    me02, me12 = vn / rmh**2, -ve / rnh**2
    me21, me22 = ve / (cl * cl) / (rmh * rnh), -ve * tl / rnh**2
    # F[0:3, 0:3] = −[ω_in×]
    F[0, 1], F[0, 2] = wi2, -wi1
    F[1, 0], F[1, 2] = -wi2, wi0
    F[2, 0], F[2, 1] = wi1, -wi0
    # F[0:3, 3:6] = m_v
    F[0, 4] = mv01
    F[1, 3] = mv10
    F[2, 3] = mv20
    # F[0:3, 6:9] = m_iep + m_enp
    F[0, 8] = me02
    F[1, 7] = mi11
    F[1, 8] = me12
    F[2, 7] = mi21 + me21
    F[2, 8] = me22
    for i in range(3):
        for jj in range(3):
            F[IX_PHI + i, IX_EPS + jj] = -c_sn[i, jj]
            F[IX_V + i, IX_NABLA + jj] = c_sn[i, jj]
    # F[3:6, 0:3] = [f×]
    F[3, 1], F[3, 2] = -f2, f1
    F[4, 0], F[4, 2] = f2, -f0
    F[5, 0], F[5, 1] = -f1, f0
    # F[3:6, 3:6] = −[(2ω_ie + ω_en)×] + [v×] m_v, with [v×] = [[0, −vu, vn], [vu, 0, −ve], [−vn, ve, 0]]
    k0, k1, k2 = wen0, 2.0 * wie1 + wen1, 2.0 * wie2 + wen2
    F[3, 3] = (-vu) * mv10 + vn * mv20
    F[3, 4] = k2
    F[3, 5] = -k1
    F[4, 3] = -k2 + (-ve) * mv20
    F[4, 4] = vu * mv01
    F[4, 5] = k0
    F[5, 3] = k1 + ve * mv10
    F[5, 4] = -k0 + (-vn) * mv01
    F[5, 5] = 0.0
    # F[3:6, 6:9] = [v×] (2 m_iep + m_enp)
    n02, n11, n12, n21, n22 = me02, 2.0 * mi11, me12, 2.0 * mi21 + me21, me22
    F[3, 6] = 0.0
    F[3, 7] = (-vu) * n11 + vn * n21
    F[3, 8] = (-vu) * n12 + vn * n22
    F[4, 6] = 0.0
    F[4, 7] = (-ve) * n21
    F[4, 8] = vu * n02 + (-ve) * n22
    F[5, 6] = 0.0
    F[5, 7] = ve * n11
    F[5, 8] = (-vn) * n02 + ve * n12
    F[5, 8] += 2.0 * normal_gravity_nb(lat, h) / np.sqrt(rm * rn)
    for i in range(3):
        F[IX_P + i, IX_V + i] = 1.0
    F[6, 6] = vu / rnh - vn * tl / rmh
    F[6, 7] = ve * tl / rmh
    F[6, 8] = -ve / rnh
    F[7, 7] = vu / rmh
    F[7, 8] = -vn / rmh


@nb.njit(cache=True)
def discretize(F, dt):
    """Φ ≈ I + F dt + (F dt)²/2 of the system matrix F (1/s) over dt (s), allocated."""
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
