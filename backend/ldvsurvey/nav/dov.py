"""DOV-induced INS position error (methods §5, DOV paper eq. 10-21), in this product's error convention
(computed − true; C_computed = (I − [φ×]) C_true).

An INS whose gravity model lacks the deflection has the velocity-error input
δg_err = g_model − g_true = [γη, γξ] (E, N), and starts with the misalignment its levelling and
gyrocompassing pick up from the plumb line: φ0 = [−ξ0, η0, η0 tan L].

    δV̇ = f^n × φ + δg_err − (2ω_ie + ω_en) × δV   (horizontal; ``coriolis=False`` drops the last
                                                     term exactly as the paper's eq. 10 does)
    φ̇ = −ω_in × φ + δω_in            (eq. 11)
    δL̇ = δV_N / R_M,  δλ̇ = δV_E sec L / R_N + δL V_E tan L sec L / R_N   (eq. 16-17)

Direct difference: one Euler step per error-update period (eq. 14-18). RK4: the attitude error
by fourth-order Runge-Kutta over the same period (eq. 19-21), velocity and position as above.
"""

from __future__ import annotations

from typing import NamedTuple

import numba as nb
import numpy as np

from ldvsurvey.nav.earth import OMEGA_IE, radii_nb


class Trajectory(NamedTuple):
    """The reference trajectory the errors are propagated along, N samples (numba passes it as a tuple)."""

    t_s: np.ndarray  #: (N,) sample times (s)
    lat_rad: np.ndarray  #: (N,) latitude (rad)
    h_m: np.ndarray  #: (N,) ellipsoidal height (m)
    v_e_mps: np.ndarray  #: (N,) east velocity (m/s)
    f_n_mps2: np.ndarray  #: (N, 3) specific force in n, ENU (m/s²)
    w_in_rps: np.ndarray  #: (N, 3) rate of n with respect to inertial space in n, ω_in^n (rad/s)
    gamma_mps2: np.ndarray  #: (N,) normal gravity (m/s²)


class Deflection(NamedTuple):
    """The deflection of the vertical along the trajectory (N samples)."""

    xi_rad: np.ndarray  #: (N,) north-south component ξ (rad)
    eta_rad: np.ndarray  #: (N,) east-west component η (rad)


@nb.njit(cache=True)
def _phidot(phi, w_in, dve, dvn, dlat, lat, h, ve):
    """φ̇ (rad/s) of eq. 11: −ω_in × φ + δω_in from the velocity and latitude errors."""
    rm, rn = radii_nb(lat)
    sl, cl = np.sin(lat), np.cos(lat)
    dw0 = -dvn / (rm + h)
    dw1 = dve / (rn + h) - OMEGA_IE * sl * dlat
    dw2 = dve * sl / cl / (rn + h) + (OMEGA_IE * cl + ve / (cl * cl) / (rn + h)) * dlat
    c0 = w_in[1] * phi[2] - w_in[2] * phi[1]
    c1 = w_in[2] * phi[0] - w_in[0] * phi[2]
    c2 = w_in[0] * phi[1] - w_in[1] * phi[0]
    return np.array([-c0 + dw0, -c1 + dw1, -c2 + dw2])


