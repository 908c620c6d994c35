"""EGM2008 (or any GeographicLib ``.egm.cof`` model) synthesized on a regional grid.

ξ, η (deflection of the vertical) and Δg (gravity disturbance) from the disturbing potential
T = V_model − U_WGS84 (the normal field's even zonal terms removed, scaled to the model's
GM and radius), evaluated in spherical approximation at the ellipsoid surface:
ξ = (1/(γ r)) ∂T/∂θ, η = −(1/(γ r sinθ)) ∂T/∂λ, Δg = −∂T/∂r  (θ geocentric colatitude).

Fully normalized associated Legendre functions to degree 2190 underflow double precision
away from the equator, so the column recursions start in extended-exponent arithmetic
(Fukushima's X-numbers, base 2^960) and switch to plain doubles once in range.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numba as nb
import numpy as np

from ldvsurvey.nav.earth import A_M, E2, GM, normal_gravity

BIG = 2.0**960
BIGI = 2.0**-960
BIGS = 2.0**480
BIGSI = 2.0**-480
#: WGS-84 fully normalized even zonal coefficients C̄_{2n,0} of the normal potential
WGS84_J2 = 1.08262982131e-3


@dataclass
class Model:
    """Spherical-harmonic coefficients (fully normalized, no Condon-Shortley phase)."""

    name: str
    gm: float
    a: float
    n_max: int
    m_max: int
    c: np.ndarray  # (n_max+1, m_max+1)
    s: np.ndarray


def model_path(name: str = "egm2008") -> Path:
    """Path of the coefficient file ``<name>.egm.cof`` shipped by the ``ssa-data-gravity`` package."""
    import ssa_data_gravity

    return Path(ssa_data_gravity.__file__).parent / "data" / f"{name}.egm.cof"


def _metadata(cof: Path) -> dict:
    meta = {}
    for line in cof.with_suffix("").read_text().splitlines():
        parts = line.split(None, 1)
        if len(parts) == 2 and not line.startswith("#"):
            meta[parts[0]] = parts[1].strip()
    return meta


def load_model(name: str = "egm2008", n_max: int | None = None) -> Model:
    """Read a GeographicLib ``.egm.cof`` (id, N, M, then C̄ and S̄ column-major by order).

    Parameters
    ----------
    name : str
        Model name (the file's stem).
    n_max : int, optional
        Truncate to this degree (and order); default the file's.

    Returns
    -------
    Model
        Fully normalized C̄, S̄ (dimensionless), GM (m³/s²) and reference radius (m) from the
        model's metadata.
    """
    path = model_path(name)
    meta = _metadata(path)
    with open(path, "rb") as fh:
        fh.read(8)
        n_file, m_file = (int(x) for x in np.frombuffer(fh.read(8), dtype="<i4"))
        k = (m_file + 1) * (2 * n_file - m_file + 2) // 2
        c_flat = np.frombuffer(fh.read(8 * k), dtype="<f8")
        s_flat = np.frombuffer(fh.read(8 * (k - (n_file + 1))), dtype="<f8")
    n = n_file if n_max is None else min(n_max, n_file)
    m_cap = min(m_file, n)
    c = np.zeros((n + 1, m_cap + 1))
    s = np.zeros((n + 1, m_cap + 1))
    pos_c = pos_s = 0
    for m in range(m_file + 1):
        cnt = n_file - m + 1
        if m <= m_cap:
            c[m : n + 1, m] = c_flat[pos_c : pos_c + (n - m + 1)]
            if m > 0:
                s[m : n + 1, m] = s_flat[pos_s : pos_s + (n - m + 1)]
        pos_c += cnt
        if m > 0:
            pos_s += cnt
    gm = float(eval(meta.get("ModelMass", "3986004.415e8"), {"__builtins__": {}}))
    a = float(meta.get("ModelRadius", "6378136.3"))
    return Model(name, gm, a, n, m_cap, c, s)


def disturbing_coefficients(model: Model) -> Model:
    """The disturbing potential's coefficients: the model less the WGS-84 normal potential.

    Degrees 0 and 1 are zeroed and the normal field's even zonal terms C̄_{2n,0} (to degree 10),
    scaled to the model's GM and radius, subtracted.

    Parameters
    ----------
    model : Model
        The full model.

    Returns
    -------
    Model
        A copy with the coefficients of T = V_model − U_WGS84.
    """
    c = model.c.copy()
    c[0, 0] = 0.0
    if model.n_max >= 1:
        c[1, :2] = 0.0
    # J2n of the normal field (Heiskanen & Moritz 2-92), fully normalized: C̄_{2n} = −J_{2n}/sqrt(4n+1)
    e = np.sqrt(E2)
    j2 = WGS84_J2
    for k in range(1, 6):
        n = 2 * k
        if n > model.n_max:
            break
        j2n = (-1) ** (k + 1) * 3 * e ** (2 * k) / ((2 * k + 1) * (2 * k + 3)) * (1 - k + 5 * k * j2 / e**2)
        c_norm = -j2n / np.sqrt(4 * k + 1) * (GM / model.gm) * (A_M / model.a) ** n
        c[n, 0] -= c_norm
    return Model(model.name, model.gm, model.a, model.n_max, model.m_max, c, model.s.copy())


@nb.njit(cache=True)
def _xnorm(f, e):
    af = abs(f)
    if af >= BIGS:
        f *= BIGI
        e += 1
    elif af < BIGSI and f != 0.0:
        f *= BIG
        e -= 1
    return f, e


@nb.njit(cache=True)
def _xlsum2(f, x, g, y, ix, iy):
    """f·X + g·Y for X-numbers (x, ix), (y, iy)."""
    idd = ix - iy
    if idd == 0:
        z = f * x + g * y
        iz = ix
    elif idd == 1:
        z = f * x + g * (y * BIGI)
        iz = ix
    elif idd == -1:
        z = g * y + f * (x * BIGI)
        iz = iy
    elif idd > 1:
        z = f * x
        iz = ix
    else:
        z = g * y
        iz = iy
    return _xnorm(z, iz)


@nb.njit(cache=True)
def _x2f(x, ix):
    if ix == 0:
        return x
    if ix == -1:
        return x * BIGI
    if ix < -1:
        return 0.0
    return x * BIG


@nb.njit(cache=True)
def _row_sums(t, u, n_max, m_max, c, s, q):
    """For one colatitude: A_m, B_m sums of C̄, S̄ times P̄_nm q^n (and (n+1) q^n, and dP̄/dθ q^n).

    t = cos θ, u = sin θ, q = a/r. Returns arrays (m_max+1,) for T, ∂T/∂r-type and ∂T/∂θ sums.
    """
    at = np.zeros(m_max + 1)
    bt = np.zeros(m_max + 1)
    ar = np.zeros(m_max + 1)
    br = np.zeros(m_max + 1)
    ad = np.zeros(m_max + 1)
    bd = np.zeros(m_max + 1)
    qn = np.empty(n_max + 2)
    qn[0] = 1.0
    for n in range(1, n_max + 2):
        qn[n] = qn[n - 1] * q
    # sectoral seeds as X-numbers
    pmm = 1.0
    ipmm = 0
    for m in range(0, m_max + 1):
        if m == 1:
            pmm, ipmm = _xnorm(np.sqrt(3.0) * u * pmm, ipmm)
        elif m > 1:
            pmm, ipmm = _xnorm(np.sqrt((2.0 * m + 1.0) / (2.0 * m)) * u * pmm, ipmm)
        # column recursion in n for this m, P̄_{n,m}
        x2, ix2 = pmm, ipmm  # P_{m,m}
        x1, ix1 = 0.0, 0  # P_{m-1,m} = 0

        for n in range(m, n_max + 1):
            if n > m:
                a_nm = np.sqrt((2.0 * n - 1.0) * (2.0 * n + 1.0) / ((n - m) * (n + m)))
                b_nm = np.sqrt((2.0 * n + 1.0) * (n + m - 1.0) * (n - m - 1.0) / ((n - m) * (n + m) * (2.0 * n - 3.0)))
                xn, ixn = _xlsum2(a_nm * t, x2, -b_nm, x1, ix2, ix1)
                x1, ix1 = x2, ix2
                x2, ix2 = xn, ixn
            p = _x2f(x2, ix2)
            p1 = _x2f(x1, ix1) if n > m else 0.0
            if p == 0.0 and p1 == 0.0:
                continue
            cn = c[n, m]
            sn = s[n, m]
            w = qn[n]
            at[m] += cn * p * w
            bt[m] += sn * p * w
            ar[m] += (n + 1.0) * cn * p * w
            br[m] += (n + 1.0) * sn * p * w
            # dP̄_nm/dθ = (n t P̄_nm − sqrt((n²−m²)(2n+1)/(2n−1)) P̄_{n−1,m}) / u
            f = np.sqrt((n * n - m * m) * (2.0 * n + 1.0) / (2.0 * n - 1.0)) if n > m else 0.0
            dp = (n * t * p - f * p1) / u
            ad[m] += cn * dp * w
            bd[m] += sn * dp * w
    return at, bt, ar, br, ad, bd


def synthesize(model: Model, lat_deg: np.ndarray, lon_deg: np.ndarray, h_m: float = 0.0):
    """ξ, η (arcsec) and the gravity disturbance δg = −∂T/∂r (mGal) on the grid lat_deg × lon_deg at
    ellipsoidal height h_m (m).

    δg is the disturbance at the point (g_P − γ_P), not the free-air anomaly Δg (which refers γ to the
    telluroid, :func:`ldvsurvey.nav.gravmodel.free_air_anomaly_mgal`).

    Parameters
    ----------
    model : Model
        Disturbing-potential coefficients (:func:`disturbing_coefficients`).
    lat_deg, lon_deg : (n_lat,), (n_lon,) arrays
        Geodetic latitudes and longitudes of the grid (deg).
    h_m : float
        Ellipsoidal height (m).

    Returns
    -------
    xi_arcsec, eta_arcsec, dg_mgal : (n_lat, n_lon) arrays
        ξ, η (arcsec) and δg (mGal).
    """
    lat = np.radians(np.asarray(lat_deg, float))
    lon = np.radians(np.asarray(lon_deg, float))
    m = np.arange(model.m_max + 1)
    cos_ml = np.cos(np.outer(lon, m))
    sin_ml = np.sin(np.outer(lon, m))
    xi = np.empty((len(lat), len(lon)))
    eta = np.empty_like(xi)
    dg = np.empty_like(xi)
    c = np.ascontiguousarray(model.c)
    s = np.ascontiguousarray(model.s)
    for i, phi in enumerate(lat):
        sl, cl = np.sin(phi), np.cos(phi)
        rn = A_M / np.sqrt(1 - E2 * sl * sl)
        x = (rn + h_m) * cl
        z = (rn * (1 - E2) + h_m) * sl
        r = np.hypot(x, z)
        theta = np.arctan2(x, z)  # geocentric colatitude
        t, u = np.cos(theta), np.sin(theta)
        at, bt, ar, br, ad, bd = _row_sums(t, u, model.n_max, model.m_max, c, s, model.a / r)
        k = model.gm / r
        dt_dth = k * (cos_ml @ ad + sin_ml @ bd)  # ∂T/∂θ
        dt_dl = k * (sin_ml @ (-m * at) + cos_ml @ (m * bt))  # ∂T/∂λ
        dg_r = k / r * (cos_ml @ ar + sin_ml @ br)  # −∂T/∂r
        gam = normal_gravity(phi, h_m)
        xi[i] = dt_dth / (gam * r)
        eta[i] = -dt_dl / (gam * r * u)
        dg[i] = dg_r
    arcsec = np.pi / 180 / 3600
    return xi / arcsec, eta / arcsec, dg / 1e-5
