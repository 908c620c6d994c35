"""Accelerometer drift from repeated stops at the same places (the relative gravimeter's drift tie).

The vertical accelerometer's in-run bias wanders (bias instability) and is not separable from Δg
while driving. Standing still, the vehicle's acceleration is known to be zero, so the mean of
f_U − γ over a stop is Δg at that spot plus the bias at that time. Spots visited more than once
(the turnarounds of repeated lines, the start) tie the bias: with y_k the stop means and G_l the
unknown Δg (+ constant bias) of spot l, the drift at stop k is b_k = y_k − G_l(k). The G_l are the
least-squares choice that makes the drift a smoothest random walk, Σ (b_k − b_{k−1})²/Δt_k, with
b = 0 at the first stop (the level of the first stop is kept: a constant offset stays
unobservable without an absolute tie). Between stops the drift is interpolated linearly.
"""

from __future__ import annotations

import numpy as np
from scipy.stats import chi2 as chi2_dist

from ldvsurvey.nav.earth import MGAL
from ldvsurvey.pipelines.stages.aids import local_metres
from ldvsurvey.units import G0_MPS2

#: stops shorter than this (after trimming their edges) are not used, s
MIN_STOP_S = 10.0
#: trimmed at both ends of a stop (braking, starting), s
STOP_EDGE_S = 2.0
#: stops closer than this are the same spot, m
SAME_SPOT_M = 30.0


#: the σ of a stop's mean is measured on means over blocks of this length (s): a few seconds, so that
#: slow disturbances of a standing vehicle (rocking, wind, people moving in it), which correlate
#: neighbouring 1-s means and hide from their scatter, show in it
STOP_BLOCK_S = 3.0
#: fewest blocks whose scatter is used; a shorter stop takes the white-noise floor alone
STOP_MIN_BLOCKS = 4


def white_stop_sigma(noise_ug_rthz, duration_s) -> float:
    """σ (m/s²) of a T-second mean of white accelerometer noise of density ``noise_ug_rthz`` (µg/√Hz): N/√T;
    NaN when no density is given."""
    if not noise_ug_rthz:
        return float("nan")
    return float(noise_ug_rthz * 1e-6 * G0_MPS2 / np.sqrt(duration_s))


def stop_sigma(t_s, x, duration_s, bridges=(), noise_ug_rthz=None):
    """σ (m/s²) of the mean of ``x`` over a stop, measured on the data, floored, plus its lost IMU rows.

    The means over :data:`STOP_BLOCK_S` blocks scatter about the stop's mean; their standard deviation
    over √(number of blocks) is the σ of the mean whatever the noise's colour below the block length.
    From a handful of blocks that estimate is itself uncertain (and chance can make it small), so it
    is floored at what the accelerometer's white noise alone gives the mean, N/√T (N the manifest's
    ``noise_ug_rthz`` in µg/√Hz, T = ``duration_s``); a stop of fewer than :data:`STOP_MIN_BLOCKS`
    blocks takes the floor alone (NaN without N). Each lost IMU run bridged inside the stop (σ_g of its
    up velocity, m/s; see :func:`chains.lost_increment_sigmas`) adds σ_g/T to the mean over T seconds."""
    floor = white_stop_sigma(noise_ug_rthz, duration_s)
    nb = int(np.floor(duration_s / STOP_BLOCK_S))
    if nb < STOP_MIN_BLOCKS:
        var = floor**2
    else:
        j = np.minimum(((t_s - t_s[0]) / (duration_s / nb)).astype(int), nb - 1)
        cnt = np.bincount(j, minlength=nb)
        good = cnt > 0
        means = np.bincount(j, weights=x, minlength=nb)[good] / cnt[good]
        var = float(np.var(means, ddof=1) / good.sum())
        if np.isfinite(floor):
            var = max(var, floor**2)
    if not np.isfinite(var):
        return float("nan")
    for t_g, _dur, sig in bridges:
        if t_s[0] <= t_g <= t_s[-1] and np.isfinite(sig):
            var += (sig / duration_s) ** 2
    return float(np.sqrt(var))


