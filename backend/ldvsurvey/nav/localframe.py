"""Small-area local east/north metres about a reference point, and back (WGS-84 radii of curvature).

Plain numpy, no numba: the views and the report (:mod:`ldvsurvey.api`) import it without loading
the compiled core. The WGS-84 ellipsoid, :func:`radii` and :func:`normal_gravity` are defined here
once; :mod:`ldvsurvey.nav.earth` takes them from here (the import's gravity check uses them without
loading numba).
"""

from __future__ import annotations

import numpy as np

A_M = 6378137.0  #: WGS-84 semi-major axis, m
F = 1.0 / 298.257223563  #: WGS-84 flattening
E2 = F * (2.0 - F)  #: first eccentricity squared
B_M = A_M * (1.0 - F)  #: semi-minor axis, m
OMEGA_IE = 7.292115e-5  #: Earth rotation rate, rad/s
GM = 3.986004418e14  #: m³/s²
GAMMA_E = 9.7803253359  #: normal gravity at the equator, m/s²
K_SOMIGLIANA = 0.00193185265241
M_RATIO = OMEGA_IE**2 * A_M**2 * B_M / GM  #: m = ω² a² b / GM


def normal_gravity(lat_rad, h_m):
    """Vectorized Somigliana normal gravity γ(L, h) with the second-order height term, m/s².

    Parameters
    ----------
    lat_rad : float or array
        Geodetic latitude, rad.
    h_m : float or array
        Ellipsoidal height, m.

    Returns
    -------
    float or array
        Normal gravity, m/s².
    """
    lat_rad = np.asarray(lat_rad, dtype=float)
    h_m = np.asarray(h_m, dtype=float)
    s2 = np.sin(lat_rad) ** 2
    g0 = GAMMA_E * (1.0 + K_SOMIGLIANA * s2) / np.sqrt(1.0 - E2 * s2)
    return g0 * (1.0 - 2.0 / A_M * (1.0 + F + M_RATIO - 2.0 * F * s2) * h_m + 3.0 * h_m**2 / A_M**2)


def radii(lat_rad):
    """Meridian and prime-vertical radii of curvature.

    Parameters
    ----------
    lat_rad : float or array
        Geodetic latitude, rad.

    Returns
    -------
    rm_m, rn_m : float or array
        Meridian (R_M) and prime-vertical (R_N) radius, m.
    """
    s2 = np.sin(lat_rad) ** 2
    w = 1.0 - E2 * s2
    return A_M * (1.0 - E2) / (w * np.sqrt(w)), A_M / np.sqrt(w)


def local_metres(lat0, lon0, lat, lon):
    """East/north offsets of points from a reference on the reference's radii (a small area).

    Parameters
    ----------
    lat0, lon0 : float
        Reference latitude and longitude, rad.
    lat, lon : float or array
        Latitude and longitude of the points, rad.

    Returns
    -------
    e_m, n_m : float or array
        East and north offsets, m.
    """
    rm, rn = radii(lat0)
    return (lon - lon0) * rn * np.cos(lat0), (lat - lat0) * rm


def local_latlon(lat0, lon0, e_m, n_m):
    """The inverse of :func:`local_metres`: latitude and longitude of east/north offsets.

    Parameters
    ----------
    lat0, lon0 : float
        Reference latitude and longitude, rad.
    e_m, n_m : float or array
        East and north offsets from the reference, m.

    Returns
    -------
    lat_rad, lon_rad : float or array
        Latitude and longitude, rad.
    """
    rm, rn = radii(lat0)
    return lat0 + n_m / rm, lon0 + e_m / (rn * np.cos(lat0))
