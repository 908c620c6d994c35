"""Single-axis rotation INS: base-tilt estimation and compensation (methods §2, height paper eq. 12-19).

C_b^s = R_y(β) R_x(α) R_z(η), C_s^n = C_b^n (C_b^s)ᵀ. While the vehicle stands still, C_b^n is
constant and the up direction seen in the sensor frame is

    u_s(t) = (C_s^n(t))ᵀ e_U = C_b^s(η(t), α, β) u_b,        u_b = (C_b^n)ᵀ e_U (constant).

As η turns, the horizontal part of R_z(η) u_b circles the turntable axis while α, β stay a fixed
offset of that axis from the sensor z-axis. The paper's stop-pair formula (α = ΔC_i2/ΔC_i3,
β = −ΔC_i1/ΔC_i3 with ΔC = C_s^n(η1) + C_s^n(η1 + 180°)) is the special case of two stops;
:func:`estimate_tilt` fits the exact model by least squares over every sample of every still
interval (one u_b per interval, α and β shared), so any indexing scheme works: stops 180° apart
(two- or four-position, in any order, unequal dwell), stops 90° apart, slow moves and continuous
rotation at any rate (the modulation over η). The encoder angle of each sample enters the model,
so encoder jitter of a count or two is harmless.

α, β are observable when η takes different values within one still interval (the *diversity*
1 − |mean e^{iη}|² of the samples, 0 for one angle, 1 for two angles 180° apart or a full turn).
A linear drift of the level over each interval is fitted beside (the vehicle settling, or the
filter relevelling at a stop after a drive).
The 1-σ of α, β is the larger of (a) the leave-one-block-out jackknife spread (blocks of equal length
in each interval, so a correlated attitude error counts once per block) and (b) the filter's
horizontal accelerometer-bias σ / g, which is the part of the level error fixed in the sensor
frame and therefore inseparable from the tilt.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ldvsurvey.nav.attitude import c_bs

#: an interval must hold at least this η diversity to contribute (see module docstring)
MIN_DIVERSITY = 0.05
#: encoder movement (rad) within a window that counts as turning (well above a few counts of jitter)
STOP_TOL_RAD = np.radians(0.05)


@dataclass
class Stop:
    """A turntable stop: time span (s) and encoder angle (rad, unwrapped)."""

    t_start_s: float
    t_end_s: float
    eta_rad: float


def find_stops(
    t_s, eta_rad, min_dwell_s: float = 5.0, tol_rad: float = STOP_TOL_RAD, window_s: float = 1.0
) -> list[Stop]:
    """Stretches where the encoder angle stays within ``tol_rad`` over every ``window_s`` window for
    at least ``min_dwell_s`` (encoder jitter of a few counts does not end a stop).

    Parameters
    ----------
    t_s : (N,) array
        Sample times (s).
    eta_rad : (N,) array
        Encoder angle (rad, unwrapped).
    min_dwell_s : float
        Shortest stop (s).
    tol_rad : float
        Largest encoder movement within a window that still counts as standing (rad).
    window_s : float
        Window length (s).

    Returns
    -------
    list of Stop
        Each stop's span (s) and median encoder angle (rad), in time order.
    """
    from scipy.ndimage import maximum_filter1d, minimum_filter1d

    t = np.asarray(t_s, float)
    eta = np.asarray(eta_rad, float)
    if len(t) < 2:
        return []
    w = max(3, int(round(window_s / np.median(np.diff(t)))) | 1)
    rng = maximum_filter1d(eta, w, mode="nearest") - minimum_filter1d(eta, w, mode="nearest")
    still = rng <= tol_rad
    edges = np.flatnonzero(np.diff(np.r_[0, still.astype(int), 0]))
    stops = []
    for a, b in zip(edges[::2], edges[1::2]):
        if t[b - 1] - t[a] >= min_dwell_s:
            stops.append(Stop(float(t[a]), float(t[b - 1]), float(np.median(eta[a:b]))))
    return stops


@dataclass
class TiltEstimate:
    """α, β (rad) with 1-σ (rad); ``observable`` False means the fallback α = β = 0 (σ None)."""

    alpha_rad: float
    beta_rad: float
    alpha_sigma_rad: float | None
    beta_sigma_rad: float | None
    pairs: list = field(default_factory=list)  # [(t1, t2)] consecutive stops ~180° apart in one still interval
    observable: bool = True
    n_intervals: int = 0
    n_samples: int = 0
    diversity: float = 0.0
    rms_residual_rad: float | None = None
    warnings: list = field(default_factory=list)


def diversity(eta_rad) -> float:
    """η diversity 1 − |mean e^{iη}|²: 0 when η takes one value, 1 for two values 180° apart or a uniform turn.

    Parameters
    ----------
    eta_rad : (K,) array
        Encoder angles (rad).

    Returns
    -------
    float
        The diversity, in [0, 1] (dimensionless); 0 for no samples.
    """
    eta = np.asarray(eta_rad, float)
    if len(eta) == 0:
        return 0.0
    return float(1.0 - abs(np.mean(np.exp(1j * eta))) ** 2)


NG = 4  # parameters per interval: pitch, roll and their linear drift over the interval


def _fit(groups, x0):
    """Gauss-Newton fit of (α, β, per interval pitch, roll and their linear drift) to
    u_s = C_b^s(η; α, β) u_b(τ); τ ∈ [−1, 1] over each interval. The drift takes up a slowly
    changing level of the vehicle or of the filter's solution (relevelling after a drive)."""
    x = np.array(x0, float)
    ng = len(groups)
    npar = 2 + NG * ng
    eps = 1e-7
    for _ in range(20):
        rows, res = [], []
        a, b = x[0], x[1]
        for i, (eta, u_s, tau) in enumerate(groups):
            p = x[2 + NG * i : 2 + NG * (i + 1)]

            def model(pp, aa=a, bb=b, eta=eta, tau=tau):
                return np.einsum("kij,kj->ki", c_bs(eta, aa, bb), _up_b_series(pp, tau))

            m0 = model(p)
            jac = np.zeros((len(eta), 3, npar))
            jac[:, :, 0] = (model(p, a + eps, b) - m0) / eps
            jac[:, :, 1] = (model(p, a, b + eps) - m0) / eps
            for j in range(NG):
                dp = p.copy()
                dp[j] += eps
                jac[:, :, 2 + NG * i + j] = (model(dp) - m0) / eps
            rows.append(jac.reshape(-1, npar))
            res.append((u_s - m0).reshape(-1))
        jm = np.vstack(rows)
        rv = np.concatenate(res)
        dx, *_ = np.linalg.lstsq(jm, rv, rcond=None)
        x += dx
        if np.abs(dx).max() < 1e-12:
            break
    return x, jm, rv


