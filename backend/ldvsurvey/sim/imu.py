"""Exact IMU increments from a simulated motion.

Angular rate ω_is^s and specific force f^s are evaluated analytically at 3 Gauss-Legendre
nodes per sampling interval and integrated (exact for polynomials up to degree 5), with
Earth rotation, transport rate, normal gravity and an optional gravity disturbance and
deflection of the vertical. A rotating IMU adds the turntable: f^s = C_b^s f^b,
ω_is^s = C_b^s ω_ib^b + η̇ · (third column of C_b^s).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ldvsurvey.nav.attitude import c_bs
from ldvsurvey.nav.earth import gravity_n, w_en_n, w_ie_n
from ldvsurvey.sim.motion import Motion, Turntable

GL_X = np.array([-np.sqrt(0.6), 0.0, np.sqrt(0.6)])
GL_W = np.array([5.0, 8.0, 5.0]) / 9.0

#: field(lat_rad, lon_rad, h_m) -> (xi_rad, eta_rad, dg_mps2)
GravityField = Callable[[np.ndarray, np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray, np.ndarray]]


@dataclass
class ImuTruth:
    """Ideal IMU output and the truth at the sample times t_k (end of each interval)."""

    t_s: np.ndarray  # (N,)
    dtheta_rad: np.ndarray  # (N, 3) in s
    dvel_mps: np.ndarray  # (N, 3) in s
    eta_rad: np.ndarray | None  # (N,) turntable angle at t_k
    lat_rad: np.ndarray
    lon_rad: np.ndarray
    h_m: np.ndarray
    v_n: np.ndarray
    c_bn: np.ndarray  # (N, 3, 3) body attitude
    f_n: np.ndarray  # (N, 3) specific force in n at t_k, m/s²
    w_nb_b: np.ndarray  # (N, 3) body rate w.r.t. n at t_k, rad/s


def rates(
    motion: Motion,
    t,
    c_bt: np.ndarray,
    field: GravityField | None = None,
    turntable: Turntable | None = None,
    alpha_rad: float = 0.0,
    beta_rad: float = 0.0,
):
    """Angular rate and specific force the sensor feels at times ``t``, with the truth.

    Parameters
    ----------
    motion : Motion
        The vehicle's timeline.
    t : (N,) array
        Times (s).
    c_bt : (3, 3) array or callable
        Constant C_b^t, or ``c_bt(t, truth) -> (C_b^t (N, 3, 3), ω_tb^b (N, 3) rad/s)`` for a body
        whose attitude over the travel direction varies (see ``body.py``).
    field : callable, optional
        ``field(lat_rad, lon_rad, h_m) -> (ξ rad, η rad, Δg m/s²)``; default none (normal gravity).
    turntable : object, optional
        ``turntable.angle(t) -> (η rad, η̇ rad/s)`` of a rotating IMU; default a fixed IMU (s = b).
    alpha_rad, beta_rad : float
        Tilt of the turntable axis (rad).

    Returns
    -------
    w_is_s : (N, 3) array
        ω_is^s (rad/s).
    f_s : (N, 3) array
        Specific force f^s (m/s²).
    truth : dict
        ``Motion.truth(t)``.
    c_bn : (N, 3, 3) array
        Body attitude C_b^n.
    f_n : (N, 3) array
        Specific force in n (m/s²).
    w_nb_b : (N, 3) array
        Body rate with respect to n (rad/s).
    eta_rad : (N,) array or None
        Turntable angle (rad), None for a fixed IMU.
    """
    tr = motion.truth(t)
    if callable(c_bt):
        cbt, w_tb_b = c_bt(tr["t_s"], tr)
        c_bn = tr["c_tn"] @ cbt
        w_nb_b = np.einsum("kji,kj->ki", cbt, tr["w_nt_t"]) + w_tb_b
    else:
        c_bn = tr["c_tn"] @ c_bt
        w_nb_b = tr["w_nt_t"] @ c_bt  # C_t^b ω = (C_b^t)ᵀ ω, row-vector form
    lat, lon, h, v_n = tr["lat_rad"], tr["lon_rad"], tr["h_m"], tr["v_n"]
    if field is not None:
        xi, eta, dg = field(lat, lon, h)
    else:
        xi = eta = dg = 0.0
    g_n = gravity_n(lat, h, xi, eta, dg)
    wie, wen = w_ie_n(lat), w_en_n(lat, h, v_n)
    f_n = tr["a_n"] + np.cross(2 * wie + wen, v_n) - g_n
    f_b = np.einsum("kji,kj->ki", c_bn, f_n)
    w_ib_b = w_nb_b + np.einsum("kji,kj->ki", c_bn, wie + wen)
    eta_t = None
    if turntable is not None:
        eta_t, eta_dot = turntable.angle(t)
        cbs = c_bs(eta_t, alpha_rad, beta_rad)
        w_s = np.einsum("kij,kj->ki", cbs, w_ib_b) + eta_dot[:, None] * cbs[:, :, 2]
        f_s = np.einsum("kij,kj->ki", cbs, f_b)
    else:
        w_s, f_s = w_ib_b, f_b
    return w_s, f_s, tr, c_bn, f_n, w_nb_b, eta_t


def simulate_imu(
    motion: Motion,
    t_s: np.ndarray,
    c_bt,
    field: GravityField | None = None,
    turntable: Turntable | None = None,
    alpha_rad: float = 0.0,
    beta_rad: float = 0.0,
    chunk: int = 20000,
) -> ImuTruth:
    """Ideal increments over (t_{k−1}, t_k] for k = 1..N, given the N+1 times ``t_s``.

    Parameters
    ----------
    c_bt : (3, 3) C_b^t, body to travel frame (the mounting of the IMU body on the vehicle
        travel direction; identity when the LDV is perfectly aligned), or a callable (see ``rates``).
    """
    n = len(t_s) - 1
    dth = np.empty((n, 3))
    dv = np.empty((n, 3))
    for a in range(0, n, chunk):
        b = min(n, a + chunk)
        t0, t1 = t_s[a:b], t_s[a + 1 : b + 1]
        half = (t1 - t0) / 2
        mid = (t1 + t0) / 2
        nodes = (mid[:, None] + half[:, None] * GL_X[None, :]).ravel()
        w_s, f_s, *_ = rates(motion, nodes, c_bt, field, turntable, alpha_rad, beta_rad)
        wts = (half[:, None] * GL_W[None, :]).ravel()[:, None]
        dth[a:b] = (w_s * wts).reshape(b - a, 3, 3).sum(axis=1)
        dv[a:b] = (f_s * wts).reshape(b - a, 3, 3).sum(axis=1)
    w_s, f_s, tr, c_bn, f_n, w_nb_b, eta = rates(motion, t_s[1:], c_bt, field, turntable, alpha_rad, beta_rad)
    return ImuTruth(
        t_s=t_s[1:],
        dtheta_rad=dth,
        dvel_mps=dv,
        eta_rad=eta,
        lat_rad=tr["lat_rad"],
        lon_rad=tr["lon_rad"],
        h_m=tr["h_m"],
        v_n=tr["v_n"],
        c_bn=c_bn,
        f_n=f_n,
        w_nb_b=w_nb_b,
    )
