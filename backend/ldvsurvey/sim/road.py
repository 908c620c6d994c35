"""A road: heading, grade and bank as smooth functions of arc length s, and its geodetic track.

Every shape is a sum of smooth steps S(u) = u − sin(2πu)/(2π) (rate continuous, with
continuous first derivative), so the simulated motion has smooth angular rates.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.integrate import solve_ivp

from ldvsurvey.nav.earth import radii

TWO_PI = 2.0 * np.pi


def smooth_step(u):
    """S(u), S'(u), S''(u) of the smooth step on [0, 1] (0 before, 1 after)."""
    u = np.asarray(u, dtype=float)
    inside = (u > 0) & (u < 1)
    s = np.where(u >= 1, 1.0, np.where(inside, u - np.sin(TWO_PI * u) / TWO_PI, 0.0))
    d1 = np.where(inside, 1.0 - np.cos(TWO_PI * u), 0.0)
    d2 = np.where(inside, TWO_PI * np.sin(TWO_PI * u), 0.0)
    return s, d1, d2


def smooth_step_integral(u):
    """∫₀ᵘ S(x) dx (for distance under a smooth speed ramp)."""
    u = np.asarray(u, dtype=float)
    uc = np.clip(u, 0.0, 1.0)
    inner = uc**2 / 2 + (np.cos(TWO_PI * uc) - 1.0) / TWO_PI**2
    return inner + np.where(u > 1, u - 1.0, 0.0)


@dataclass
class Ramps:
    """f(x) = f0 + Σ Δ_i S((x − x_i)/L_i): a smoothly stepped profile."""

    f0: float = 0.0
    steps: list[tuple[float, float, float]] = field(default_factory=list)  # (x_start, length, delta)

    def eval(self, x):
        """f, f', f'' at x (each ramp touches only the points inside it)."""
        x = np.asarray(x, dtype=float)
        flat = x.ravel()
        order = np.argsort(flat, kind="stable")
        xs = flat[order]
        f = np.full(xs.shape, self.f0)
        d1 = np.zeros(xs.shape)
        d2 = np.zeros(xs.shape)
        for x0, length, delta in self.steps:
            a = np.searchsorted(xs, x0, side="right")
            b = np.searchsorted(xs, x0 + length, side="left")
            f[b:] += delta
            if b > a:
                s, s1, s2 = smooth_step((xs[a:b] - x0) / length)
                f[a:b] += delta * s
                d1[a:b] += delta * s1 / length
                d2[a:b] += delta * s2 / length**2
        out = []
        for arr in (f, d1, d2):
            r = np.empty_like(arr)
            r[order] = arr
            out.append(r.reshape(x.shape))
        return tuple(out)


@dataclass
class Road:
    """Road geometry along arc length s (m) from a start point.

    Attributes
    ----------
    lat0_rad, lon0_rad, h0_m : start of the road.
    heading : Ramps of the road heading ψ_r(s), rad (clockwise from north).
    grade : Ramps of the road pitch θ_r(s), rad.
    bank : Ramps of the road roll γ_r(s), rad.
    length_m : road length.
    """

    lat0_rad: float
    lon0_rad: float
    h0_m: float
    length_m: float
    heading: Ramps
    grade: Ramps = field(default_factory=Ramps)
    bank: Ramps = field(default_factory=Ramps)

    def __post_init__(self):
        self._sol = None

    def tangent(self, s):
        """Unit tangent T(s) in ENU and dT/ds."""
        psi, dpsi, _ = self.heading.eval(s)
        th, dth, _ = self.grade.eval(s)
        cp, sp, ct, st = np.cos(psi), np.sin(psi), np.cos(th), np.sin(th)
        t = np.stack([sp * ct, cp * ct, st], axis=-1)
        dt = np.stack([cp * ct * dpsi - sp * st * dth, -sp * ct * dpsi - cp * st * dth, ct * dth], axis=-1)
        return t, dt

    def _rhs(self, s, y):
        lat, _lon, h = y
        t, _ = self.tangent(np.array(s))
        rm, rn = radii(lat)
        return [t[1] / (rm + h), t[0] / ((rn + h) * np.cos(lat)), t[2]]

    def geodetic(self, s):
        """(lat_rad, lon_rad, h_m) along the road at arc length(s) s, from a tight ODE solution."""
        if self._sol is None:
            self._sol = solve_ivp(
                self._rhs,
                (0.0, self.length_m),
                [self.lat0_rad, self.lon0_rad, self.h0_m],
                method="DOP853",
                rtol=1e-13,
                atol=[1e-16, 1e-16, 1e-9],
                dense_output=True,
                max_step=200.0,
            )
        s = np.asarray(s, dtype=float)
        if np.any(s < -1e-6) or np.any(s > self.length_m + 1e-6):
            raise ValueError("arc length outside the road")
        y = self._sol.sol(s.ravel())
        return y[0].reshape(s.shape), y[1].reshape(s.shape), y[2].reshape(s.shape)
