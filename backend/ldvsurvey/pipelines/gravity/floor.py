"""The accelerometer drift's share of the repeated-line coincidence (the floor beyond white noise).

The manifest's bias instability (``imu.accel_bias_instability_ug``, stationary σ of a first-order
Gauss–Markov bias, and ``imu.bias_correlation_s``, its correlation time τ) wanders the vertical
accelerometer bias; while driving it is indistinguishable from Δg. Its expected contribution to
the coincidence depends on the very processing: the stop tie (if applied) removes the part the
repeated stops see, the FIR passes the rest (τ ≫ L), the coincidence removes the part common to
all lines at a point, line leveling (if chosen) each line's mean. No closed form covers the stop
geometry, so it is computed by a cheap Monte Carlo of the same processing: GM realisations on
the drive's own time axis (1 Hz; the FIR cut-off is 1/L ≪ 0.5 Hz), the stop means (with the
accelerometer's white noise over each stop) through the same drift estimate, the residual through
the same FIR, lines, common points and coincidence. The result is the RMS over realisations of
the coincidence the drift alone would give (``drift_mgal``); the combined floor is the
root-sum-square with the white-noise floor (independent sources; an RMS statistic, so the
combination is the expectation of ε², not of ε).

A manifest that states no bias instability does not make a drifting accelerometer steady: where the
stop tie was applied (it found drift beyond the stops' noise, or was asked for), the Monte Carlo takes
its Gauss–Markov law from the drift the tie measured (:func:`tied_drift_law`) and says so
(``drift_source``, ``drift_warning``). Where no drift term can be computed although the tie was applied
(fewer than two lines, no common stretch), ``drift_warning`` says the floor is the white one alone.
"""

from __future__ import annotations

import numpy as np
from scipy.signal import lfilter

from ldvsurvey.nav.coincidence import common_points, internal_coincidence
from ldvsurvey.nav.earth import MGAL
from ldvsurvey.nav.gravity import G0, Lowpass
from ldvsurvey.pipelines.gravity.drift import estimate_drift, stop_means
from ldvsurvey.pipelines.gravity.report import leveling_fit

#: Monte Carlo realisations (the spread of the estimate is ~1/√(2·N) relative: ~8 % at 80)
N_REALISATIONS = 80
#: rate of the realisations, Hz
MC_RATE_HZ = 1.0


def tied_drift_law(chain) -> tuple[float, float, str] | None:
    """The Gauss–Markov law (σ in m/s², τ in s) of the drift the stop tie measured, or None without one.

    With four stops or more: the (σ, τ) of greatest likelihood for the tie's drift at the stops
    (:func:`_likeliest_law`): a smooth ramp fits a long τ, which the tie follows, a wander faster than
    the stops a short one. With fewer: σ the RMS about its mean of the tied drift (``chain["drift_mps2"]``,
    linear between the stops: the slow part the stops see, so a lower bound of the process's σ), τ the
    median spacing of the stops (the tie sees the drift change between them, and nothing faster).
    Also the text naming the source."""
    b = chain.get("drift_mps2")
    if b is None:
        return None
    b = np.asarray(b, float)
    stops = stop_means(chain, chain["still"])
    tc = np.sort([s[0] for s in stops])
    if len(stops) >= 4:
        law = _likeliest_law(chain, b, stops)
        if law is not None:
            return law
    sigma = float(np.sqrt(np.mean((b - np.mean(b)) ** 2)))
    if not sigma > 0 or len(tc) < 2:
        return None
    tau = float(np.median(np.diff(tc)))
    text = (
        f"the stop tie's measured drift (RMS {sigma / G0 * 1e6:.2f} µg about its mean, taken as the "
        f"Gauss–Markov σ; τ = the stops' median spacing, {tau:.0f} s)"
    )
    return sigma, tau, text


