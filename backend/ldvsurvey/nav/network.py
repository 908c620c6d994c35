"""Network adjustment of a gravity survey: repeated lines, crossovers and base ties (pure functions).

Every line sample (filtered δg, mGal) at a network point p is modelled as

    v_i(p) = G(p) + b_L + d_L·(t_i(p) − t_L) + c_l + ε_i(p)

with G(p) the unknown true value at the point, b_L and d_L the bias and linear drift of the line's
log L (t_L: the log's first tie or its first line sample), c_l the line's own bias, ε white-noise
floor of the filtered line (σ_l). A base tie k observed in log L at time t_k at station S is

    y_k − δg_k = b_L + d_L·(t_k − t_L) + s_S + ε_k,      0 = s_S + η_S

(y_k: the log's stop mean of δg beside the tie, δg_k = g_k − γ(φ_k, h_k) from the tie's absolute g; ε_k of
1-σ σ_stop, the stop mean's own; s_S the error of station S's given g, ONE unknown per station, common to
every stop that observes it, held by the pseudo-observation 0 ± σ_g (η_S of 1-σ σ_g). Repeat visits of a
station average the stop noise down, never the station's σ_g: a log tied to one station n times has a level
of variance σ_stop²/n + σ_g². A station given without σ_g (σ_g = 0) has no unknown: its g is exact.)
The G(p) are eliminated point by point (the weighted mean of the samples at p), which leaves the
weighted least squares of the centred observations on the centred design. Constraints: the line
biases of a log sum to zero (the log's level is b_L); without ties the logs' biases sum to zero
(the free datum: the survey keeps the mean level of its logs).

Weights: a filtered line's noise is correlated along the track over the filter's correlation
time τ_c = 1/∫|H|⁴df (the white-noise equivalent: a mean over T seconds of the filtered noise has
the variance of T/τ_c independent samples), so samples at spacing Δs carry the information of
Δs/(v·τ_c) independent ones: their variance is σ_l²·max(1, v·τ_c/Δs). A line's samples at its crossings
are correlated the same way: each carries σ_l²·max(1, (1/N)·Σ_jk ρ(t_j − t_k)) over the line's N
crossings (:func:`noise_autocorrelation`), so their mean has its true variance.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.spatial import cKDTree

from ldvsurvey.nav.coincidence import along_track, common_points, crossovers, internal_coincidence
from ldvsurvey.nav.gravity import Lowpass

#: two lines repeat each other when the median distance of one's samples from the other is below this (m) …
REPEAT_MAX_OFFSET_M = 50.0
#: … over at least this share of the shorter line
REPEAT_MIN_SHARE = 0.3
#: crossings at a smaller angle are repeats, not crossovers (as pipelines/gravity/report.py)
CROSSING_MIN_ANGLE_DEG = 20.0
#: a line's sample farther than this from a crossing point is not taken there (m)
CROSSING_MAX_DISTANCE_M = 50.0
#: reweighting passes of the robust (Huber) adjustment …
ROBUST_ITERATIONS = 5
#: … beyond this many marginal σ
ROBUST_K = 3.0


@dataclass
class Line:
    """One survey line's filtered values on its trimmed samples (local metres of the survey)."""

    name: str
    log: int
    t_s: np.ndarray
    e_m: np.ndarray
    n_m: np.ndarray
    dg_mgal: np.ndarray
    sigma_mgal: float  #: white-noise floor of one filtered value
    speed_mps: float  #: median speed on the line


@dataclass
class Tie:
    """A base tie observed by one log: its stop mean beside the tie and the tie's δg."""

    name: str
    log: int
    t_s: float
    measured_mgal: float  #: the log's stop mean of δg (same processing as the lines' level)
    tie_mgal: float  #: δg of the tie, g − γ(φ, h)
    sigma_mgal: float  #: 1-σ of the observation: the stop mean's, with the station's g where it is given
    distance_m: float  #: horizontal distance of the stop from the tie
    stop_sigma_mgal: float | None = None  #: 1-σ of the stop mean alone (None: ``sigma_mgal`` is it)
    g_sigma_mgal: float = 0.0  #: 1-σ of the station's absolute g