def stop_means(chain, still):
    """(t_s, lat, lon, mean f_U − γ in m/s², duration s, σ of the mean in m/s²) of every usable stop.

    The σ is the data's, floored at the white noise of the chain's ``accel_noise_ug_rthz`` (the
    manifest's, µg/√Hz; :func:`stop_sigma`)."""
    out = []
    t = chain["t_s"]
    for a, b in still:
        a, b = a + STOP_EDGE_S, b - STOP_EDGE_S
        if b - a < MIN_STOP_S:
            continue
        k = (t >= a) & (t <= b) & np.isfinite(chain["dg_static"])
        if k.sum() < 10:
            continue
        x = chain["dg_static"][k]
        out.append(
            (
                0.5 * (a + b),
                float(np.mean(chain["lat"][k])),
                float(np.mean(chain["lon"][k])),
                float(np.mean(x)),
                float(b - a),
                stop_sigma(t[k], x, float(b - a), chain.get("imu_bridges") or (), chain.get("accel_noise_ug_rthz")),
            )
        )
    return out


def estimate_drift(stops):
    """Drift b_k (m/s²) at the stops and the spot index of each; None when no spot is visited twice.

    The estimate is linear in the stop means y: b = M y. Where the stops carry their σ (the sixth
    element, :func:`stop_means`), ``drift_sigma`` is the 1-σ of every b_k from M diag(σ²) Mᵀ (0 at the
    first stop, whose level is kept by definition)."""
    est = _estimate_drift(stops)
    if est is None or len(stops[0]) < 6:
        return est
    sig = np.array([s[5] for s in stops], float)
    if not np.all(np.isfinite(sig)):
        return est
    y = np.array([s[3] for s in stops], float)
    m = np.empty((len(y), len(y)))
    for i in range(len(y)):  # the columns of M: the estimate of unit stop means (the spots stay)
        e = [(*s[:3], float(j == i), s[4]) for j, s in enumerate(stops)]
        m[:, i] = _estimate_drift(e)["drift"]
    cov = (m * sig**2) @ m.T
    est["drift_sigma"] = np.sqrt(np.diag(cov))
    est["drift"] = m @ y
    # is there drift at all? χ² of the drifts against their own covariance (rank: the stops less the spots)
    dof = int(np.linalg.matrix_rank(cov, tol=1e-9 * float(np.max(np.diag(cov)) or 1.0)))
    if dof > 0:
        est["chi2"] = float(est["drift"] @ np.linalg.pinv(cov, rcond=1e-9, hermitian=True) @ est["drift"])
        est["dof"] = dof
    return est


def _estimate_drift(stops):
    if len(stops) < 2:
        return None
    lat0, lon0 = stops[0][1], stops[0][2]
    e, n = local_metres(lat0, lon0, np.array([s[1] for s in stops]), np.array([s[2] for s in stops]))
    spot = np.full(len(stops), -1)
    centres = []
    for k in range(len(stops)):
        for j, (ce, cn) in enumerate(centres):
            if np.hypot(e[k] - ce, n[k] - cn) < SAME_SPOT_M:
                spot[k] = j
                break
        else:
            centres.append((e[k], n[k]))
            spot[k] = len(centres) - 1
    if np.bincount(spot).max() < 2:
        return None
    y = np.array([s[3] for s in stops])
    t = np.array([s[0] for s in stops])
    n_spot = len(centres)
    # unknowns: G of every spot except the first stop's (fixed so that b_0 = 0)
    free = [j for j in range(n_spot) if j != spot[0]]
    col = {j: i for i, j in enumerate(free)}
    rows, rhs = [], []
    for k in range(1, len(stops)):
        if spot[k] == spot[k - 1]:
            continue
        w = 1.0 / np.sqrt(max(t[k] - t[k - 1], 1.0))
        r = np.zeros(len(free))
        d = y[k] - y[k - 1]
        for j, sign in ((spot[k], 1.0), (spot[k - 1], -1.0)):
            if j == spot[0]:
                d -= sign * y[0]
            else:
                r[col[j]] += sign
        rows.append(w * r)
        rhs.append(w * d)
    g = np.zeros(n_spot)
    g[spot[0]] = y[0]
    if free and rows:
        sol, *_ = np.linalg.lstsq(np.array(rows), np.array(rhs), rcond=None)
        for j in free:
            g[j] = sol[col[j]]
    return {"t_s": t, "drift": y - g[spot], "spot": spot, "n_spots": n_spot}