@nb.njit(cache=True)
def propagate(track, dov, dt_update_s, rk4, phi0_rad, coriolis=True):
    """Error propagation along a trajectory, one update every ``dt_update_s``.

    Parameters
    ----------
    track : Trajectory
        The reference trajectory (times s, latitude rad, height m, east velocity m/s, specific force
        and ω_in in n, normal gravity m/s²).
    dov : Deflection
        ξ, η (rad) along the trajectory, missing from the INS's gravity model.
    dt_update_s : float
        Error-update period (s).
    rk4 : bool
        Attitude error by fourth-order Runge-Kutta, else by the direct difference.
    phi0_rad : (3,) array
        Initial misalignment φ (rad), e.g. :func:`initial_misalignment`.
    coriolis : bool
        Keep −(2ω_ie + ω_en) × δV (the Foucault coupling, ~5 % of the east error over hours at mid
        latitudes).

    Returns
    -------
    t_out : (K,) array
        Update times (s).
    dn_m, de_m : (K,) arrays
        North and east position errors (m), computed − true.
    phi : (K, 3) array
        Misalignment (rad) at the update times.
    """
    t, lat, h, v_e, f_n, w_in, gam = track
    xi, eta = dov
    n_s = len(t)
    k_max = int((t[-1] - t[0]) / dt_update_s) + 1
    t_out = np.empty(k_max)
    dn = np.empty(k_max)
    de = np.empty(k_max)
    ph = np.empty((k_max, 3))
    phi = phi0_rad.copy()
    dve = dvn = dlat = dlon = 0.0
    j = 0
    for k in range(k_max):
        tk = t[0] + k * dt_update_s
        while j < n_s - 2 and t[j + 1] <= tk:
            j += 1
        rm, rn = radii_nb(lat[j])
        t_out[k] = tk
        dn[k] = dlat * (rm + h[j])
        de[k] = dlon * (rn + h[j]) * np.cos(lat[j])
        ph[k] = phi
        if k == k_max - 1:
            break
        # state at t_{m-1} = tk
        fe, fn, fu = f_n[j, 0], f_n[j, 1], f_n[j, 2]
        ge = gam[j] * eta[j]
        gn = gam[j] * xi[j]
        # δV̇ = f × φ + δg_err (E and N components)
        ae = fn * phi[2] - fu * phi[1] + ge
        an = fu * phi[0] - fe * phi[2] + gn
        if coriolis:
            w_up = 2.0 * OMEGA_IE * np.sin(lat[j]) + v_e[j] * np.tan(lat[j]) / (rn + h[j])
            ae += w_up * dvn
            an -= w_up * dve
        if rk4:
            # ω_in at t, t + τ/2 and t + τ from the trajectory samples
            jm = j
            while jm < n_s - 2 and t[jm + 1] <= tk + 0.5 * dt_update_s:
                jm += 1
            je = jm
            while je < n_s - 2 and t[je + 1] <= tk + dt_update_s:
                je += 1
            k1 = _phidot(phi, w_in[j], dve, dvn, dlat, lat[j], h[j], v_e[j])
            k2 = _phidot(phi + 0.5 * dt_update_s * k1, w_in[jm], dve, dvn, dlat, lat[jm], h[jm], v_e[jm])
            k3 = _phidot(phi + 0.5 * dt_update_s * k2, w_in[jm], dve, dvn, dlat, lat[jm], h[jm], v_e[jm])
            k4 = _phidot(phi + dt_update_s * k3, w_in[je], dve, dvn, dlat, lat[je], h[je], v_e[je])
            phi = phi + dt_update_s * (k1 + 2 * k2 + 2 * k3 + k4) / 6.0
        else:
            phi = phi + dt_update_s * _phidot(phi, w_in[j], dve, dvn, dlat, lat[j], h[j], v_e[j])
        dve += ae * dt_update_s
        dvn += an * dt_update_s
        dlat += dvn / (rm + h[j]) * dt_update_s
        sl, cl = np.sin(lat[j]), np.cos(lat[j])
        dlon += (dve / (cl * (rn + h[j])) + dlat * v_e[j] * sl / (cl * cl) / (rn + h[j])) * dt_update_s
    return t_out, dn, de, ph


def initial_misalignment(xi_rad: float, eta_rad: float, lat_rad: float) -> np.ndarray:
    """Misalignment φ0 = [−ξ, η, η tan L] that levelling to the plumb line, then gyrocompassing, pick up.

    Parameters
    ----------
    xi_rad, eta_rad : float
        Deflection of the vertical at the alignment (rad).
    lat_rad : float
        Latitude of the alignment (rad).

    Returns
    -------
    (3,) array
        φ0 (rad), east, north, up.
    """
    return np.array([-xi_rad, eta_rad, eta_rad * np.tan(lat_rad)])


def schuler_constant_dov(t_s, eps_rad: float, lat_rad: float, h_m: float = 0.0):
    """Analytic undamped response to a constant deflection: δx = R ε (1 − cos ω_s t).

    Parameters
    ----------
    t_s : array
        Time since the alignment (s).
    eps_rad : float
        The constant deflection component (rad).
    lat_rad : float
        Latitude (rad).
    h_m : float
        Ellipsoidal height (m).

    Returns
    -------
    array
        Position error δx (m) along the deflection's direction, at ``t_s``.
    """
    from ldvsurvey.nav.earth import normal_gravity, radii

    rm, rn = radii(lat_rad)
    r = np.sqrt(rm * rn) + h_m
    ws = np.sqrt(normal_gravity(lat_rad, h_m) / r)
    return r * eps_rad * (1 - np.cos(ws * np.asarray(t_s)))
