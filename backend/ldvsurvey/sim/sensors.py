"""Sensor models of the simulator: IMU errors, LDV (1-D, 2-D, water) and GNSS fixes.

In the ideal scenarios the LDV head frame d is the travel frame: the vehicle moves along the
head's forward axis (the LDV model's no-side-slip assumption); the IMU body is mounted on it with
C_d^b(η_L, φ_L). With the body-attitude effect (``body.py``) the head is fixed in the body and the
travel direction moves in it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ldvsurvey.nav.earth import radii
from ldvsurvey.nav.errmodel import c_db
from ldvsurvey.sim.imu import rates
from ldvsurvey.sim.motion import Motion
from ldvsurvey.units import G0_MPS2 as G0  # noqa: E402
from ldvsurvey.units import RAD_PER_DEG as DEG  # noqa: E402  (rad per degree)

#: fix quality -> total (horizontal σ, vertical σ) in m of the simulated receiver
FIX_SIGMA = {4: (0.02, 0.03), 5: (0.15, 0.25), 2: (0.5, 0.9), 1: (2.0, 3.5)}
#: epoch-to-epoch white part (horizontal σ, vertical σ) in m (carrier-smoothed receiver noise);
#: the rest of FIX_SIGMA is a first-order Gauss-Markov error with correlation time GNSS_CORR_S
#: (multipath, atmosphere and orbit errors wander slowly)
FIX_WHITE = {4: (0.01, 0.015), 5: (0.03, 0.05), 2: (0.1, 0.15), 1: (0.2, 0.3)}
GNSS_CORR_S = 300.0


@dataclass
class ImuErrors:
    """Sensor-frame IMU errors: constant biases and white noise (ARW, VRW)."""

    gyro_bias_rps: np.ndarray
    accel_bias_mps2: np.ndarray
    arw_psd: float = 0.0  # rad²/s
    vrw_psd: float = 0.0  # (m/s)²/s

    @classmethod
    def draw(cls, rng, gyro_bias_dph, accel_bias_ug, arw_dprh=0.0, vrw_ug_rthz=0.0):
        """Biases of the given magnitude in random directions (each axis ± the magnitude)."""
        gb = rng.choice([-1.0, 1.0], 3) * gyro_bias_dph * DEG / 3600.0
        ab = rng.choice([-1.0, 1.0], 3) * accel_bias_ug * 1e-6 * G0
        return cls(gb, ab, (arw_dprh * DEG / 60.0) ** 2, (vrw_ug_rthz * 1e-6 * G0) ** 2)

    def apply(self, dtheta, dvel, dt_s, rng):
        """Increments with the biases and white noise added.

        Parameters
        ----------
        dtheta, dvel : (N, 3) arrays
            Angle (rad) and velocity (m/s) increments.
        dt_s : float
            Sampling interval (s).
        rng : numpy.random.Generator
            Noise generator.

        Returns
        -------
        dtheta, dvel : (N, 3) arrays
            The measured increments (rad, m/s).
        """
        n = len(dtheta)
        dth = dtheta + self.gyro_bias_rps * dt_s
        dv = dvel + self.accel_bias_mps2 * dt_s
        if self.arw_psd > 0:
            dth = dth + rng.normal(0.0, np.sqrt(self.arw_psd * dt_s), (n, 3))
        if self.vrw_psd > 0:
            dv = dv + rng.normal(0.0, np.sqrt(self.vrw_psd * dt_s), (n, 3))
        return dth, dv


@dataclass
class LdvSpecSim:
    """Simulated LDV: true mounting (rad), scale factors, lever arm (m, body), noise σ (m/s)."""

    pitch_rad: float = 0.0
    heading_rad: float = 0.0
    scale: float = 1.0
    scale_up: float = 1.0
    lever_arm_m: tuple = (0.0, 0.0, -0.8)
    noise_mps: float = 0.005
    kind: str = "2d"

    def c_bt(self) -> np.ndarray:
        """C_b^t = (C_d^b)ᵀ: body to travel (= LDV head) frame."""
        return c_db(self.pitch_rad, self.heading_rad).T


def ldv_measure(motion: Motion, t_s, spec: LdvSpecSim, rng, current_n=None, body=None):
    """Forward and up speeds along the LDV head's axes, with scale factor and white noise.

    Parameters
    ----------
    motion : Motion
        The vehicle's timeline.
    t_s : (N,) array
        Sample times (s).
    spec : LdvSpecSim
        The LDV (mounting rad, scale factors, lever arm m, noise σ m/s).
    rng : numpy.random.Generator
        Noise generator.
    current_n : (N, 3) array, optional
        Water velocity to subtract (ENU, m/s; a water-track LDV).
    body : BodyModel, optional
        The vehicle body's attitude (the head frame then is fixed in the body, no longer the travel frame).

    Returns
    -------
    v_fwd, v_up : (N,) arrays
        Measured forward and up speed (m/s).
    """
    c_bt = spec.c_bt() if body is None else body
    _, _, tr, c_bn, _, w_nb_b, _ = rates(motion, np.asarray(t_s, float), c_bt)
    lever = np.asarray(spec.lever_arm_m, float)
    v_head = tr["v_n"] + np.einsum("kij,kj->ki", c_bn, np.cross(w_nb_b, lever))
    if current_n is not None:
        v_head = v_head - current_n
    c_dn = tr["c_tn"] if body is None else c_bn @ c_db(spec.pitch_rad, spec.heading_rad)
    v_d = np.einsum("kji,kj->ki", c_dn, v_head)
    n = len(v_d)
    v_fwd = spec.scale * v_d[:, 1] + rng.normal(0, spec.noise_mps, n)
    v_up = spec.scale_up * v_d[:, 2] + rng.normal(0, spec.noise_mps, n)
    return v_fwd, v_up


def gnss_fixes(motion: Motion, t_s, c_bt, lever_arm_m, fix_of_t, rng, white_only: bool = False, extra_enu_m=None):
    """Antenna fixes with fix-dependent errors (white plus Gauss-Markov, see FIX_SIGMA and FIX_WHITE).

    Parameters
    ----------
    motion : Motion
        The vehicle's timeline.
    t_s : (N,) array
        Fix times (s).
    c_bt : (3, 3) array or callable
        Constant C_b^t or a body model (see :func:`ldvsurvey.sim.imu.rates`).
    lever_arm_m : (3,) sequence
        Antenna lever arm in the body (right, forward, up; m), rotated by the true body attitude.
    fix_of_t : callable
        ``fix_of_t(t) -> int array``: the fix quality (GGA code, 0 = no fix) at each time.
    rng : numpy.random.Generator
        Noise generator.
    white_only : bool
        Make the whole error white (σ from FIX_SIGMA).
    extra_enu_m : (N, 3) array, optional
        Further errors (ENU, m; multipath jumps).

    Returns
    -------
    lat_deg, lon_deg : (N,) arrays
        Latitude and longitude (deg; NaN without a fix).
    h_m : (N,) array
        Ellipsoidal height (m; NaN without a fix).
    fix : (N,) int array
        Fix quality.
    """
    t = np.asarray(t_s, float)
    _, _, tr, c_bn, _, _, _ = rates(motion, t, c_bt)
    lev = np.einsum("kij,j->ki", c_bn, np.asarray(lever_arm_m, float))
    fix = np.asarray(fix_of_t(t), dtype=int)
    sig = np.array(
        [[FIX_SIGMA.get(int(f), (np.nan, np.nan))[0]] * 2 + [FIX_SIGMA.get(int(f), (np.nan, np.nan))[1]] for f in fix]
    )
    wsig = np.array([[FIX_WHITE.get(int(f), (0.0, 0.0))[0]] * 2 + [FIX_WHITE.get(int(f), (0.0, 0.0))[1]] for f in fix])
    csig = np.sqrt(np.maximum(sig**2 - wsig**2, 0.0))
    if white_only:  # the whole σ white (filter-consistency tests need the filter's own noise model)
        wsig, csig = sig, 0.0 * sig
    # unit-variance Gauss-Markov sequences, scaled by the current fix's correlated σ
    gm = np.empty((len(t), 3))
    gm[0] = rng.normal(0, 1, 3)
    phi = np.exp(-np.diff(t, prepend=t[0]) / GNSS_CORR_S)
    drive = rng.normal(0, 1, (len(t), 3))
    for k in range(1, len(t)):
        gm[k] = phi[k] * gm[k - 1] + np.sqrt(1 - phi[k] ** 2) * drive[k]
    noise = wsig * rng.normal(0, 1, (len(t), 3)) + csig * gm
    if extra_enu_m is not None:
        noise = noise + extra_enu_m
    rm, rn = radii(tr["lat_rad"])
    e = lev[:, 0] + noise[:, 0]
    nn = lev[:, 1] + noise[:, 1]
    lat = tr["lat_rad"] + nn / (rm + tr["h_m"])
    lon = tr["lon_rad"] + e / ((rn + tr["h_m"]) * np.cos(tr["lat_rad"]))
    h = tr["h_m"] + lev[:, 2] + noise[:, 2]
    none = fix <= 0
    lat, lon, h = (np.where(none, np.nan, a) for a in (lat, lon, h))
    return np.degrees(lat), np.degrees(lon), h, fix