#: "auto" applies the tie only when the drift range exceeds this many σ of a stop-to-stop difference
SIGNIFICANT_SIGMA = 4.0


def drift_correction(chain, still, noise_ug_rthz=None, mode="auto"):
    """Estimate the drift from the chain's stops; returns (drift at the chain's times in m/s², report).

    ``mode`` "stops" always applies it; "auto" only when the drift range is significant against
    the stops' own white noise (accelerometer density over each stop's duration): tying a
    drift-free accelerometer to noisy stops would only add their noise to every line."""
    stops = stop_means(chain, still)
    est = estimate_drift(stops)
    if est is None:
        return None, {"method": "none", "reason": "no spot where the vehicle stood still twice", "n_stops": len(stops)}
    b = np.interp(chain["t_s"], est["t_s"], est["drift"])
    # the stops' σ from their own data (the manifest's density over each stop's duration where the
    # data gives none): a stop with a bridged IMU gap or a noisy engine says so itself
    sig = np.array([s[5] for s in stops], float)
    if noise_ug_rthz:
        dur = np.array([s[4] for s in stops])
        sig = np.where(np.isfinite(sig), sig, [white_stop_sigma(noise_ug_rthz, d) for d in dur])
    sigma = float(np.sqrt(np.nanmean(sig**2)) / MGAL) if np.isfinite(sig).any() else None
    rng_mgal = float(np.ptp(est["drift"]) / MGAL)
    d_sig = est.get("drift_sigma")
    listed = [
        {
            "t_s": float(t),
            "spot": int(j),
            "drift_mgal": float(d / MGAL),
            "duration_s": float(dur),
            "stop_sigma_mgal": float(sg / MGAL) if np.isfinite(sg) else None,
            "drift_sigma_mgal": float(d_sig[i] / MGAL) if d_sig is not None else None,
        }
        for i, (t, j, d, sg, dur) in enumerate(zip(est["t_s"], est["spot"], est["drift"], sig, [s[4] for s in stops]))
    ]
    base = {
        "n_stops": len(stops),
        "n_spots": int(est["n_spots"]),
        "drift_range_mgal": rng_mgal,
        "stop_sigma_mgal": sigma,
        "stop_sigma_source": f"the stops' own data (scatter of {STOP_BLOCK_S:g}-s means, floored at the manifest's "
        "white accelerometer noise over √T, plus lost IMU rows bridged there)",
        "max_drift_sigmas": _max_sigmas(est),
        # the drifts' χ² against their covariance and its probability under "no drift" (small: drift)
        "drift_chi2": est.get("chi2"),
        "drift_dof": est.get("dof"),
        "no_drift_p_value": float(chi2_dist.sf(est["chi2"], est["dof"])) if "chi2" in est else None,
        "stops": listed,
    }
    if mode == "auto" and sigma is not None and rng_mgal < SIGNIFICANT_SIGMA * np.sqrt(2.0) * sigma:
        return None, {
            "method": "none",
            **base,
            "reason": f"drift at the stops ({rng_mgal:.2f} mGal) within {SIGNIFICANT_SIGMA:g} σ of their "
            "noise: not applied",
        }
    report = {
        "method": "repeated stops",
        **base,
        "note": "vertical accelerometer drift tied at repeated stops and interpolated linearly between "
        "them; drift faster than the stop spacing remains in the lines",
    }
    return b, report


def _max_sigmas(est) -> float | None:
    """The largest |b_k|/σ(b_k) over the stops after the first (None without σ)."""
    d_sig = est.get("drift_sigma")
    if d_sig is None or len(d_sig) < 2 or not np.all(d_sig[1:] > 0):
        return None
    return float(np.max(np.abs(est["drift"][1:]) / d_sig[1:]))
