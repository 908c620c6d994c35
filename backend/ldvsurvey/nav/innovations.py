"""Consistency of a filter's measurement model from its own innovations.

A Kalman filter whose measurement errors are white and whose variances are right produces
normalized innovations ν/√S that are white with unit variance. Real GNSS position errors are not
white: the correlated part (atmosphere, multipath, orbit) changes over minutes, and a jump of a few
decimetres can persist for a minute. Modelled as white, such errors make every GNSS epoch look like
new information, and the 1-σ of any parameter the filter draws from the GNSS track (LDV heading,
scale, pitch) comes out too small by about √(s²·τ), with s² the variance of the normalized
innovations and τ their integrated autocorrelation time in epochs (the number of correlated epochs
that carry the information of one independent epoch). :func:`variance_inflation` measures that
factor from the innovations; multiplying the parameter covariance by it is the standard
effective-sample-size correction (first-order: exact for parameters that average the measurement
errors, conservative for those set by the ends of a track).
"""

from __future__ import annotations

import numpy as np


def integrated_autocorrelation(x: np.ndarray, max_lag: int | None = None) -> float:
    """τ = 1 + 2 Σ_k ρ_k over the initial positive sequence of the sample autocorrelation ρ_k
    (Geyer's truncation: the sum stops at the first lag whose ρ is not positive), in samples.

    ``x``: a series of samples (NaN dropped; treated as equally spaced). Fewer than 20 samples: 1.
    """
    x = np.asarray(x, float)
    x = x[np.isfinite(x)]
    n = len(x)
    if n < 20:
        return 1.0
    x = x - x.mean()
    var = float(np.dot(x, x)) / n
    if var <= 0:
        return 1.0
    m = min(n // 4, max_lag if max_lag is not None else n // 4)
    f = np.fft.rfft(x, 2 * n)
    acf = np.fft.irfft(f * np.conj(f))[: m + 1] / (n * var)
    tau = 1.0
    for k in range(1, m + 1):
        if acf[k] <= 0:
            break
        tau += 2.0 * acf[k]
    return float(tau)


def variance_inflation(nu: np.ndarray, gate: float = 5.0) -> dict:
    """Covariance inflation factor (≥ 1) from normalized innovations ``nu`` (one component, NaN
    where there was no measurement): s² · τ, with s² = mean(ν²) over |ν| ≤ ``gate`` (the rows the
    filter accepted) and τ their integrated autocorrelation time.

    Returns ``{"factor", "nis_variance", "corr_epochs", "n"}``.
    """
    v = np.asarray(nu, float)
    v = v[np.isfinite(v)]
    v = v[np.abs(v) <= gate]
    if len(v) < 20:
        return {"factor": 1.0, "nis_variance": None, "corr_epochs": None, "n": int(len(v))}
    s2 = float(np.mean(v**2))
    tau = integrated_autocorrelation(v)
    return {"factor": float(max(1.0, s2 * tau)), "nis_variance": s2, "corr_epochs": tau, "n": int(len(v))}
