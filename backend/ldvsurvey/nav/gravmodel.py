"""What the built-in EGM2008 gives a gravity survey beside δg: the height anomaly ζ and the omission error.

ζ = T/γ (Bruns) from the model's disturbing potential T at the point, plus the zero-degree term of
EGM2008 with respect to WGS-84 (−0.41 m, NGA's EGM2008 release notes). It places the telluroid for
the free-air anomaly Δg = g_P − γ(φ, h − ζ) (Molodensky). Its 1-σ (EGM2008 commission error,
decimetres on land) moves Δg by 0.3086 mGal/m · σ_ζ, a few hundredths of a mGal.

The omission error of a model complete to degree N compared with data resolved to degree n_s:
σ² = Σ_{n=N+1}^{n_s} c_n, with the Tscherning–Rapp (1974) degree variances of the gravity anomaly
c_n = A (n − 1)/((n − 2)(n + B)) s^(n+2), A = 425.28 mGal², B = 24, s = 0.999617: a global
average (rugged areas more, flat areas less).
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np

from ldvsurvey.nav.earth import A_M, E2, normal_gravity

#: EGM2008's zero-degree height term against WGS-84 (m)
ZERO_DEGREE_M = -0.41
#: mean Earth radius for degree ↔ wavelength, m
R_MEAN_M = 6371000.0
#: Tscherning–Rapp degree-variance model constants
TR_A_MGAL2, TR_B, TR_S = 425.28, 24.0, 0.999617


def omission_mgal(n_model: int, resolution_m: float) -> float:
    """RMS of the gravity signal between the model's degree and the data's half-wavelength resolution.

    Parameters
    ----------
    n_model : int
        Degree to which the model is complete.
    resolution_m : float
        Half-wavelength resolution of the data (m).

    Returns
    -------
    float
        Omission error (mGal) from the Tscherning–Rapp degree variances; 0 when the data resolve no
        more than the model.
    """
    n_s = int(np.ceil(np.pi * R_MEAN_M / max(resolution_m, 1.0)))
    if n_s <= n_model:
        return 0.0
    n = np.arange(n_model + 1, n_s + 1, dtype=float)
    c = TR_A_MGAL2 * (n - 1) / ((n - 2) * (n + TR_B)) * TR_S ** (n + 2)
    return float(np.sqrt(np.sum(c)))


@lru_cache(maxsize=2)
def _model(degree: int):
    from ldvsurvey.nav.egm import disturbing_coefficients, load_model

    return disturbing_coefficients(load_model("egm2008", n_max=degree))


def height_anomaly_m(lat_deg, lon_deg, h_m: float = 0.0, degree: int = 2190) -> np.ndarray:
    """Height anomaly ζ from EGM2008 to ``degree`` at the points (one synthesis per distinct latitude:
    give a grid's nodes, or few points).

    Parameters
    ----------
    lat_deg, lon_deg : arrays
        Geodetic latitude and longitude of the points (deg), same length.
    h_m : float
        Ellipsoidal height at which T is evaluated (m).
    degree : int
        Degree of the synthesis.

    Returns
    -------
    (N,) array
        ζ (m), with EGM2008's zero-degree term.
    """
    from ldvsurvey.nav.egm import _row_sums

    model = _model(degree)
    lat = np.radians(np.atleast_1d(np.asarray(lat_deg, float)))
    lon = np.radians(np.atleast_1d(np.asarray(lon_deg, float)))
    m = np.arange(model.m_max + 1)
    out = np.empty(len(lat))
    c = np.ascontiguousarray(model.c)
    s = np.ascontiguousarray(model.s)
    for phi in np.unique(lat):  # the Legendre sums depend on the latitude only
        k = lat == phi
        sl, cl = np.sin(phi), np.cos(phi)
        rn = A_M / np.sqrt(1 - E2 * sl * sl)
        x = (rn + h_m) * cl
        z = (rn * (1 - E2) + h_m) * sl
        r = np.hypot(x, z)
        theta = np.arctan2(x, z)
        at, bt, *_ = _row_sums(np.cos(theta), np.sin(theta), model.n_max, model.m_max, c, s, model.a / r)
        lam = lon[k][:, None] * m[None, :]
        t_pot = model.gm / r * (np.cos(lam) @ at + np.sin(lam) @ bt)
        out[k] = t_pot / normal_gravity(phi, h_m) + ZERO_DEGREE_M
    return out


def height_anomaly_grid(lat_deg, lon_deg, h_m: float = 0.0, degree: int = 2190, step_deg: float = 1.0 / 30):
    """Height anomaly ζ at the points from a coarse grid over their extent (ζ varies by centimetres over 2′).

    Parameters
    ----------
    lat_deg, lon_deg : arrays
        Geodetic latitude and longitude of the points (deg), same shape.
    h_m : float
        Ellipsoidal height of the synthesis (m).
    degree : int
        Degree of the synthesis.
    step_deg : float
        Grid step (deg; 2′ by default).

    Returns
    -------
    array
        ζ (m), bilinear from the grid, the shape of ``lat_deg``.
    """
    from scipy.interpolate import RegularGridInterpolator

    la = np.asarray(lat_deg, float)
    lo = np.asarray(lon_deg, float)
    glat = np.arange(np.floor(la.min() / step_deg) - 1, np.ceil(la.max() / step_deg) + 2) * step_deg
    glon = np.arange(np.floor(lo.min() / step_deg) - 1, np.ceil(lo.max() / step_deg) + 2) * step_deg
    gl, go = np.meshgrid(glat, glon, indexing="ij")
    z = height_anomaly_m(gl.ravel(), go.ravel(), h_m, degree).reshape(gl.shape)
    return RegularGridInterpolator((glat, glon), z)(np.column_stack([la.ravel(), lo.ravel()])).reshape(la.shape)


def free_air_anomaly_mgal(dg_mgal, lat_rad, h_m, zeta_m) -> np.ndarray:
    """Free-air anomaly Δg = δg + γ(φ, h) − γ(φ, h − ζ): the disturbance referred to the telluroid.

    Parameters
    ----------
    dg_mgal : array
        Gravity disturbance δg (mGal).
    lat_rad : array
        Latitude (rad).
    h_m : array
        Ellipsoidal height (m).
    zeta_m : array
        Height anomaly ζ (m).

    Returns
    -------
    array
        Δg (mGal).
    """
    from ldvsurvey.nav.earth import MGAL

    return (
        np.asarray(dg_mgal) + (normal_gravity(lat_rad, h_m) - normal_gravity(lat_rad, np.asarray(h_m) - zeta_m)) / MGAL
    )
