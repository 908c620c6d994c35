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

from ldvsurvey.nav.earth import MGAL
from ldvsurvey.pipelines.inputs import local_metres

#: stops shorter than this (after trimming their edges) are not used, s
MIN_STOP_S = 10.0
#: trimmed at both ends of a stop (braking, starting), s
STOP_EDGE_S = 2.0
#: stops closer than this are the same spot, m
SAME_SPOT_M = 30.0


def stop_means(chain, still):
    """(t_s, lat, lon, mean f_U − γ in m/s², duration s) of every usable stop."""
    out = []
    t = chain["t_s"]
    for a, b in still:
        a, b = a + STOP_EDGE_S, b - STOP_EDGE_S
        if b - a < MIN_STOP_S:
            continue
        k = (t >= a) & (t <= b) & np.isfinite(chain["dg_static"])
        if k.sum() < 10:
            continue
        out.append(
            (
                0.5 * (a + b),
                float(np.mean(chain["lat"][k])),
                float(np.mean(chain["lon"][k])),
                float(np.mean(chain["dg_static"][k])),
                float(b - a),
            )
        )
    return out


def estimate_drift(stops):
    """Drift b_k (m/s²) at the stops and the spot index of each; None when no spot is visited twice."""
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
    sigma = None
    if noise_ug_rthz:
        dur = np.array([s[4] for s in stops])
        sigma = float(np.sqrt(np.mean((noise_ug_rthz * 1e-6 * 9.80665) ** 2 / dur)) / MGAL)
    rng_mgal = float(np.ptp(est["drift"]) / MGAL)
    if mode == "auto" and sigma is not None and rng_mgal < SIGNIFICANT_SIGMA * np.sqrt(2.0) * sigma:
        return None, {
            "method": "none",
            "n_stops": len(stops),
            "drift_range_mgal": rng_mgal,
            "stop_sigma_mgal": sigma,
            "reason": f"drift at the stops ({rng_mgal:.2f} mGal) within {SIGNIFICANT_SIGMA:g} σ of their "
            "noise: not applied",
        }
    report = {
        "method": "repeated stops",
        "n_stops": len(stops),
        "n_spots": int(est["n_spots"]),
        "drift_range_mgal": float(np.ptp(est["drift"]) / MGAL),
        "stop_sigma_mgal": sigma,
        "stops": [
            {"t_s": float(t), "spot": int(j), "drift_mgal": float(d / MGAL)}
            for t, j, d in zip(est["t_s"], est["spot"], est["drift"])
        ],
        "note": "vertical accelerometer drift tied at repeated stops and interpolated linearly between "
        "them; drift faster than the stop spacing remains in the lines",
    }
    return b, report