def _likeliest_law(chain, b, stops) -> tuple[float, float, str] | None:
    """(σ m/s², τ s, text) maximising the Gaussian likelihood of the tie's drift at the stops, their mean
    removed (the level is the log's bias), each stop with its own noise (twice its mean's variance: a
    drift is a difference of two readings); τ from the stops' spacing to ten times the log."""
    tc = np.array([st[0] for st in stops])
    noise = np.array([st[5] if np.isfinite(st[5]) else 0.0 for st in stops])
    t = np.asarray(chain["t_s"], float)[: len(b)]
    d = np.interp(tc, t, b)
    d = d - np.mean(d)
    spacing = float(np.median(np.diff(np.sort(tc))))
    if not np.any(d) or not spacing > 0:
        return None
    n = len(d)
    c = np.eye(n) - 1.0 / n  # the mean removed: the likelihood of the contrasts
    lag = np.abs(tc[:, None] - tc[None, :])
    nz = c @ np.diag(2.0 * noise**2) @ c
    best = None
    for tau in np.geomspace(spacing, 10.0 * float(t[-1] - t[0]), 40):
        r = c @ np.exp(-lag / tau) @ c
        for sigma in np.geomspace(1e-3, 10.0, 60) * float(np.std(d)):
            w, v = np.linalg.eigh(sigma**2 * r + nz)
            keep = w > 1e-12 * w.max()  # the mean's direction carries nothing
            y = v[:, keep].T @ d
            ll = -0.5 * (np.sum(y**2 / w[keep]) + np.sum(np.log(w[keep])))
            if best is None or ll > best[0]:
                best = (ll, float(sigma), float(tau))
    _, sigma, tau = best
    text = (
        f"the stop tie's measured drift at {n} stops (the Gauss–Markov law of greatest likelihood: "
        f"σ {sigma / G0 * 1e6:.2f} µg, τ {tau:.0f} s)"
    )
    return sigma, tau, text


def gauss_markov_1hz(n: int, sigma: float, tau_s: float, dt_s: float, rng) -> np.ndarray:
    """(n,) stationary first-order Gauss–Markov sequence (σ, τ), started from its stationary law."""
    phi = np.exp(-dt_s / tau_s)
    x0 = rng.normal(0.0, sigma)
    w = rng.normal(0.0, sigma * np.sqrt(1.0 - phi**2), n)
    return lfilter([1.0], [1.0, -phi], w, zi=[phi * x0])[0]


