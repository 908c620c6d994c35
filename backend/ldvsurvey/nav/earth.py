"""WGS-84 Earth model: radii of curvature, rates, normal gravity, gravity vector in n (ENU).

All angles in radians, heights in metres, rates in rad/s, gravity in m/s².
Scalar ``*_nb`` twins are numba-compiled for the per-sample loops.
"""

from __future__ import annotations

import numba as nb
import numpy as np

# the ellipsoid, its constants and the vectorized normal gravity are defined once, without numba, there
from ldvsurvey.nav.localframe import (  # noqa: F401
    A_M,
    B_M,
    E2,
    GAMMA_E,
    GM,
    K_SOMIGLIANA,
    M_RATIO,
    OMEGA_IE,
    F,
    normal_gravity,
    radii,
)
from ldvsurvey.units import MPS2_PER_MGAL as MGAL  # noqa: E402, F401  (re-exported; 1 mGal in m/s²)
from ldvsurvey.units import RAD_PER_ARCSEC as ARCSEC  # noqa: E402, F401  (re-exported; 1 arcsecond in rad)


@nb.njit(cache=True)
def radii_nb(lat_rad: float) -> tuple[float, float]:
    """Meridian and prime-vertical radii (R_M, R_N) in m at geodetic latitude (rad)."""
    s2 = np.sin(lat_rad) ** 2
    w = 1.0 - E2 * s2
    return A_M * (1.0 - E2) / (w * np.sqrt(w)), A_M / np.sqrt(w)


@nb.njit(cache=True)
def normal_gravity_nb(lat_rad: float, h_m: float) -> float:
    """Somigliana normal gravity with the second-order height term, m/s²."""
    s2 = np.sin(lat_rad) ** 2
    g0 = GAMMA_E * (1.0 + K_SOMIGLIANA * s2) / np.sqrt(1.0 - E2 * s2)
    return g0 * (1.0 - 2.0 / A_M * (1.0 + F + M_RATIO - 2.0 * F * s2) * h_m + 3.0 * h_m * h_m / (A_M * A_M))


def w_ie_n(lat_rad):
    """Earth rate in n (ENU): [0, ω cos L, ω sin L], rad/s; shape (..., 3)."""
    lat_rad = np.asarray(lat_rad, dtype=float)
    return np.stack([np.zeros_like(lat_rad), OMEGA_IE * np.cos(lat_rad), OMEGA_IE * np.sin(lat_rad)], axis=-1)


def w_en_n(lat_rad, h_m, v_n):
    """Transport rate in n: [−v_N/(R_M+h), v_E/(R_N+h), v_E tan L/(R_N+h)], rad/s."""
    rm, rn = radii(lat_rad)
    v_n = np.asarray(v_n, dtype=float)
    ve, vn = v_n[..., 0], v_n[..., 1]
    return np.stack([-vn / (rm + h_m), ve / (rn + h_m), ve * np.tan(lat_rad) / (rn + h_m)], axis=-1)


def gravity_n(lat_rad, h_m, xi_rad=0.0, eta_rad=0.0, dg_mps2=0.0):
    """True gravity in n (ENU): [−γη, −γξ, −(γ + Δg)], m/s².

    Parameters
    ----------
    xi_rad, eta_rad : north-south and east-west deflection of the vertical, rad.
    dg_mps2 : gravity disturbance Δg (positive where gravity is stronger), m/s².
    """
    gam = normal_gravity(lat_rad, h_m)
    xi, eta, dg = np.broadcast_arrays(xi_rad, eta_rad, dg_mps2)
    return np.stack(np.broadcast_arrays(-gam * eta, -gam * xi, -(gam + dg)), axis=-1)


def lla_to_ecef(lat_rad, lon_rad, h_m):
    """Geodetic to Earth-centred Earth-fixed coordinates, m; shape (..., 3)."""
    _, rn = radii(lat_rad)
    cl = np.cos(lat_rad)
    return np.stack(
        [(rn + h_m) * cl * np.cos(lon_rad), (rn + h_m) * cl * np.sin(lon_rad), (rn * (1 - E2) + h_m) * np.sin(lat_rad)],
        axis=-1,
    )


def enu_offset_m(lat0_rad, lon0_rad, h0_m, lat_rad, lon_rad, h_m):
    """Local ENU offsets (m) of points from a reference point (exact, via ECEF)."""
    d = lla_to_ecef(lat_rad, lon_rad, h_m) - lla_to_ecef(lat0_rad, lon0_rad, h0_m)
    sl, cl, so, co = np.sin(lat0_rad), np.cos(lat0_rad), np.sin(lon0_rad), np.cos(lon0_rad)
    e = -so * d[..., 0] + co * d[..., 1]
    n = -sl * co * d[..., 0] - sl * so * d[..., 1] + cl * d[..., 2]
    u = cl * co * d[..., 0] + cl * so * d[..., 1] + sl * d[..., 2]
    return np.stack([e, n, u], axis=-1)
