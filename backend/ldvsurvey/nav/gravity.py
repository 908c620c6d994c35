"""Strapdown gravity disturbance (methods §4, with the sign of the gravimetry paper's eq. 2 corrected).

δg = f_U − v̇_U − γ(L, h) + (v_E/(R_N+h) + 2ω_ie cos L) v_E + v_N²/(R_M+h)

f_U is the up component of C_b^n f^b, v̇_U the vertical acceleration from the aiding velocity
(LDV or GNSS). Then a window-based zero-phase FIR low-pass (Blackman, ``firwin(2·L·fs taps,
cutoff 1/L Hz)`` applied forward and backward as in filtfilt), NaN-aware so gaps do not smear.
All inputs in SI units; outputs in m/s² unless the name says mGal.
"""

from __future__ import annotations

import numpy as np
from scipy.signal import firwin, oaconvolve

from ldvsurvey.nav.earth import MGAL, OMEGA_IE, normal_gravity, radii


def disturbance_mps2(f_u, vdot_u, v_e, v_n, lat_rad, h_m):
    """Gravity disturbance δg (m/s²) from the up specific force and the vehicle motion.

    Parameters
    ----------
    f_u : up component of the specific force in n, m/s².
    vdot_u : vertical acceleration of the vehicle, m/s².
    v_e, v_n : east and north velocity, m/s. lat_rad : latitude. h_m : ellipsoidal height, m.
    """
    rm, rn = radii(lat_rad)
    return (f_u - vdot_u - normal_gravity(lat_rad, h_m) + (v_e / (rn + h_m) + 2 * OMEGA_IE * np.cos(lat_rad)) * v_e
            + v_n ** 2 / (rm + h_m))


def fir_taps(length_s: float, fs_hz: float) -> np.ndarray:
    """Blackman-window low-pass, 2·L·fs (+1, odd) taps, cut-off 1/L Hz (one pass)."""
    n = int(round(2 * length_s * fs_hz))
    n += 1 - n % 2
    return firwin(n, 1.0 / length_s, window="blackman", fs=fs_hz)


def zero_phase_lowpass(x, length_s: float, fs_hz: float, min_weight: float = 0.5, weights=None):
    """Forward-backward FIR (as filtfilt) of a regularly sampled series; NaN samples are gaps.

    The filter is applied to the data and to the valid-sample mask and the two are divided,
    so gaps are bridged by the neighbours (normalized convolution). Optional ``weights``
    (e.g. 1/σ²) let better samples dominate; they are scaled to a maximum of 1. Output is NaN
    where the valid weight under the (doubled) filter is below ``min_weight``.
    """
    x = np.asarray(x, dtype=float)
    h = fir_taps(length_s, fs_hz)
    h2 = oaconvolve(h, h[::-1])  # forward then backward = one zero-phase pass with h ⋆ h
    ok = np.isfinite(x)
    w = ok.astype(float)
    if weights is not None:
        w = w * np.nan_to_num(np.asarray(weights, float))
        w = w / max(float(w.max()), 1e-300)
    num = oaconvolve(np.where(ok, x, 0.0) * w, h2, mode="same")
    den = oaconvolve(w, h2, mode="same")
    with np.errstate(invalid="ignore", divide="ignore"):
        y = num / den
    y[den < min_weight] = np.nan
    return y


def half_wavelength_resolution_m(speed_mps: float, length_s: float) -> float:
    """Spatial half-wavelength at the FIR cut-off 1/L: v·L/2 (m)."""
    return 0.5 * speed_mps * length_s


def to_mgal(x):
    return np.asarray(x) / MGAL