def drift_floor(
    log,
    chain,
    res,
    lowpass: Lowpass,
    spacing_m: float,
    *,
    tie_applied: bool,
    leveling: str = "none",
    n_real: int = N_REALISATIONS,
    seed: int = 0,
    bundle: int = 0,
) -> dict:
    """Expected coincidence (mGal) of the manifest's accelerometer bias instability after the processing.

    Parameters
    ----------
    log, chain : DriveLog, dict
        The log (its manifest's bias instability and noise) and its chain (times, stops).
    res : report.Evaluation
        :func:`report.evaluate`'s result (the lines and their samples).
    lowpass, spacing_m : Lowpass, float
        The gravity filter; the spacing of the common along-track points (m).
    tie_applied : bool
        Whether the stop tie was subtracted.
    leveling : {"none", "bias", "linear"}
        The line levelling applied.
    n_real, seed : int
        Monte Carlo realisations and the seed of their generator.
    bundle : int
        Index of ``log`` among the run's logs: its lines are those of ``res`` on that chain.

    Returns
    -------
    dict
        ``drift_mgal`` (None without a drift law: :func:`_drift_law`), its spread over the realisations,
        ``drift_source`` and a ``drift_warning`` where the law is the tie's or the tie's drift is left out.
    """
    imu = log.manifest.imu
    drift_law = _drift_law(imu, chain, tie_applied, bundle)
    if drift_law is None:
        return {
            "drift_mgal": None,
            "drift_source": "manifest gives no imu.accel_bias_instability_ug / "
            "imu.bias_correlation_s: drift not in the floor",
        }
    sig_ug, tau, law, warning = drift_law
    sigma = float(sig_ug) * 1e-6 * G0
    t = chain["t_s"]
    tg = np.arange(t[0], t[-1], 1.0 / MC_RATE_HZ)
    used = [ln for ln in res.lines if ln.has_data and ln.chain == bundle]
    if len(used) < 2:
        return _no_drift_term(
            "fewer than two lines in the " + (f"bundle {bundle + 1}" if bundle else "first bundle"), chain, bundle
        )
    # the filtered drift is smooth at 1/L: the lines' samples thinned to ~the Monte Carlo rate
    step = max(1, int(round(chain.get("fs", 1.0 / float(np.median(np.diff(t[:1000])))) / MC_RATE_HZ)))
    line_t = [(t[ln.samples][::step], ln.along_m[::step]) for ln in used]
    stops = stop_means(chain, chain["still"]) if tie_applied else []
    noise = (imu.accel_noise_ug_per_rthz or 0.0) * 1e-6 * G0
    rng = np.random.default_rng(seed)
    lp = lowpass.at(MC_RATE_HZ)
    tot = []
    for _ in range(n_real):
        b = gauss_markov_1hz(len(tg), sigma, float(tau), 1.0 / MC_RATE_HZ, rng)
        r = b
        if tie_applied and stops:
            cum = np.r_[0.0, np.cumsum(b)]
            y = []
            for tc, la, lo, _, dur, sig in stops:  # the stop mean of b, plus the stop's own noise
                a = np.searchsorted(tg, tc - dur / 2)
                e = max(a + 1, np.searchsorted(tg, tc + dur / 2))
                sig = sig if np.isfinite(sig) else noise / np.sqrt(dur)
                y.append((tc, la, lo, (cum[e] - cum[a]) / (e - a) + rng.normal(0.0, sig), dur))
            est = estimate_drift(y)
            if est is not None:
                r = b - np.interp(tg, est["t_s"], est["drift"])
        f = lp.apply(r)
        try:
            grid, vals = common_points([(s, np.interp(tt, tg, f) / MGAL) for tt, s in line_t], spacing_m)
        except ValueError:
            return _no_drift_term("no common stretch", chain, bundle)
        if leveling in ("bias", "linear"):
            vals = vals - leveling_fit(vals, grid, leveling)
        co = internal_coincidence(vals)
        tot.append(co.total)
    out = {
        "drift_mgal": float(np.sqrt(np.mean(np.square(tot)))),
        "drift_mgal_spread": float(np.std(tot)),
        "accel_bias_instability_ug": float(sig_ug),
        "bias_correlation_s": float(tau),
        "drift_source": f"{law}; Monte Carlo of the same processing ({n_real} Gauss-Markov "
        f"realisations, stop tie {'applied' if tie_applied else 'not applied'}, leveling "
        f"{leveling})",
    }
    if warning:
        out["drift_warning"] = warning
    return out


def _drift_law(imu, chain, tie_applied: bool, bundle: int):
    """(σ µg, τ s, where the law comes from, a warning or None) of the accelerometer drift: the manifest's
    bias instability, else the applied stop tie's measured drift (:func:`tied_drift_law`), else None."""
    sig_ug = getattr(imu, "accel_bias_instability_ug", None)
    tau = getattr(imu, "bias_correlation_s", None)
    if sig_ug and tau:
        return sig_ug, tau, "manifest bias instability", None
    tied = tied_drift_law(chain) if tie_applied else None
    if tied is None:
        return None
    sigma, tau, law = tied
    warning = (
        f"bundle {bundle + 1}: the manifest states no accelerometer bias instability but the stop tie "
        f"measured drift: the drift floor takes its law from {law}"
    )
    return sigma / G0 * 1e6, tau, law, warning


def _no_drift_term(reason: str, chain, bundle: int) -> dict:
    """No drift term (``reason``); a warning when the stop tie measured drift all the same."""
    out = {"drift_mgal": None, "drift_source": reason}
    law = tied_drift_law(chain)
    if law is not None:
        out["drift_warning"] = (
            f"bundle {bundle + 1}: the stop tie measured drift ({law[0] / G0 * 1e6:.2f} µg RMS) but the floor "
            f"has no drift term ({reason}): the white floor alone understates the lines' error"
        )
    return out


def combine(floor: dict, drift: dict) -> dict:
    """The white-noise floor with the drift term beside it and their root-sum-square."""
    out = {**floor, **drift, "white_mgal": floor.get("total_mgal")}
    d = drift.get("drift_mgal")
    w = floor.get("total_mgal")
    out["combined_mgal"] = float(np.hypot(w, d)) if (d is not None and w) else w
    return out
