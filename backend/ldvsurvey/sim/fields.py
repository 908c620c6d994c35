"""Synthetic gravity fields for the simulator: Δg and DOV as functions of position."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ldvsurvey.nav.earth import MGAL, radii


@dataclass
class SinusoidField:
    """Δg = Σ A_k sin(2π (e cos θ_k + n sin θ_k)/λ_k + p_k) around an origin; no deflection.

    Terms are (amplitude mGal, wavelength m, direction rad, phase rad). The largest horizontal
    gradient is bounded by Σ 2π A_k / λ_k (mGal/m).
    """

    lat0_rad: float
    lon0_rad: float
    terms: list[tuple[float, float, float, float]]
    offset_mgal: float = 0.0

    def _en(self, lat, lon):
        rm, rn = radii(self.lat0_rad)
        return (lon - self.lon0_rad) * rn * np.cos(self.lat0_rad), (lat - self.lat0_rad) * rm

    def dg_mgal(self, lat_rad, lon_rad):
        """Δg (mGal) at latitude, longitude (rad), any shape."""
        e, n = self._en(np.asarray(lat_rad, float), np.asarray(lon_rad, float))
        out = np.full(np.shape(e), self.offset_mgal)
        for a, lam, th, ph in self.terms:
            out = out + a * np.sin(2 * np.pi * (e * np.cos(th) + n * np.sin(th)) / lam + ph)
        return out

    def max_gradient_mgal_per_km(self) -> float:
        """Bound of the largest horizontal gradient of Δg, Σ 2π A_k / λ_k (mGal/km)."""
        return float(sum(2 * np.pi * a / lam for a, lam, _, _ in self.terms) * 1000.0)

    def __call__(self, lat_rad, lon_rad, h_m):
        """ξ, η (rad, zero) and Δg (m/s²) at latitude, longitude (rad) and height (m)."""
        dg = self.dg_mgal(lat_rad, lon_rad) * MGAL
        z = np.zeros_like(dg)
        return z, z, dg


@dataclass
class ConstantField:
    """Constant Δg (mGal) and deflection ξ, η (rad) everywhere."""

    dg_mgal: float = 0.0
    xi_rad: float = 0.0
    eta_rad: float = 0.0

    def __call__(self, lat_rad, lon_rad, h_m):
        one = np.ones(np.shape(lat_rad))
        return self.xi_rad * one, self.eta_rad * one, self.dg_mgal * MGAL * one