@dataclass
class Cluster:
    """Samples of several lines at one network point."""

    kind: str  #: "repeat" or "crossing"
    group: int | tuple  #: repeat group, or the two groups crossing
    e_m: float
    n_m: float
    lines: np.ndarray  #: line index of each sample
    values: np.ndarray  #: mGal
    t_s: np.ndarray
    #: the samples' variance over σ_l² (along-track correlation): one for the cluster, or one per sample
    var_scale: float | np.ndarray = 1.0


@dataclass
class Adjustment:
    """The adjusted network."""

    names: list[str]  #: parameter names
    x: np.ndarray  #: parameters (mGal, mGal/h for drifts; ``station:<name>``: a station's g error, mGal)
    cov: np.ndarray  #: their covariance (a priori weights, scaled by max(1, σ0²))
    sigma0: float  #: a posteriori unit-weight σ
    dof: int
    t_ref: np.ndarray  #: per log, s
    drift_logs: list[int]
    line_bias: bool
    datum: str
    index: dict = field(default_factory=dict)  #: parameter name -> column
    weights: list = field(default_factory=list)  #: per cluster, the robust weight factor of each sample (1: full)

    def correction(self, log: int, line: int | None, t_s) -> np.ndarray:
        """b_L + d_L (t − t_L) + c_l at times t (mGal)."""
        return self._row(log, line, t_s) @ self.x

    def correction_sigma(self, log: int, line: int | None, t_s) -> np.ndarray:
        """1-σ of the correction at times t (mGal)."""
        a = self._row(log, line, t_s)
        return np.sqrt(np.maximum(np.einsum("ij,jk,ik->i", a, self.cov, a), 0.0))

    def _row(self, log, line, t_s):
        t = np.atleast_1d(np.asarray(t_s, float))
        a = np.zeros((len(t), len(self.x)))
        a[:, self.index[f"bias:{log}"]] = 1.0
        if f"drift:{log}" in self.index:
            a[:, self.index[f"drift:{log}"]] = (t - self.t_ref[log]) / 3600.0
        if line is not None and f"line:{line}" in self.index:
            a[:, self.index[f"line:{line}"]] = 1.0
        return a


# ---------------------------------------------------------------------------------------------
# the network's points


def repeat_groups(lines: list[Line]) -> list[list[int]]:
    """Lines that repeat each other (median distance below REPEAT_MAX_OFFSET_M), by union-find."""
    parent = list(range(len(lines)))

    def find(i):
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    trees = [cKDTree(np.column_stack([ln.e_m, ln.n_m])) for ln in lines]

    def share_near(i, j):  # share of line j's samples within the offset of line i's samples
        d, _ = trees[i].query(np.column_stack([lines[j].e_m, lines[j].n_m]))
        return float(np.mean(d < REPEAT_MAX_OFFSET_M)) if len(d) else 0.0

    for i in range(len(lines)):
        for j in range(i + 1, len(lines)):
            if max(share_near(i, j), share_near(j, i)) >= REPEAT_MIN_SHARE:
                parent[find(j)] = find(i)
    groups: dict[int, list[int]] = {}
    for i in range(len(lines)):
        groups.setdefault(find(i), []).append(i)
    return list(groups.values())