def _up_b_series(p, tau):
    """Up vectors in b (K, 3) for pitch p0 + p2 τ and roll p1 + p3 τ."""
    th = p[0] + p[2] * tau
    ga = p[1] + p[3] * tau
    return np.column_stack([-np.cos(th) * np.sin(ga), np.sin(th), np.cos(th) * np.cos(ga)])


def estimate_tilt(
    t_s,
    c_sn,
    eta_rad,
    still: list[tuple[float, float]],
    *,
    trim_s: float = 1.0,
    rate_hz: float = 10.0,
    block_s: float = 20.0,
    bias_sigma_rad: float = 0.0,
    stops: list[Stop] | None = None,
) -> TiltEstimate:
    """Least-squares α, β over the still intervals (see the module docstring).

    Parameters
    ----------
    t_s : (N,) array
        Sample times (s).
    c_sn : (N, 3, 3) array
        Sensor attitude C_s^n (best the smoothed ZUPT solution).
    eta_rad : (N,) array
        Encoder angle (rad, unwrapped).
    still : list of (float, float)
        ``(t0, t1)`` (s) of each interval where the vehicle stands still.
    trim_s : float
        Cut from both ends of each still interval (s).
    rate_hz : float
        Samples used per second (Hz).
    block_s : float
        Jackknife block length (s).
    bias_sigma_rad : float
        Horizontal accelerometer-bias σ / g of the filter (rad), a floor of the 1-σ.
    stops : list of Stop, optional
        Turntable stops; consecutive ones about 180° apart in one still interval are recorded as ``pairs``.

    Returns
    -------
    TiltEstimate
        α, β (rad) and their 1-σ (rad); ``observable`` False (α = β = 0, a warning) when no interval
        turns enough.
    """
    t = np.asarray(t_s, float)
    eta = np.asarray(eta_rad, float)
    step = max(1, int(round(1.0 / (rate_hz * np.median(np.diff(t))))))
    groups, blocks = _still_groups(t, eta, c_sn, still, trim_s=trim_s, step=step, block_s=block_s)
    pairs = _stop_pairs(still, stops)
    n = sum(len(g[0]) for g in groups)
    div = (sum(len(g[0]) * diversity(g[0]) for g in groups) / n) if n else 0.0
    if not groups:
        return TiltEstimate(
            0.0,
            0.0,
            None,
            None,
            pairs,
            observable=False,
            warnings=[
                "base tilt not observable: the turntable did not turn while the vehicle stood still (no still "
                "interval with stops at different encoder angles or a rotation); α = β = 0 is used, so the "
                "attitude keeps an oscillation of the size of the tilt"
            ],
        )
    x, jm, rv = _fit(groups, _initial_levels(groups))
    sig = np.maximum(_tilt_sigma(groups, blocks, x, jm, rv), bias_sigma_rad)
    return TiltEstimate(
        float(x[0]),
        float(x[1]),
        float(sig[0]),
        float(sig[1]),
        pairs,
        observable=True,
        n_intervals=len(groups),
        n_samples=n,
        diversity=div,
        rms_residual_rad=float(np.sqrt(np.mean(rv**2))),
    )


