"""GNSS effects of real drives (the ``gnss`` effect).

- RTK convergence at the start: fix 1 for 20 s, 2 for 20 s, 5 for 20 s, then 4;
- outages (fix 0) of 10–120 s, ~3 per hour (Poisson);
- quality changes: fix 5, 2 or 1 for 30–300 s, ~4 per hour;
- multipath jumps in fixed/float solutions: a constant offset of 0.1–0.5 m in a random
  direction (horizontal and vertical) for 5–60 s, ~6 per hour;
- the antenna at a real lever arm ([0.3, 0.8, 1.6] m RFU by default), rotated by the true body
  attitude (see ``sensors.gnss_fixes``).
The base schedule of the scenario (e.g. the blocked lines of the gravity survey) stays under these.
"""

from __future__ import annotations

import numpy as np

from ldvsurvey.sim.effects import GnssEffects

RANK = {4: 0, 5: 1, 2: 2, 1: 3, 0: 4}  #: fix quality from best to worst


def _events(rng, per_h: float, dur: tuple, t_a: float, t_b: float):
    n = rng.poisson(per_h * (t_b - t_a) / 3600.0)
    starts = np.sort(rng.uniform(t_a, t_b, n))
    return [(float(s), float(s + rng.uniform(*dur))) for s in starts]


def gnss_events(spec: GnssEffects, t0_s: float, t_end_s: float, rng) -> dict:
    """Random convergence, outage, degradation and multipath windows.

    Parameters
    ----------
    spec : GnssEffects
        Rates (per h), durations (s) and multipath sizes (m).
    t0_s, t_end_s : float
        The log's span (s).
    rng : numpy.random.Generator
        The effects' generator.

    Returns
    -------
    dict
        ``convergence`` and ``degraded`` as (t_start_s, t_end_s, fix), ``outages`` as (t_start_s,
        t_end_s), ``multipath`` as (t_start_s, t_end_s, de_m, dn_m, du_m).
    """
    conv = [(t0_s, t0_s + 20.0, 1), (t0_s + 20.0, t0_s + 40.0, 2), (t0_s + 40.0, t0_s + 60.0, 5)]
    degraded = [
        (a, b, int(rng.choice([5, 2, 1])))
        for a, b in _events(rng, spec.degraded_per_h, spec.degraded_s, t0_s + 60.0, t_end_s)
    ]
    outages = _events(rng, spec.outages_per_h, spec.outage_s, t0_s + 60.0, t_end_s)
    mp = []
    for a, b in _events(rng, spec.multipath_per_h, spec.multipath_s, t0_s + 60.0, t_end_s):
        amp = rng.uniform(*spec.multipath_m)
        d = rng.normal(0, 1, 3)
        d[2] *= 1.5
        mp.append((a, b, *(amp * d / np.linalg.norm(d))))
    return dict(convergence=conv, degraded=degraded, outages=outages, multipath=mp)


def fix_with_events(base_fix_of_t, ev: dict):
    """fix_of_t(t) with convergence, degradations and outages laid over the base schedule."""

    def fix_of_t(t):
        t = np.asarray(t, float)
        fix = np.asarray(base_fix_of_t(t), int).copy()
        for a, b, q in ev["convergence"] + ev["degraded"]:
            m = (t >= a) & (t < b) & (fix > 0)
            rank = np.vectorize(RANK.get)(fix[m]) if m.any() else np.zeros(0)
            fix[m] = np.where(rank < RANK[q], q, fix[m])  # the worse of the two qualities
        for a, b in ev["outages"]:
            fix[(t >= a) & (t < b)] = 0
        return fix

    return fix_of_t


def multipath_offsets(t_s, fix, ev: dict) -> np.ndarray:
    """(N, 3) ENU position offsets (m) of the multipath windows, in fix 4 and 5 only."""
    t = np.asarray(t_s, float)
    out = np.zeros((len(t), 3))
    for a, b, de, dn, du in ev["multipath"]:
        m = (t >= a) & (t < b) & np.isin(fix, (4, 5))
        out[m] = (de, dn, du)
    return out