def repeat_clusters(lines: list[Line], group: list[int], gi: int, spacing_m: float, corr_s: float) -> list[Cluster]:
    """Common along-track points of a group of repeated lines (a line may miss some: NaN there)."""
    if len(group) < 2:
        return []
    ref = max(group, key=lambda i: len(lines[i].e_m))
    r = lines[ref]
    step = max(1, len(r.e_m) // 4000)
    re_, rn_ = r.e_m[::step], r.n_m[::step]
    along, times, east, north = [], [], [], []
    for i in group:
        s, _lat = along_track(re_, rn_, lines[i].e_m, lines[i].n_m)
        along.append((s, lines[i].dg_mgal))
        times.append((s, lines[i].t_s))
        east.append((s, lines[i].e_m))
        north.append((s, lines[i].n_m))
    try:
        grid, vals = common_points(along, spacing_m, allow_holes=True)
    except ValueError:
        return []
    tv = [np.interp(grid, *_sorted(s, t)) for s, t in times]
    ev = np.interp(grid, *_sorted(*east[group.index(ref)]))
    nv = np.interp(grid, *_sorted(*north[group.index(ref)]))
    speed = np.median([lines[i].speed_mps for i in group])
    scale = max(1.0, speed * corr_s / spacing_m)
    out = []
    idx = np.array(group)
    for j in range(len(grid)):
        ok = np.isfinite(vals[:, j])
        if ok.sum() < 2:
            continue
        out.append(
            Cluster(
                "repeat",
                gi,
                float(ev[j]),
                float(nv[j]),
                idx[ok],
                vals[ok, j],
                np.array([tv[k][j] for k in np.flatnonzero(ok)]),
                scale,
            )
        )
    return out


def _sorted(s, v):
    o = np.argsort(s)
    return s[o], v[o]


def noise_autocorrelation(lowpass: Lowpass, lags_s) -> np.ndarray:
    """ρ(τ) of white noise through the applied (forward and backward) gravity filter at the lags ``lags_s``
    (s): the normalized autocorrelation of its impulse response; ∫ρ dτ = τ_c
    (:attr:`Lowpass.correlation_time_s`)."""
    fs = 200.0 / lowpass.length_s  # 200 samples per filter length: ρ is smooth at 1/L
    h = lowpass.at(fs).taps
    g = np.convolve(h, h[::-1])  # the applied filter's impulse response
    r = np.convolve(g, g[::-1])
    r = r / r[(len(r) - 1) // 2]
    lag = (np.arange(len(r)) - (len(r) - 1) // 2) / fs
    return np.interp(np.abs(np.asarray(lags_s, float)), lag, r, right=0.0)


def _crossing_inflation(lines: list[Line], clusters: list[Cluster], lowpass: Lowpass) -> None:
    """Set each crossing sample's variance scale from its line's along-track noise correlation.

    A line's samples at its crossings are values of one filtered noise, correlated over v·τ_c: the mean of
    N of them at times t_j has the variance σ²/N · (1/N) Σ_jk ρ(t_j − t_k), not σ²/N. Each of the line's
    crossing samples gets that factor (≥ 1; 1 for a single crossing or crossings far apart), so the N
    carry together the information of N_eff = N² / Σ_jk ρ independent ones (the generalized least squares
    of equal weights with the filtered noise's autocovariance, for the line's level)."""
    per_line: dict[int, list[tuple[int, int, float]]] = {}
    for ci, cl in enumerate(clusters):
        for j, (i, t) in enumerate(zip(cl.lines, cl.t_s)):
            per_line.setdefault(int(i), []).append((ci, j, float(t)))
    scales = [np.ones(len(cl.lines)) for cl in clusters]
    for items in per_line.values():
        t = np.array([x[2] for x in items])
        rho = noise_autocorrelation(lowpass, t[:, None] - t[None, :])
        f = max(1.0, float(np.sum(rho)) / len(t))
        for ci, j, _ in items:
            scales[ci][j] = f
    for cl, sc in zip(clusters, scales):
        cl.var_scale = sc


def crossing_clusters(
    lines: list[Line], groups: list[list[int]], min_angle_deg=CROSSING_MIN_ANGLE_DEG, lowpass: Lowpass | None = None
) -> list[Cluster]:
    """One point per crossing of two groups' tracks: every line of both groups there (when it passes within
    CROSSING_MAX_DISTANCE_M), its value interpolated at its sample nearest the crossing.

    ``lowpass``: the gravity filter; with it each sample's variance is inflated by its line's crossings'
    noise correlation (:func:`_crossing_inflation`); without it the crossings count as independent."""
    out = []
    for a in range(len(groups)):
        for b in range(a + 1, len(groups)):
            ra = max(groups[a], key=lambda i: len(lines[i].e_m))
            rb = max(groups[b], key=lambda i: len(lines[i].e_m))
            la, lb = lines[ra], lines[rb]
            sa, sb = max(1, len(la.e_m) // 2000), max(1, len(lb.e_m) // 2000)
            found, _ = crossovers(
                [(la.e_m[::sa], la.n_m[::sa], la.dg_mgal[::sa]), (lb.e_m[::sb], lb.n_m[::sb], lb.dg_mgal[::sb])],
                min_angle_deg,
            )
            for _i, _j, e, n, _d in found:
                idx, vals, ts = [], [], []
                for i in groups[a] + groups[b]:
                    ln = lines[i]
                    d = np.hypot(ln.e_m - e, ln.n_m - n)
                    k = int(np.argmin(d))
                    if d[k] > CROSSING_MAX_DISTANCE_M or not np.isfinite(ln.dg_mgal[k]):
                        continue
                    idx.append(i)
                    vals.append(_at_point(ln, k, e, n))
                    ts.append(ln.t_s[k])
                in_a = [i in groups[a] for i in idx]
                if any(in_a) and not all(in_a):
                    out.append(Cluster("crossing", (a, b), e, n, np.array(idx), np.array(vals), np.array(ts), 1.0))
    if lowpass is not None:
        _crossing_inflation(lines, out, lowpass)
    return out


def _at_point(ln: Line, k: int, e: float, n: float) -> float:
    """The line's value at the point of its track nearest (e, n), between samples k−1..k+1."""
    lo, hi = max(0, k - 1), min(len(ln.e_m) - 1, k + 1)
    if hi == lo:
        return float(ln.dg_mgal[k])
    de, dn = ln.e_m[hi] - ln.e_m[lo], ln.n_m[hi] - ln.n_m[lo]
    seg = de * de + dn * dn
    u = 0.0 if seg == 0 else float(np.clip(((e - ln.e_m[lo]) * de + (n - ln.n_m[lo]) * dn) / seg, 0.0, 1.0))
    return float(ln.dg_mgal[lo] + u * (ln.dg_mgal[hi] - ln.dg_mgal[lo]))


# ---------------------------------------------------------------------------------------------
# the adjustment


@dataclass(frozen=True, eq=False)
class _Design:
    """The adjustment's parameters: names, their columns, each log's reference time (s)."""

    names: list
    index: dict
    t_ref: np.ndarray
    line_bias: bool

    def row(self, lg: int, li: int | None, t: float) -> np.ndarray:
        """Design row of a sample of line ``li`` (None: a tie) of log ``lg`` at time ``t`` (s)."""
        a = np.zeros(len(self.names))
        a[self.index[f"bias:{lg}"]] = 1.0
        if f"drift:{lg}" in self.index:
            a[self.index[f"drift:{lg}"]] = (t - self.t_ref[lg]) / 3600.0
        if li is not None and self.line_bias:
            a[self.index[f"line:{li}"]] = 1.0
        return a


def drift_logs_of(lines: list[Line], ties: list[Tie], n_logs: int, drift: str, min_drift_span_s: float):
    """Each log's reference time t_L (its first tie or line sample, s), the logs that get a linear drift,
    and the logs seen (with a line or a tie)."""
    logs_seen = sorted({ln.log for ln in lines} | {t.log for t in ties})
    t_ref = np.zeros(n_logs)
    for lg in range(n_logs):
        tt = [t.t_s for t in ties if t.log == lg] + [float(ln.t_s[0]) for ln in lines if ln.log == lg and len(ln.t_s)]
        t_ref[lg] = min(tt) if tt else 0.0
    if drift == "linear":
        drift_logs = list(logs_seen)
    elif drift == "auto":
        drift_logs = []
        for lg in logs_seen:
            tt = [t.t_s for t in ties if t.log == lg]
            if len(tt) >= 2 and max(tt) - min(tt) >= min_drift_span_s:
                drift_logs.append(lg)
    else:
        drift_logs = []
    return t_ref, drift_logs, logs_seen


def constraint_basis(lines: list[Line], design: _Design, n_logs: int, logs_seen: list, tied: bool):
    """Basis Z of the parameters allowed by the constraints C x = 0 (x = Z ξ), and the datum's description.

    The line biases of a log sum to zero; without ties Σ b_L = 0 (free datum); a log without any line
    or tie has its bias fixed at zero (not part of the network)."""
    npar, index = len(design.names), design.index
    cons = []
    if design.line_bias:
        for lg in range(n_logs):
            row = np.zeros(npar)
            for i, ln in enumerate(lines):
                if ln.log == lg:
                    row[index[f"line:{i}"]] = 1.0
            if row.any():
                cons.append(row)
    datum = "ties"
    if not tied:
        row = np.zeros(npar)
        row[[index[f"bias:{lg}"] for lg in range(n_logs)]] = 1.0
        cons.append(row)
        datum = "free (the logs' biases sum to zero: the survey keeps the mean level of its logs)"
    for lg in range(n_logs):
        if lg not in logs_seen:
            row = np.zeros(npar)
            row[index[f"bias:{lg}"]] = 1.0
            cons.append(row)
    if not cons:
        return np.eye(npar), datum
    c = np.array(cons)
    _, sv, vt = np.linalg.svd(c)
    rank = int(np.sum(sv > 1e-10 * sv[0]))
    return vt[rank:].T, datum  # basis of the null space


def observation_blocks(lines: list[Line], clusters: list[Cluster], ties: list[Tie], design: _Design) -> list:
    """Per cluster, then per tie: (design rows, values mGal, weights 1/σ² with the along-track inflation,
    marginal σ of the samples in mGal, or None for a tie: no point to eliminate)."""
    blocks = []
    for cl in clusters:
        vs = np.broadcast_to(np.asarray(cl.var_scale, float), (len(cl.lines),))
        w = np.array([1.0 / (lines[i].sigma_mgal ** 2 * f) for i, f in zip(cl.lines, vs)])
        a = np.array([design.row(lines[i].log, i, t) for i, t in zip(cl.lines, cl.t_s)])
        sm = np.array([lines[i].sigma_mgal for i in cl.lines])
        blocks.append((a, np.asarray(cl.values, float), w, sm))
    for tie in ties:
        row = design.row(tie.log, None, tie.t_s)
        if f"station:{tie.name}" in design.index:
            row[design.index[f"station:{tie.name}"]] = 1.0
        blocks.append(
            (
                row[None, :],
                np.array([tie.measured_mgal - tie.tie_mgal]),
                np.array([1.0 / _stop_sigma(tie) ** 2]),
                None,  # no point to eliminate: the tie's value is known
            )
        )
    for name, s_g in _stations(ties).items():  # each station's g error: 0 ± σ_g, once however often observed
        row = np.zeros(len(design.names))
        row[design.index[f"station:{name}"]] = 1.0
        blocks.append((row[None, :], np.zeros(1), np.array([1.0 / s_g**2]), None))
    return blocks


def _stop_sigma(tie: Tie) -> float:
    """1-σ of a tie's stop mean alone (mGal): the observation's own noise, the station's σ_g apart."""
    return tie.sigma_mgal if tie.stop_sigma_mgal is None else tie.stop_sigma_mgal


def _stations(ties: list[Tie]) -> dict:
    """The stations whose g carries a 1-σ (name -> σ_g in mGal, > 0): each gets one unknown offset."""
    out = {}
    for t in ties:
        if t.g_sigma_mgal > 0:
            out[t.name] = max(out.get(t.name, 0.0), float(t.g_sigma_mgal))
    return out


def robust_solve(blocks: list, z: np.ndarray, robust_k: float | None, undetermined):
    """Weighted least squares of the blocks with each point's G eliminated, Huber-reweighted.

    Returns (ξ, its covariance, the robust weight factors per block, the centred design A·Z, the centred
    values, √weights). ``undetermined()`` gives the message of the ValueError raised when the normal
    matrix is singular."""
    mult = [np.ones(len(b[1])) for b in blocks]
    for _ in range(ROBUST_ITERATIONS + 1):
        rows, obs, wts, std = [], [], [], []
        for (a, y, w, sm), mu in zip(blocks, mult):
            ww = w * mu
            if sm is None:
                rows.append(a)
                obs.append(y)
                std.append(1.0 / np.sqrt(w))
            else:  # centred by the (down-weighted) point mean: the point's G eliminated
                wm = ww / ww.sum()
                rows.append(a - wm @ a)
                obs.append(y - wm @ y)
                std.append(sm * np.sqrt(np.maximum(1.0 - wm, 1e-9)))  # marginal σ of a residual about the mean
            wts.append(ww)
        a_all = np.vstack(rows) @ z
        y_all = np.concatenate(obs)
        sw = np.sqrt(np.concatenate(wts))
        aw = a_all * sw[:, None]
        n_mat = aw.T @ aw
        ev = np.linalg.eigvalsh(n_mat)
        if ev[0] <= 1e-9 * max(ev[-1], 1e-300):
            raise ValueError(undetermined())
        cov_z = np.linalg.inv(n_mat)
        xi = cov_z @ (aw.T @ (y_all * sw))
        # Huber down-weighting of residuals beyond robust_k marginal σ: one bad stretch is not smeared over
        # the lines it is compared with (their point means, their log's other lines)
        u = np.abs(y_all - a_all @ xi) / np.concatenate(std)
        if robust_k is None:
            break
        new = np.where(u > robust_k, robust_k / np.maximum(u, 1e-12), 1.0)
        parts = np.split(new, np.cumsum([len(b[1]) for b in blocks])[:-1])
        mult = [p if b[3] is not None else np.ones(1) for p, b in zip(parts, blocks)]  # ties keep their weight
    return xi, cov_z, mult, a_all, y_all, sw


def adjust(
    lines: list[Line],
    clusters: list[Cluster],
    ties: list[Tie],
    n_logs: int,
    drift: str = "auto",
    line_bias: bool = True,
    min_drift_span_s: float = 600.0,
    robust_k: float | None = ROBUST_K,
) -> Adjustment:
    """Weighted least squares of the network (see the module text).

    Parameters
    ----------
    lines : list of Line
        The lines (filtered δg in mGal, their white-noise floor σ_l).
    clusters : list of Cluster
        The network's points (repeats and crossings).
    ties : list of Tie
        Base ties observed by the logs: each weighted by its stop mean's σ (``stop_sigma_mgal``); a station
        (``name``) with ``g_sigma_mgal`` > 0 gets one unknown offset ``station:<name>`` (mGal) held by
        0 ± σ_g, shared by all its ties.
    n_logs : int
        Number of logs (each gets a bias b_L).
    drift : {"auto", "linear", "none"}
        "linear" estimates d_L (mGal/h) for every log; "auto" for the logs whose ties span at least
        ``min_drift_span_s`` (start and end ties); "none" for none.
    line_bias : bool
        A bias c_l per line (summing to zero per log).
    min_drift_span_s : float
        Span of a log's ties (s) that supports a drift under "auto".
    robust_k : float or None
        Line samples whose residual exceeds this many marginal σ are down-weighted (Huber,
        ROBUST_ITERATIONS passes; None: plain least squares).

    Returns
    -------
    Adjustment
        The parameters (mGal, mGal/h), their covariance, σ0 and the robust weights.

    Raises
    ------
    ValueError
        Naming what is not determined (a log without ties or a common point with another log).
    """
    t_ref, drift_logs, logs_seen = drift_logs_of(lines, ties, n_logs, drift, min_drift_span_s)
    names = [f"bias:{lg}" for lg in range(n_logs)] + [f"drift:{lg}" for lg in drift_logs]
    if line_bias:
        names += [f"line:{i}" for i in range(len(lines))]
    names += [f"station:{nm}" for nm in _stations(ties)]
    design = _Design(names, {nm: k for k, nm in enumerate(names)}, t_ref, line_bias)
    z, datum = constraint_basis(lines, design, n_logs, logs_seen, bool(ties))
    blocks = observation_blocks(lines, clusters, ties, design)
    if not blocks:
        raise ValueError("no common point between lines and no base tie: nothing to adjust")
    xi, cov_z, mult, a_all, y_all, sw = robust_solve(
        blocks, z, robust_k, lambda: _undetermined(lines, ties, clusters, n_logs, drift_logs)
    )
    # σ0 from the residuals against their marginal variances (the along-track inflation only spreads a
    # line's information over its correlated samples; it is not a larger error of each)
    infl = np.concatenate(
        [np.broadcast_to(np.asarray(cl.var_scale, float), (len(b[1]),)) for b, cl in zip(blocks, clusters)]
        + [np.ones(len(blocks) - len(clusters))]  # the ties and the stations' pseudo-observations
    )
    r = (y_all - a_all @ xi) * sw * np.sqrt(infl)
    n_points = len(clusters)
    dof = int(len(y_all) - n_points - a_all.shape[1])
    sigma0 = float(np.sqrt(np.sum(r**2) / dof)) if dof > 0 else float("nan")
    scale = max(1.0, sigma0**2) if np.isfinite(sigma0) else 1.0
    x = z @ xi
    cov = z @ cov_z @ z.T * scale
    adj = Adjustment(names, x, cov, sigma0, dof, t_ref, drift_logs, line_bias, datum, design.index)
    adj.weights = mult[: len(clusters)]
    return adj


def _undetermined(lines, ties, clusters, n_logs, drift_logs) -> str:
    linked = {lg: set() for lg in range(n_logs)}
    for cl in clusters:
        lg = {lines[i].log for i in cl.lines}
        for a in lg:
            linked[a] |= lg
    tied = {t.log for t in ties}
    alone = [lg for lg in range(n_logs) if lg not in tied and linked[lg] <= {lg}]
    msg = "the network is not determined"
    if alone and (tied or n_logs > 1):
        msg += f": log(s) {', '.join(f'B{lg + 1}' for lg in alone)} share no point with another log and have no tie"
    elif drift_logs:
        msg += (
            ": a linear drift is not separable from the line biases (give ties at the start and end, "
            "or network_drift=none)"
        )
    return msg


# ---------------------------------------------------------------------------------------------
# statistics before and after


def repeat_rms(clusters: list[Cluster], values) -> float | None:
    """Internal coincidence of all repeat points: sqrt(Σ δ²/Σ(n_p − 1)) about each point's mean;
    ``values(cluster)`` gives the cluster's values (raw or adjusted)."""
    num = den = 0.0
    for cl in clusters:
        if cl.kind != "repeat":
            continue
        x = values(cl)
        num += float(np.sum((x - x.mean()) ** 2))
        den += len(x) - 1
    return float(np.sqrt(num / den)) if den else None


def crossover_rms(clusters: list[Cluster], groups: list[list[int]], values) -> tuple[float | None, np.ndarray]:
    """Crossover ε = sqrt(Σ d²/(2N)) over the differences of every line of one group with every line
    of the other at each crossing; also the differences themselves."""
    d = []
    for cl in clusters:
        if cl.kind != "crossing":
            continue
        x = values(cl)
        ga = np.array([i in groups[cl.group[0]] for i in cl.lines])
        for va in x[ga]:
            for vb in x[~ga]:
                d.append(va - vb)
    d = np.array(d)
    return (float(np.sqrt(np.sum(d**2) / (2 * len(d)))) if len(d) else None), d


def coincidence_of_group(lines: list[Line], group: list[int], spacing_m: float, offsets=None):
    """:func:`internal_coincidence` of one repeat group (values minus ``offsets(i, t)`` when given)."""
    ref = max(group, key=lambda i: len(lines[i].e_m))
    r = lines[ref]
    step = max(1, len(r.e_m) // 4000)
    pairs = []
    for i in group:
        s, _ = along_track(r.e_m[::step], r.n_m[::step], lines[i].e_m, lines[i].n_m)
        v = lines[i].dg_mgal if offsets is None else lines[i].dg_mgal - offsets(i, lines[i].t_s)
        pairs.append((s, v))
    grid, vals = common_points(pairs, spacing_m, allow_holes=True)
    return internal_coincidence(vals, [lines[i].name for i in group], grid)


def leave_one_line_out(lines: list[Line], clusters: list[Cluster], ties: list[Tie], n_logs: int, **adjust_kw) -> dict:
    """Prediction errors of each line from the others and the ties (the network adjusted without it).

    For each line l: the adjustment of the other lines and the ties; at every point p of l with at least
    one other line, e = (v_l(p) − b̂_L − d̂_L·(t − t_L)) − Ĝ(p), Ĝ the weighted mean of the other lines'
    adjusted values there (l's own line bias is not known without it: taken as zero, its expectation).
    e·√(m/(m+1)) (m other lines at p) has the variance σ_l² for independent lines of equal floor, so the
    RMS is comparable to the white floor, unlike the fit's residuals, which have spent its degrees of
    freedom. Returns ``{"repeat": rms, "crossing": rms, "lines": [rms per line or None]}`` (None where
    the network without the line is not determined or the line shares no point)."""
    sums = {"repeat": [0.0, 0], "crossing": [0.0, 0]}
    per_line = []
    for leave in range(len(lines)):
        keep = [i for i in range(len(lines)) if i != leave]
        new = {old: k for k, old in enumerate(keep)}
        sub = []
        for cl in clusters:
            m = cl.lines != leave
            if m.sum() >= 2:
                vs = np.broadcast_to(np.asarray(cl.var_scale, float), (len(cl.lines),))[m]
                sub.append(
                    Cluster(
                        cl.kind,
                        cl.group,
                        cl.e_m,
                        cl.n_m,
                        np.array([new[int(i)] for i in cl.lines[m]]),
                        cl.values[m],
                        cl.t_s[m],
                        vs.copy(),
                    )
                )
        try:
            adj = adjust([lines[i] for i in keep], sub, ties, n_logs, **adjust_kw)
        except ValueError:
            per_line.append(None)
            continue
        ln = lines[leave]
        num, den = 0.0, 0
        for cl in clusters:
            at = np.flatnonzero(cl.lines == leave)
            others = np.flatnonzero(cl.lines != leave)
            if not len(at) or not len(others):
                continue
            j = at[0]
            vo = np.array(
                [
                    cl.values[k] - adj.correction(lines[cl.lines[k]].log, new[int(cl.lines[k])], cl.t_s[k])[0]
                    for k in others
                ]
            )
            wo = np.array([1.0 / lines[cl.lines[k]].sigma_mgal ** 2 for k in others])
            g_hat = float(np.sum(wo * vo) / np.sum(wo))
            e = cl.values[j] - adj.correction(ln.log, None, cl.t_s[j])[0] - g_hat
            e2 = e * e * len(others) / (len(others) + 1)
            if not np.isfinite(e2):
                continue
            sums[cl.kind][0] += e2
            sums[cl.kind][1] += 1
            num += e2
            den += 1
        per_line.append(float(np.sqrt(num / den)) if den else None)
    out = {k: (float(np.sqrt(s / n)) if n else None) for k, (s, n) in sums.items()}
    out["lines"] = per_line
    return out
