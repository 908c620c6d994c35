"""One gravity field for the simulator: buried point masses (the ``gravity_field`` effect).

The disturbing potential T(x) = Σ_i GM_i / |x − x_i| lives in a local Cartesian frame
(east e, north n, up u, m) around an origin: e = (λ − λ₀) R cos φ₀, n = (φ − φ₀) R, u = h − h₀
with R = 6 371 000 m (a coordinate definition; the field is exact in these coordinates).
Everything follows from its gradient δg = ∇T (m/s²):

    Δg = −∂T/∂u,    ξ = −(∂T/∂n)/γ,    η = −(∂T/∂e)/γ,

so that g^n = [−γη, −γξ, −(γ+Δg)] (ENU), with γ the normal gravity at the point. A mass below
gives Δg > 0 above it, and north of it ξ > 0 (the zenith tilts away from it).

Realistic construction (:func:`build_field`, from one seed): two *regional* masses 150–300 km
away and 50–100 km deep, scaled so the DOV at the survey centre has a magnitude drawn in
5–30″ (Δg varies smoothly by tens of mGal with it: DOV and Δg are correlated through the one
potential); ``n_local`` *local* masses (excess and deficit) 2–8 km deep within the survey area,
scaled so their Δg peaks near ±20 mGal and the total horizontal Δg gradient over the area
stays ≤ 3 mGal/km. Nothing here uses the product's EGM2008 or DOV code.
"""

from __future__ import annotations

import numpy as np

from ldvsurvey.nav.earth import ARCSEC, MGAL, normal_gravity
from ldvsurvey.sim.effects import GravityFieldSpec

R_M = 6371000.0
G_NEWTON = 6.6743e-11  #: m³/(kg s²), to quote the masses in kg


class PointMassField:
    """Δg, ξ, η of buried point masses; ``masses`` rows are (e_m, n_m, u_m, GM_m3ps2)."""

    def __init__(self, lat0_rad: float, lon0_rad: float, h0_m: float, masses):
        self.lat0_rad, self.lon0_rad, self.h0_m = float(lat0_rad), float(lon0_rad), float(h0_m)
        self.masses = np.asarray(masses, float).reshape(-1, 4)

    def enu(self, lat_rad, lon_rad, h_m):
        """Local coordinates (e, n, u) in m of geodetic points."""
        lat, lon, h = np.broadcast_arrays(
            np.asarray(lat_rad, float), np.asarray(lon_rad, float), np.asarray(h_m, float)
        )
        return ((lon - self.lon0_rad) * R_M * np.cos(self.lat0_rad), (lat - self.lat0_rad) * R_M, h - self.h0_m)

    def potential(self, e, n, u):
        """T (m²/s²) at local coordinates."""
        out = np.zeros(np.shape(e))
        for me, mn, mu, gm in self.masses:
            out = out + gm / np.sqrt((e - me) ** 2 + (n - mn) ** 2 + (u - mu) ** 2)
        return out

    def gradient(self, e, n, u):
        """∇T = (∂T/∂e, ∂T/∂n, ∂T/∂u) in m/s²."""
        ge, gn, gu = np.zeros(np.shape(e)), np.zeros(np.shape(e)), np.zeros(np.shape(e))
        for me, mn, mu, gm in self.masses:
            de, dn, du = e - me, n - mn, u - mu
            r3 = (de * de + dn * dn + du * du) ** 1.5
            ge, gn, gu = ge - gm * de / r3, gn - gm * dn / r3, gu - gm * du / r3
        return ge, gn, gu

    def components(self, lat_rad, lon_rad, h_m):
        """(ξ rad, η rad, Δg m/s²) at geodetic points."""
        e, n, u = self.enu(lat_rad, lon_rad, h_m)
        ge, gn, gu = self.gradient(e, n, u)
        gam = normal_gravity(np.broadcast_to(lat_rad, np.shape(e)), np.broadcast_to(h_m, np.shape(e)))
        return -gn / gam, -ge / gam, -gu

    __call__ = components

    def dg_mgal(self, lat_rad, lon_rad, h_m=None):
        """Δg (mGal) at geodetic points (at the origin height when ``h_m`` is not given)."""
        h = self.h0_m if h_m is None else h_m
        return self.components(lat_rad, lon_rad, np.broadcast_to(h, np.shape(lat_rad)))[2] / MGAL

    def grids(self, lat_deg, lon_deg, h_m: float):
        """ξ, η (arcsec) and Δg (mGal) on a lat × lon grid (ascending degrees) at height h_m."""
        la, lo = np.meshgrid(np.radians(lat_deg), np.radians(lon_deg), indexing="ij")
        xi, eta, dg = self.components(la, lo, np.full(la.shape, h_m))
        return xi / ARCSEC, eta / ARCSEC, dg / MGAL


