"""Single-axis rotation INS: base-tilt estimation and compensation (methods §2, height paper eq. 12-19).

C_s^n(η) = C_b^n C_b^s(η, α, β)ᵀ. With the vehicle still, two stops η1 and η2 = η1 + 180° give
ΔC = C_s^n(η1) + C_s^n(η2) = C_b^n [[0,0,0],[0,0,0],[−2β, 2α, 2]], so α = ΔC_i2/ΔC_i3 and
β = −ΔC_i1/ΔC_i3, best from the up row. Then C_b^n = C_s^n C_b^s(η, α, β) at every sample.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ldvsurvey.nav.attitude import c_from_q, q_from_c


@dataclass
class Stop:
    """A turntable stop: time span (s) and encoder angle (rad, unwrapped)."""

    t_start_s: float
    t_end_s: float
    eta_rad: float


def find_stops(t_s, eta_rad, min_dwell_s: float = 5.0, tol_rad: float = 1e-4) -> list[Stop]:
    """Stretches where the encoder angle stays constant for at least ``min_dwell_s``."""
    eta = np.asarray(eta_rad, float)
    moving = np.abs(np.diff(eta, prepend=eta[0])) > tol_rad
    still = ~moving
    edges = np.flatnonzero(np.diff(np.r_[0, still.astype(int), 0]))
    stops = []
    for a, b in zip(edges[::2], edges[1::2]):
        if t_s[b - 1] - t_s[a] >= min_dwell_s:
            stops.append(Stop(float(t_s[a]), float(t_s[b - 1]), float(np.median(eta[a:b]))))
    return stops


def mean_attitude(c: np.ndarray) -> np.ndarray:
    """Average of nearby rotation matrices (sign-aligned quaternion mean)."""
    q = q_from_c(c)
    q *= np.where(q @ q[0] < 0, -1.0, 1.0)[:, None]
    m = q.mean(axis=0)
    return c_from_q(m / np.linalg.norm(m))


def tilt_from_pair(c_sn_1: np.ndarray, c_sn_2: np.ndarray) -> tuple[float, float]:
    """(α, β) in rad from the sensor attitudes at two stops 180° apart (up row of ΔC)."""
    dc = c_sn_1 + c_sn_2
    i = int(np.argmax(np.abs(dc[:, 2])))
    return float(dc[i, 1] / dc[i, 2]), float(-dc[i, 0] / dc[i, 2])


@dataclass
class TiltEstimate:
    alpha_rad: float
    beta_rad: float
    alpha_sigma_rad: float
    beta_sigma_rad: float
    pairs: list  # [(t1, t2, alpha, beta)]


def estimate_tilt(t_s, c_sn, stops: list[Stop], still: list[tuple[float, float]], trim_s: float = 1.0,
                  level_sigma_rad: float = 0.0) -> TiltEstimate | None:
    """Pair consecutive stops 180° apart that lie in one still interval and average (α, β).

    Parameters
    ----------
    c_sn : (N, 3, 3) sensor attitude C_s^n at the samples ``t_s`` (best: the smoothed solution).
    level_sigma_rad : attitude σ of one stop, used for σ when there are too few pairs for a spread.
    """
    def inside_still(a, b):
        return any(s <= a and b <= e for s, e in still)

    pairs = []
    for s1, s2 in zip(stops[:-1], stops[1:]):
        d = abs(s2.eta_rad - s1.eta_rad)
        if abs(d - np.pi) > np.radians(1.0) or not inside_still(s1.t_start_s, s2.t_end_s):
            continue
        cs = []
        for s in (s1, s2):
            k = (t_s >= s.t_start_s + trim_s) & (t_s <= s.t_end_s - trim_s)
            if k.sum() < 10:
                break
            cs.append(mean_attitude(c_sn[k]))
        if len(cs) == 2:
            a, b = tilt_from_pair(*cs)
            pairs.append((s1.t_start_s, s2.t_end_s, a, b))
    if not pairs:
        return None
    ab = np.array([(p[2], p[3]) for p in pairs])
    n = len(ab)
    floor = level_sigma_rad / np.sqrt(2 * n)
    spread = ab.std(axis=0, ddof=1) / np.sqrt(n) if n > 1 else np.zeros(2)
    sig = np.maximum(spread, floor)
    return TiltEstimate(float(ab[:, 0].mean()), float(ab[:, 1].mean()), float(sig[0]), float(sig[1]), pairs)


def oscillation_per_cycle(t_s, values, stops: list[Stop], still: list[tuple[float, float]]):
    """Peak-to-peak of ``values`` within each full rotation cycle lying in a still interval.

    A cycle runs from a stop to the next stop at the same encoder angle. Returns the list of
    peak-to-peak values (same unit as ``values``).
    """
    out = []
    for i, s in enumerate(stops):
        nxt = next((o for o in stops[i + 1:] if abs(o.eta_rad - s.eta_rad) < np.radians(1.0)), None)
        if nxt is None:
            continue
        a, b = s.t_start_s, nxt.t_start_s
        if not any(st <= a and b <= en for st, en in still):
            continue
        k = (t_s >= a) & (t_s < b)
        if k.sum() > 10:
            out.append(float(np.ptp(values[k])))
    return out
