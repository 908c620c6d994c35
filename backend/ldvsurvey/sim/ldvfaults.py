"""LDV dropouts and outliers of real drives (the ``ldv_dropouts`` effect).

Bursts of samples with a quality below ``min_quality`` (drawn in 5–95 for ``min_quality`` 100):
Poisson arrivals at ``rate_per_min`` (~1 a minute; 2–3 on rough ground) over the whole log
plus ``static_bursts`` inside the initial static period; durations log-uniform in
[``burst_min_s``, ``burst_max_s``] (0.1–5 s). The values in a burst are garbage, never NaN,
one kind per burst: ``zeros``; ``stale`` (the last value before the burst repeated);
``spikes`` (uniform ±2–30 m/s); ``noise`` (the true value + N(0, 2 m/s)).
Isolated spikes of 0.3–5 m/s (either sign) keep a *good* quality, ``spikes_per_min`` (~0.2).
The existing isolated low-quality samples of the ideal scenarios remain.
"""

from __future__ import annotations

import numpy as np

from ldvsurvey.sim.effects import LdvDropouts

KINDS = ("zeros", "stale", "spikes", "noise")


def apply_dropouts(t_s, v_fwd, v_up, quality, spec: LdvDropouts, static_end_s: float, rng):
    """Corrupt LDV rows (in copies): bursts of zeros, stale values, spikes or noise, and isolated spikes.

    Parameters
    ----------
    t_s : (N,) array
        Sample times (s).
    v_fwd, v_up : (N,) arrays
        Forward and up speed (m/s).
    quality : (N,) array
        Signal quality.
    spec : LdvDropouts
        Burst rate (per min), lengths (s), spike rate (per min) and sizes (m/s).
    static_end_s : float
        End of the static start (s); ``spec.static_bursts`` bursts fall inside it.
    rng : numpy.random.Generator
        The effects' generator.

    Returns
    -------
    v_fwd, v_up, quality : (N,) arrays
        The corrupted copies (m/s; bursts flagged with quality below 100).
    bursts : list of (float, float, str)
        ``(t_start_s, t_end_s, kind)``; rows with t_start ≤ t < t_end are corrupted.
    spike_times : list of float
        Times (s) of the isolated spikes left with good quality.
    """
    t = np.asarray(t_s, float)
    vf, vu, q = v_fwd.copy(), v_up.copy(), quality.copy()
    t0, t1 = t[0], t[-1]
    minutes = (t1 - t0) / 60.0
    starts = list(rng.uniform(t0, t1, rng.poisson(spec.rate_per_min * minutes)))
    if static_end_s > t0 + 20.0:
        starts += list(rng.uniform(t0 + 5.0, static_end_s - 10.0, spec.static_bursts))
    bursts = []
    for a in sorted(starts):
        d = float(np.exp(rng.uniform(np.log(spec.burst_min_s), np.log(spec.burst_max_s))))
        kind = str(rng.choice(KINDS))
        m = (t >= a) & (t < a + d)
        if not m.any():
            continue
        idx = np.flatnonzero(m)
        k = int(m.sum())
        q[m] = rng.integers(5, 96, k)
        for arr in (vf, vu):
            if kind == "zeros":
                arr[m] = 0.0
            elif kind == "stale":
                arr[m] = arr[max(idx[0] - 1, 0)]
            elif kind == "spikes":
                arr[m] = rng.choice([-1.0, 1.0], k) * rng.uniform(2.0, 30.0, k)
            else:
                arr[m] = arr[m] + rng.normal(0.0, 2.0, k)
        bursts.append((float(a), float(a + d), kind))
    n_sp = rng.poisson(spec.spikes_per_min * minutes)
    sp_idx = rng.integers(0, len(t), n_sp)
    sp_idx = sp_idx[q[sp_idx] >= 100]
    vf[sp_idx] += rng.choice([-1.0, 1.0], len(sp_idx)) * rng.uniform(
        spec.spike_min_mps, spec.spike_max_mps, len(sp_idx)
    )
    return vf, vu, q, bursts, sorted(float(x) for x in t[sp_idx])