def build_field(spec: GravityFieldSpec, lat_rad, lon_rad, h_m) -> PointMassField:
    """A realistic point-mass field around a track; see the module text.

    Parameters
    ----------
    spec : GravityFieldSpec
        The field's seed and magnitudes.
    lat_rad, lon_rad, h_m : arrays
        Positions along the track (rad, rad, m).

    Returns
    -------
    PointMassField
        Masses about the track's mean position, ``field(lat_rad, lon_rad, h_m) -> (ξ rad, η rad, Δg m/s²)``.
    """
    rng = np.random.default_rng([spec.seed, 17])
    lat0, lon0 = float(np.mean(lat_rad)), float(np.mean(lon_rad))
    h0 = float(np.mean(h_m))
    probe = PointMassField(lat0, lon0, h0, np.zeros((0, 4)))
    e, n, _ = probe.enu(lat_rad, lon_rad, h_m)
    half = max(3000.0, 0.5 * max(np.ptp(e), np.ptp(n)))
    gam = float(normal_gravity(lat0, h0))
    # regional: two masses far away and deep, scaled to a DOV magnitude drawn in [min, max]
    reg = []
    for _ in range(2):
        az, dist, depth = rng.uniform(0, 2 * np.pi), rng.uniform(150e3, 300e3), rng.uniform(50e3, 100e3)
        reg.append([dist * np.sin(az), dist * np.cos(az), -depth, rng.choice([1.0, -1.0]) * 1e9])
    reg = np.array(reg)
    ge, gn, _ = PointMassField(lat0, lon0, h0, reg).gradient(0.0, 0.0, 0.0)
    target = rng.uniform(spec.dov_min_arcsec, spec.dov_max_arcsec) * ARCSEC * gam
    reg[:, 3] *= target / np.hypot(ge, gn)
    # local: excesses and deficits near the track, each at most ~0.8 of the gradient bound alone
    # (a mass at depth d with peak Δg A has a largest horizontal gradient 0.859 A/d)
    pick = rng.integers(0, len(e), spec.n_local)
    depth = rng.uniform(2e3, 8e3, spec.n_local)
    peak = np.minimum(
        spec.local_dg_mgal * rng.uniform(0.5, 1.0, spec.n_local),
        0.8 * spec.max_gradient_mgal_per_km * depth / 1000.0 / 0.859,
    )
    loc = np.column_stack(
        [
            e[pick] + rng.normal(0, 2e3, spec.n_local),
            n[pick] + rng.normal(0, 2e3, spec.n_local),
            -depth,
            rng.choice([1.0, -1.0], spec.n_local) * peak * MGAL * depth**2,
        ]
    )
    # the horizontal gradient of Δg over the area (regional + local) stays below the bound
    g = np.linspace(-1.2 * half, 1.2 * half, 121)
    ee, nn = np.meshgrid(g, g)
    step = g[1] - g[0]

    def max_grad(ms):
        _, _, gu = PointMassField(lat0, lon0, h0, ms).gradient(ee, nn, 0.0 * ee)
        dgy, dgx = np.gradient(-gu / MGAL, step, step)
        return float(np.max(np.hypot(dgx, dgy))) * 1000.0

    budget = max(spec.max_gradient_mgal_per_km - max_grad(reg), 0.3 * spec.max_gradient_mgal_per_km)
    mg = max_grad(loc)
    if mg > budget:
        loc[:, 3] *= budget / mg * 0.98
    return PointMassField(lat0, lon0, h0, np.vstack([reg, loc]))


def grid_axes(lat_rad, lon_rad, step_arcmin: float, margin_steps: int = 3):
    """Ascending lat/lon axes (deg) covering a track with a margin, on multiples of the step."""
    st = step_arcmin / 60.0
    la, lo = np.degrees(lat_rad), np.degrees(lon_rad)
    lat = np.arange(np.floor(la.min() / st) - margin_steps, np.ceil(la.max() / st) + margin_steps + 1) * st
    lon = np.arange(np.floor(lo.min() / st) - margin_steps, np.ceil(lo.max() / st) + margin_steps + 1) * st
    return lat, lon