def _still_groups(t, eta, c_sn, still, *, trim_s, step, block_s):
    """The fit's groups (η, up vector in s, τ) of each still interval that turns enough, and its
    jackknife blocks [(group index, sample indices)]."""
    groups, blocks = [], []
    for a, b in still:
        k = np.flatnonzero((t >= a + trim_s) & (t <= b - trim_s))[::step]
        if len(k) < 10 or diversity(eta[k]) < MIN_DIVERSITY:
            continue
        gi = len(groups)
        tau = 2.0 * (t[k] - t[k[0]]) / max(t[k[-1]] - t[k[0]], 1e-9) - 1.0
        groups.append((eta[k], c_sn[k, 2, :], tau))
        nb = max(1, int((t[k[-1]] - t[k[0]]) // block_s))
        for part in np.array_split(np.arange(len(k)), nb):
            blocks.append((gi, part))
    return groups, blocks


def _stop_pairs(still, stops):
    """[(t1, t2)] (s) of consecutive stops about 180° apart within one still interval (for the record)."""
    pairs = []
    for a, b in still:
        inside = [Stop(max(s.t_start_s, a), min(s.t_end_s, b), s.eta_rad) for s in stops or []]
        inside = [s for s in inside if s.t_end_s - s.t_start_s >= 5.0]
        for s1, s2 in zip(inside[:-1], inside[1:]):
            if abs(abs(s2.eta_rad - s1.eta_rad) % (2 * np.pi) - np.pi) < np.radians(5.0):
                pairs.append((s1.t_start_s, s2.t_end_s))
    return pairs


def _initial_levels(groups):
    """Start of the fit: α = β = 0 and each interval's level from its mean up vector brought back to b."""
    x0 = [0.0, 0.0]
    for e, u, _ in groups:
        ub = np.mean(np.einsum("kji,kj->ki", c_bs(e), u), axis=0)
        x0 += [np.arcsin(np.clip(ub[1], -1, 1)), np.arctan2(-ub[0], ub[2]), 0.0, 0.0]
    return x0


def _tilt_sigma(groups, blocks, x, jm, rv):
    """1-σ of α, β (rad): the leave-one-block-out jackknife spread, or with fewer than three refits the
    formal σ with one independent error per interval."""
    est = []
    if len(blocks) >= 3:
        for gi, part in blocks:
            sub = []
            xs = [x[0], x[1]]
            for j, (e, u, tau) in enumerate(groups):
                if j == gi:
                    keep = np.setdiff1d(np.arange(len(e)), part)
                    if len(keep) < 10 or diversity(e[keep]) < MIN_DIVERSITY:
                        continue
                    e, u, tau = e[keep], u[keep], tau[keep]
                sub.append((e, u, tau))
                xs += list(x[2 + NG * j : 2 + NG * (j + 1)])
            if sub:
                est.append(_fit(sub, xs)[0][:2])
    if len(est) >= 3:
        est = np.array(est)
        m = len(est)
        return np.sqrt((m - 1) / m * np.sum((est - est.mean(axis=0)) ** 2, axis=0))
    dof = max(1, len(rv) - jm.shape[1])
    s2 = float(rv @ rv) / dof * (len(rv) / (3 * len(groups)))
    cov = s2 * np.linalg.pinv(jm.T @ jm)
    return np.sqrt(np.diag(cov)[:2])


def oscillation_per_cycle(t_s, values, eta_rad, still: list[tuple[float, float]]):
    """Peak-to-peak of ``values`` within each full turntable cycle lying in a still interval.

    A cycle runs from a time to the next time the encoder comes back to the same angle after
    having turned at least 180° away (a stop scheme) or after a full turn (continuous rotation).

    Parameters
    ----------
    t_s : (N,) array
        Sample times (s).
    values : (N,) array
        The quantity whose oscillation is measured (any unit, e.g. pitch in rad).
    eta_rad : (N,) array
        Encoder angle (rad, unwrapped).
    still : list of (float, float)
        ``(t0, t1)`` (s) of each interval where the vehicle stands still.

    Returns
    -------
    list of float
        Peak-to-peak of ``values`` over each complete cycle (the unit of ``values``).
    """
    t = np.asarray(t_s, float)
    eta = np.asarray(eta_rad, float)
    out = []
    for a, b in still:
        k = np.flatnonzero((t >= a) & (t <= b))
        if len(k) < 10:
            continue
        i = 0
        while i < len(k):
            e0 = eta[k[i]]
            d = eta[k[i:]] - e0
            far = np.flatnonzero(np.abs(np.mod(d + np.pi, 2 * np.pi) - np.pi) > np.radians(170.0))
            if not len(far):
                break
            back = np.flatnonzero(np.abs(np.mod(d[far[0] :] + np.pi, 2 * np.pi) - np.pi) < np.radians(1.0))
            if not len(back):
                break
            j = i + far[0] + back[0]
            out.append(float(np.ptp(values[k[i : j + 1]])))
            i = j + 1
    return out
