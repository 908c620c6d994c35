"""Filtering, line cutting and the statistics of the ``gravity`` pipeline (methods §4, §4a).

Every figure in mGal; every line's statistics beside what gaps and trimming removed from it.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from ldvsurvey.errors import ParameterError
from ldvsurvey.nav.coincidence import Coincidence, along_track, common_points, crossovers, internal_coincidence
from ldvsurvey.nav.gravity import (
    G0,
    MGAL,
    Lowpass,
    noise_floor_mgal,
    runs,
    second_difference_noise_gain,
    trim_line,
)
from ldvsurvey.pipelines.stages.aids import local_metres

#: filtered values are withheld where bridged samples take more than this share of the FIR's weight …
MAX_BRIDGED_SHARE = 0.5
#: … or where long gaps (detail the filter would resolve is missing) take more than this
MAX_LONG_GAP_SHARE = 0.01
#: a gap is long when it lasts more than this share of the FIR length
LONG_GAP_FIR_SHARE = 0.5
#: crossings at a smaller angle are repeated passes over the same road, not crossovers
CROSSOVER_MIN_ANGLE_DEG = 20.0


def edge_gain_max(floor: dict) -> float:
    """The height-noise gain g at which a break doubles a SINS/GNSS chain's white variance.

    ``floor``: :func:`floor_of` of the chain (σ_tot² = σ_acc² + σ_h²). Next to a break the heights'
    share grows to g²·σ_h², so the variance doubles where (g² − 1)·σ_h² = σ_tot²:
    g = √(1 + σ_tot²/σ_h²) (√2 when the heights are the only noise given)."""
    return float(np.sqrt(1.0 + (floor["total_mgal"] / floor["gnss_height_mgal"]) ** 2))


def break_edges(ch, lowpass: Lowpass):
    """Samples of a double-differenced chain (GNSS heights) withheld next to its breaks.

    Next to a break (NaN δg) the truncated FIR keeps an edge velocity error of the heights nearly
    unweighted: the white-height-noise σ of the filtered value grows from the interior floor to tens of
    mGal (:func:`second_difference_noise_gain`). Withheld where the break at least doubles the chain's
    white variance (accelerometer and heights): ``ch["edge_gain_max"]`` from :func:`edge_gain_max`."""
    gmax = ch.get("edge_gain_max")
    if not gmax:
        return np.zeros(len(ch["dg"]), bool)
    gain = second_difference_noise_gain(np.isfinite(ch["dg"]), lowpass.at(ch["fs"]))
    return ~(gain <= gmax)


def imu_bridge_sigma_mgal(ch, lowpass: Lowpass, t_s):
    """σ (mGal) that the lost IMU rows' bridges leave in the chain's filtered δg at the times ``t_s``.

    Each bridge leaves a velocity error of σ_g (m/s, :func:`chains.lost_increment_sigmas`) in
    f_U·Δt: an impulse of that area in δg, which the zero-phase FIR (kernel h⋆h, unit sum, over the
    chain's sampling interval Δt) turns into σ_g·(h⋆h)(t − t_g)/Δt. Independent bridges add in
    variance. A bridge without a measured σ (too little clean data next to it) counts as NaN.

    Parameters
    ----------
    ch : dict
        A chain (:mod:`chains`) with ``fs`` (Hz) and ``imu_bridges`` [(t_s, duration s, σ_g m/s)].
    lowpass : Lowpass
        The gravity filter.
    t_s : array_like
        Times (s) at which the σ is wanted.

    Returns
    -------
    numpy.ndarray
        1-σ at ``t_s``, mGal.
    """
    t_s = np.asarray(t_s, float)
    var = np.zeros(len(t_s))
    bridges = ch.get("imu_bridges") or []
    if not bridges or not len(t_s):
        return np.sqrt(var) / MGAL
    fs = ch["fs"]
    h2 = lowpass.at(fs).kernel
    c = len(h2) // 2
    lo, hi = float(t_s.min()) - c / fs, float(t_s.max()) + c / fs
    for t_g, _dur, sig in bridges:
        if not lo <= t_g <= hi:  # beyond the kernel's reach
            continue
        d = np.rint((t_s - t_g) * fs).astype(np.int64)
        near = np.abs(d) <= c
        if near.any():
            var[near] += (sig * fs * h2[c + d[near]]) ** 2
    return np.sqrt(var) / MGAL


def with_imu_bridges(floor: dict, res: Evaluation) -> dict:
    """The floor with the lost IMU rows' term: ``imu_bridge_mgal`` the RMS over the lines of their
    cost (the coincidence's expected square is the lines' mean variance), added in quadrature to
    ``combined_mgal`` (the white floor and the drift term, where present)."""
    used = [ln for ln in res.lines if ln.has_data and ln.imu_bridges_recorded]
    if not used:
        return floor
    costs = [ln.imu_bridge_cost_mgal for ln in used]
    out = dict(floor)
    known = [c for c in costs if c is not None]
    term = float(np.sqrt(np.mean(np.square(known)))) if known else None
    out["imu_bridge_mgal"] = term
    out["imu_bridge_source"] = (
        "IMU rows lost and bridged by prediction: the prediction's error measured next to every gap "
        "(leave-out of as many real rows), through the FIR"
        + ("" if len(known) == len(costs) else f"; {len(costs) - len(known)} line(s) without a measured σ")
    )
    base = out.get("combined_mgal", out.get("total_mgal"))
    if term is not None and base:
        out["combined_mgal"] = float(np.hypot(base, term))
    return out


def unsupported(bridged, lowpass: Lowpass, den_cache=None):
    """Samples whose filtered value is mostly the bridge rather than data (see MAX_*_SHARE).

    ``lowpass``: bound to the series' rate. ``den_cache``: see :meth:`Lowpass.apply` (both shares are
    series without gaps)."""
    long = np.zeros(len(bridged), bool)
    for a, b in runs(bridged):
        if (b - a) / lowpass.rate_hz > LONG_GAP_FIR_SHARE * lowpass.length_s:
            long[a:b] = True
    share = lowpass.apply(bridged.astype(float), den_cache=den_cache)
    share_long = lowpass.apply(long.astype(float), den_cache=den_cache) if long.any() else np.zeros(len(bridged))
    return ~((share <= MAX_BRIDGED_SHARE) & (share_long <= MAX_LONG_GAP_SHARE))


def leveling_fit(vals, grid_m, mode):
    """Per-line adjustment (n, m) in mGal of lines on common points about their mean line.

    ``bias``: each line's mean residual; ``linear``: each line's least-squares a + b·s fit of its
    residual (a drift varying linearly along the line). The residuals sum to zero at every point,
    so the adjustments do too: what all lines share (Δg and the common part of the drift) stays;
    only the lines' differences from each other are removed (a repeat-line adjustment)."""
    res = vals - np.nanmean(vals, axis=0)
    if mode == "bias":
        return np.repeat(np.nanmean(res, axis=1)[:, None], vals.shape[1], axis=1)
    x = (grid_m - grid_m.mean()) / max(float(np.ptp(grid_m)), 1e-9)
    out = np.empty_like(vals)
    for i, r in enumerate(res):
        ok = np.isfinite(r)
        a = np.polyfit(x[ok], r[ok], 1)
        out[i] = np.polyval(a, x)
    return out


@dataclass(frozen=True, eq=False)
class LineResult:
    """One survey line of one chain after filtering, cutting and trimming.

    The arrays run over the line's trimmed samples that hold a filtered value (empty: no data); the
    distances are in the local metres of the survey's first line.
    """

    name: str
    chain: int  #: index of the chain (bundle) the line is in
    samples: np.ndarray  #: indices of those samples in the chain (sorted)
    along_m: np.ndarray  #: along-track distance on the reference line, m
    lateral_m: np.ndarray  #: lateral offset from the reference line, m
    east_m: np.ndarray  #: local east, m
    north_m: np.ndarray  #: local north, m
    bridged_s: float  #: LDV/GNSS data bridged on the whole line, s
    bridged_share: float  #: that share of the line's samples
    unsupported_s: float  #: filtered values withheld on the line, s
    duration_s: float  #: the line as given, s
    trimmed_duration_s: float  #: the line less its trimmed ends, s
    imu_bridges_recorded: bool = False  #: the chain records lost IMU rows (the next two fields apply)
    imu_bridged_s: float | None = None  #: lost IMU rows bridged on the line, s
    imu_bridge_cost_mgal: float | None = None  #: their RMS σ on the line's values, mGal (None: not measured)
    no_data: bool = False  #: no sample of the line holds a supported value

    @property
    def has_data(self) -> bool:
        """Whether the line holds filtered values."""
        return len(self.along_m) > 0

    def info(self) -> dict:
        """The line's entries of a summary block (durations in s, costs in mGal)."""
        out = {
            "bridged_s": self.bridged_s,
            "bridged_share": self.bridged_share,
            "unsupported_s": self.unsupported_s,
            "duration_s": self.duration_s,
            "trimmed_duration_s": self.trimmed_duration_s,
        }
        if self.imu_bridges_recorded:
            out["imu_bridged_s"] = self.imu_bridged_s
            out["imu_bridge_cost_mgal"] = self.imu_bridge_cost_mgal
        if self.no_data:
            out["no_data"] = True
        return out


@dataclass(eq=False)
class Evaluation:
    """The filtered chains, their lines and the statistics of one chain kind (:func:`evaluate`)."""

    filtered: list  #: per chain, filtered δg in m/s² (NaN where withheld; levelled lines when chosen)
    unsupported: list  #: per chain, mask of the samples whose filtered value is withheld
    lines: list  #: :class:`LineResult` per line, in the order given
    repeated: bool = False  #: every line runs along the first (median lateral offset below 50 m)
    crossings: list = field(default_factory=list)  #: crossovers of the lines' tracks
    crossover_mgal: float | None = None  #: crossover RMS, mGal
    median_speed_mps: float | None = None  #: over the lines' samples, m/s
    resolution_m: float | None = None  #: nominal half-wavelength v·L/2 at that speed, m
    coincidence: Coincidence | None = None  #: internal coincidence on the common points
    coincidence_note: str | None = None  #: why there is none (comparison chains)
    line_offsets_mgal: dict | None = None  #: line levelling: each line's mean adjustment, mGal
    line_slopes_mgal_per_km: dict | None = None  #: linear levelling: each line's slope, mGal/km

    @property
    def used(self) -> list:
        """The lines that hold data."""
        return [ln for ln in self.lines if ln.has_data]


def filter_chain(ch, lowpass: Lowpass) -> tuple[np.ndarray, np.ndarray]:
    """The chain's filtered δg (m/s², NaN where withheld) and the mask of withheld samples.

    Withheld: values mostly made of bridged data (:func:`unsupported`) and, in a double-differenced
    chain, the samples next to its breaks (:func:`break_edges`). The chain is not changed."""
    lp = lowpass.at(ch["fs"])
    den_cache = {}  # δg without gaps and the bridged shares: one filtered mask for all of them
    f = lp.apply(ch["dg"], den_cache=den_cache)
    withheld = unsupported(ch["bridged"], lp, den_cache) | break_edges(ch, lowpass)
    del den_cache
    f[withheld] = np.nan
    return f, withheld


def cut_line(ch, filtered, withheld, line, trim_s: float, lowpass: Lowpass) -> LineResult:
    """The samples of ``line`` (name, chain index, t0 s, t1 s) kept after trimming ``trim_s`` (s) at both
    ends, and what bridges, withheld values and lost IMU rows took from it (no geometry yet)."""
    name, ci, a, b = line
    t = ch["t_s"]
    if bool(np.all(t[1:] >= t[:-1])):  # the line's samples by bisection, not by masks over the whole log
        whole = slice(np.searchsorted(t, a, "left"), np.searchsorted(t, b, "right"))
        j0, j1 = np.searchsorted(t, a + trim_s, "left"), np.searchsorted(t, b - trim_s, "right")
        k = j0 + np.flatnonzero(np.isfinite(filtered[j0 : max(j0, j1)]))
    else:
        whole = (t >= a) & (t <= b)
        k = np.flatnonzero(trim_line(t, a, b, trim_s) & np.isfinite(filtered))
    # (the line's samples as indices: a mask per line would be a byte per sample of the log, per line)
    imu = {}
    if "imu_bridges" in ch:  # IMU rows lost on the line, bridged by prediction, and their cost
        sig = imu_bridge_sigma_mgal(ch, lowpass, t[k]) if len(k) else np.zeros(0)
        cost = float(np.sqrt(np.mean(sig**2))) if len(sig) else None
        imu = {
            "imu_bridges_recorded": True,
            "imu_bridged_s": float(sum(d for tg, d, _ in ch["imu_bridges"] if a <= tg <= b)),
            # None where a bridge next to the line has no measured σ (too little clean data around it)
            "imu_bridge_cost_mgal": cost if cost is None or np.isfinite(cost) else None,
        }
    empty = np.zeros(0)
    return LineResult(
        name,
        ci,
        k,
        empty,
        empty,
        empty,
        empty,
        bridged_s=float(np.sum(ch["bridged"][whole]) / ch["fs"]),
        bridged_share=float(np.mean(ch["bridged"][whole])) if ch["bridged"][whole].size else 0.0,
        unsupported_s=float(np.sum(withheld[whole]) / ch["fs"]),
        duration_s=float(b - a),
        trimmed_duration_s=float(max(0.0, b - a - 2 * trim_s)),
        **imu,
    )


def place_lines(chains, cut: list) -> list:
    """The lines with data placed along the first of them: along-track distance, lateral offset, east and
    north (m) of every kept sample in the local metres of the first line's first sample."""
    ref = None
    out = []
    for ln in cut:
        if len(ln.samples) < 10:
            out.append(ln)
            continue
        ch, k = chains[ln.chain], ln.samples
        if ref is None:
            lat0, lon0 = ch["lat"][k][0], ch["lon"][k][0]
            e, n = local_metres(lat0, lon0, ch["lat"][k], ch["lon"][k])
            step = max(1, int(len(e) // 4000))
            ref = (lat0, lon0, e[::step], n[::step])
        e, n = local_metres(ref[0], ref[1], ch["lat"][k], ch["lon"][k])
        s, lateral = along_track(ref[2], ref[3], e, n)
        out.append(replace(ln, along_m=s, lateral_m=lateral, east_m=e, north_m=n))
    return out


def line_coincidence(chains, filtered, used, line_times, spacing_m: float, strict: bool, leveling: str) -> dict:
    """The internal coincidence of repeated lines on their common points (mGal), with line levelling.

    ``line_times``: {name: (t0, t1)}. With ``leveling`` "bias" or "linear" each line's fit about the mean
    line (:func:`leveling_fit`) is removed from its filtered values in ``filtered`` (arrays this
    evaluation owns) and the coincidence is that of the levelled lines. Returns the
    :class:`Evaluation` fields it sets."""
    out = {}
    try:
        grid, vals = common_points(
            [(ln.along_m, filtered[ln.chain][ln.samples] / MGAL) for ln in used], spacing_m, allow_holes=not strict
        )
        co = internal_coincidence(vals, [ln.name for ln in used], grid)
        if leveling in ("bias", "linear"):
            fit = leveling_fit(vals, grid, leveling)
            out["line_offsets_mgal"] = {nm: float(np.mean(o)) for nm, o in zip(co.names, fit)}
            if leveling == "linear":
                out["line_slopes_mgal_per_km"] = {
                    nm: float((o[-1] - o[0]) / max(grid[-1] - grid[0], 1e-9) * 1e3) for nm, o in zip(co.names, fit)
                }
            for ln, o in zip(used, fit):
                t = chains[ln.chain]["t_s"]
                line_all = (t >= line_times[ln.name][0]) & (t <= line_times[ln.name][1])
                # along the line at its own distances (constant beyond the common stretch)
                s_all = np.interp(t[line_all], t[ln.samples], ln.along_m)
                filtered[ln.chain][line_all] -= np.interp(s_all, grid, o) * MGAL
            co = internal_coincidence(vals - fit, co.names, grid)
        out["coincidence"] = co
    except ValueError as exc:
        if strict:
            raise ParameterError(f"no coincidence: {exc}", field="lines") from None
        out["coincidence_note"] = str(exc)
    return out


def evaluate(chains, lines, lowpass: Lowpass, spacing_m: float, trim_s: float, *, strict=True, leveling="none"):
    """Filter each chain, cut and trim the lines, put them on common points, compute the statistics.

    Nothing passed in is changed: the filtered series are the result's own.

    Parameters
    ----------
    chains : list of dict
        Raw chains (see :mod:`chains`): δg in m/s² at their rate ``fs`` (Hz).
    lines : list of tuple
        (name, chain index, t0 s, t1 s) per line.
    lowpass : Lowpass
        The gravity filter (bound to each chain's rate here).
    spacing_m : float
        Spacing of the common along-track points, m.
    trim_s : float
        Trimmed at both ends of every line, s.
    strict : bool
        A line without data is an error (the main chain); otherwise (a comparison chain, e.g. GNSS
        blocked on a whole line) the line is reported without figures.
    leveling : {"none", "bias", "linear"}
        Every line shifted by its mean residual about the mean line (bias) or by its linear drift along
        it (linear): removes each line's share of a drift the stops could not tie (the shifts sum to zero,
        so the level of the survey stays); the coincidence is that of the levelled lines.

    Returns
    -------
    Evaluation
        Filtered chains, per-line results and statistics (mGal).
    """
    filtered, withheld = zip(*(filter_chain(ch, lowpass) for ch in chains)) if chains else ((), ())
    filtered, withheld = list(filtered), list(withheld)
    cut = [cut_line(chains[ln[1]], filtered[ln[1]], withheld[ln[1]], ln, trim_s, lowpass) for ln in lines]
    for ln, (_, _, a, b) in zip(cut, lines):
        if len(ln.samples) < 10 and strict:
            raise ParameterError(
                f"line {ln.name} [{a}, {b}] s holds no data after trimming {trim_s:g} s at each end",
                field="lines" if trim_s == 0 else "line_end_trim_s",
            )
    per_line = [ln if len(ln.samples) >= 10 else replace(ln, no_data=True) for ln in place_lines(chains, cut)]
    out = Evaluation(filtered, withheld, per_line)
    used = out.used
    if not used:
        if strict:
            raise ValueError("no line holds data")
        # a comparison chain without a supported value on any line (e.g. RTK only in stretches shorter
        # than the FIR): every line reported as holding no data, nothing smeared over them
        out.coincidence_note = "no line holds a supported value"
        return out
    out.repeated = all(np.median(ln.lateral_m) < 50.0 for ln in used)
    if out.repeated and len(used) >= 2:
        line_times = {name: (a, b) for name, _, a, b in lines}
        for k, v in line_coincidence(chains, filtered, used, line_times, spacing_m, strict, leveling).items():
            setattr(out, k, v)
    step = max(1, int(round(chains[0]["fs"] * 2.0)))  # ~2 s along the tracks
    tracks = [(ln.east_m[::step], ln.north_m[::step], filtered[ln.chain][ln.samples][::step] / MGAL) for ln in used]
    out.crossings, out.crossover_mgal = crossovers(tracks, CROSSOVER_MIN_ANGLE_DEG)
    speeds = np.concatenate([chains[ln.chain]["speed"][ln.samples] for ln in used])
    out.median_speed_mps = float(np.nanmedian(speeds))
    out.resolution_m = lowpass.nominal_half_wavelength_m(out.median_speed_mps)
    return out


def floor_of(log, chain, lowpass: Lowpass):
    """White-noise floor (mGal) of the coincidence for one chain, with where each noise figure came from.

    The manifest's ``imu.accel_noise_ug_per_rthz`` and ``gnss.height_noise`` are overrides; without
    them the figures are estimated from the log itself: the accelerometer density from the static
    start (:func:`static_accel_noise_ug_rthz`), the GNSS height noise from the SINS/GNSS chain's own
    raw δg (:func:`fit_height_noise`)."""
    acc = log.manifest.imu.accel_noise_ug_per_rthz
    out = {"accel_noise_ug_rthz": acc, "accel_noise_source": "manifest" if acc else "not given"}
    if not acc:
        est = static_accel_noise_ug_rthz(log, chain.get("still"))
        if est is not None:
            acc, (a, b) = est
            out.update(
                accel_noise_ug_rthz=acc,
                accel_noise_source=f"estimated from the static start ({a:.1f}–{b:.1f} s): scatter of the "
                "vertical specific force (first differences), as a density",
            )
    if chain["kind"] == "ldv":
        ldv_sig = getattr(log.manifest.ldv, "noise_mps", None)
        src = "manifest"
        if not isinstance(ldv_sig, (int, float)) or not ldv_sig > 0:
            ldv_sig, src = chain.get("ldv_noise_mps"), "estimated from the data (second differences)"
        out.update(ldv_noise_mps=ldv_sig, ldv_noise_source=src, ldv_rate_hz=log.manifest.ldv.rate_hz)
        out.update(noise_floor_mgal(lowpass, acc, ldv_sig, log.manifest.ldv.rate_hz))
        return out
    stated = _stated_height_noise(log, chain)
    if stated is not None:
        white, corr, tau = stated
        out.update(
            gnss_height_sigma_m=white,
            gnss_height_correlated_m=corr,
            gnss_height_correlation_s=tau,
            gnss_height_sigma_source="manifest gnss.height_noise (white and Gauss-Markov parts, by fix quality)",
        )
        out.update(
            noise_floor_mgal(
                lowpass,
                acc,
                height_noise_m=white,
                gnss_rate_hz=chain["fs"],
                height_correlated_m=corr,
                height_correlation_s=tau,
            )
        )
        return out
    fit = fit_height_noise(chain, lowpass, acc)
    if fit is None:
        out.update(gnss_height_sigma_m=chain["height_sigma_m"], gnss_height_sigma_source="fix quality")
        out.update(noise_floor_mgal(lowpass, acc, height_noise_m=chain["height_sigma_m"], gnss_rate_hz=chain["fs"]))
        return out
    white, q, n_seg = fit
    out.update(
        gnss_height_sigma_m=white,
        gnss_height_random_walk_m2_per_s=q,
        gnss_height_sigma_source=f"fitted to the chain's raw δg ({n_seg} segments of {HEIGHT_FIT_SEGMENT_S:g} s, "
        f"{2.0 / lowpass.length_s:.4f}–{0.5 * chain['fs']:.2f} Hz): white heights plus a random-walk wander",
    )
    out.update(noise_floor_mgal(lowpass, acc, height_noise_m=white, gnss_rate_hz=chain["fs"]))
    out["gnss_height_correlated_mgal"] = height_wander_floor_mgal(lowpass, q)
    parts = [v for k, v in out.items() if k.endswith("_mgal") and k != "total_mgal" and v]
    out["total_mgal"] = float(np.sqrt(sum(v**2 for v in parts)))
    return out


#: length of the segments of the height-noise fit's averaged periodogram (s)
HEIGHT_FIT_SEGMENT_S = 256.0
#: the fit uses the periodogram from this many cycles per FIR length up (above the pass band)
HEIGHT_FIT_MIN_FIR_CYCLES = 1.0
#: shortest static start the accelerometer density is estimated from (s)
MIN_STATIC_S = 30.0


def static_accel_noise_ug_rthz(log, still):
    """Accelerometer white-noise density (µg/√Hz) from the log's static start, and that interval.

    ``still``: the navigation's still intervals (the first one starts with the log when it begins at
    rest). The vertical specific force per sample (Δv along its own mean direction over Δt) scatters
    by σ = N·√f_s for a density N; its first differences remove the gravity, the bias and any slow
    drift, so σ = robust σ of the differences / √2. Engine vibration at rest, if any, counts as noise
    (it is there on the move too). None without a static start of :data:`MIN_STATIC_S`.
    """
    imu = getattr(log, "imu", None)
    if not still or imu is None:
        return None
    a, b = still[0]
    t = np.asarray(imu.t_s, float)
    if b - a < MIN_STATIC_S or a > t[0] + 1.0:
        return None
    k = np.flatnonzero((t >= a) & (t <= b))
    k = k[k > 0]
    dt = t[k] - t[k - 1]
    f = np.asarray(imu.dvel_mps, float)[k] / dt[:, None]
    up = np.mean(f, axis=0)
    fz = f @ (up / np.linalg.norm(up))
    d = np.diff(fz)
    sig = 1.4826 * np.median(np.abs(d - np.median(d))) / np.sqrt(2.0)
    fs = 1.0 / float(np.median(dt))
    return float(sig / np.sqrt(fs) / G0 * 1e6), (float(a), float(b))


def fit_height_noise(chain, lowpass: Lowpass, accel_noise_ug_rthz=None):
    """(white σ m, random-walk intensity q m²/s, segments used) of the GNSS heights of a SINS/GNSS
    chain, fitted to the chain's raw δg; None when too little of it is continuous.

    Why the raw δg and not the GNSS-minus-INS height residual: the smoothed INS height is pulled to
    the fixes, and on a drive it follows their wander completely (the residual of a simulated RTK
    drive holds only the white part: its structure function is flat from 1 s to 300 s lags), so the
    residual hides exactly the part that dominates the floor. The raw δg (second differences of the
    GNSS heights less the twice-integrated specific force, before the FIR) sees no filter: above the
    FIR's pass band (f ≥ :data:`HEIGHT_FIT_MIN_FIR_CYCLES`/L) it holds the disturbance's
    negligible tail and the noise only, with a two-sided PSD

        S(f) = N²g²  +  σ_w² f_s³ (2 sin πf/f_s)⁴  +  q f_s² (2 sin πf/f_s)²

    (accelerometer density N from the manifest or the static start; white heights σ_w per epoch;
    a wander whose increments have variance q·Δt, i.e. a Gauss-Markov σ_c, τ with q = 2σ_c²/τ seen
    at f ≫ 1/(2πτ)). σ_w² and q are fitted by Whittle's likelihood to the Hann-windowed, half-overlapped
    periodogram of the continuous stretches, the model seen through the window's spectral kernel.
    Whatever else of the INS reaches the raw δg there (attitude error times acceleration in turns)
    counts as height noise: it is noise of the chain too. The fit's scatter on a 24-min log is about
    30 % in q and 2 % in σ_w (30 synthetic realizations). Only q reaches the floor in that regime (the correlation
    time of a wander slower than the FIR is not resolved by it, and taking it as a random walk bounds
    the floor from above; by 1.4 % for τ = 2·L, 5 % for τ = L; L = ``lowpass.length_s``).
    """
    from scipy.optimize import minimize

    fs = float(chain["fs"])
    n = int(round(HEIGHT_FIT_SEGMENT_S * fs))
    dg = np.asarray(chain["dg"], float)
    win = np.hanning(n)
    pers = []
    for a, b in runs(np.isfinite(dg)):
        for i in range(a, b - n + 1, n // 2):
            x = dg[i : i + n]
            pers.append(np.abs(np.fft.rfft((x - x.mean()) * win)) ** 2 / (np.sum(win**2) * fs))  # two-sided PSD
    if len(pers) < 2:
        return None
    f = np.fft.rfftfreq(n, 1.0 / fs)
    use = (f >= HEIGHT_FIT_MIN_FIR_CYCLES / lowpass.length_s) & (f < 0.5 * fs)
    p = np.mean(pers, axis=0)[use]
    # the periodogram's expectation is the PSD seen through the window's spectral kernel; the steep
    # white-height term (∝ f⁴) would otherwise spill into the low bins and pass for a wander
    over = 8
    ff = np.arange(n * over) * fs / (n * over)
    kern = np.abs(np.fft.fft(win, n * over)) ** 2
    kern /= kern.sum()
    s_ff = (2.0 * np.sin(np.pi * ff / fs)) ** 2
    basis = [np.real(np.fft.ifft(np.fft.fft(kern) * np.fft.fft(b)))[::over][: n // 2 + 1][use] for b in (s_ff**2, s_ff)]
    b_white, b_walk = basis[0] * fs**3, basis[1] * fs**2
    acc = ((accel_noise_ug_rthz or 0.0) * 1e-6 * G0) ** 2

    def model(x):
        return acc + np.exp(x[0]) * b_white + np.exp(x[1]) * b_walk

    def nll(x):
        m = model(x)
        return float(np.sum(np.log(m) + p / m))

    x0 = np.log([max(np.median(p / b_white), 1e-12), 1e-7])
    best = min((minimize(nll, x0 + [0.0, d], method="Nelder-Mead") for d in (0.0, 6.0, 12.0)), key=lambda r: r.fun)
    return float(np.sqrt(np.exp(best.x[0]))), float(np.exp(best.x[1])), len(pers)


def height_wander_floor_mgal(lowpass: Lowpass, q_m2_per_s):
    """1-σ (mGal) of a random-walk height wander (increments' variance q·Δt, q in m²/s, two-sided PSD
    q/(2πf)²) differenced twice and through the zero-phase FIR: σ² = q ∫(2πf)²|H|⁴ df (as
    :func:`ldvsurvey.nav.gravity.noise_floor_mgal` integrates its terms: :meth:`Lowpass.noise_integral`)."""
    return float(np.sqrt(q_m2_per_s * lowpass.noise_integral(2)) / MGAL)


def _stated_height_noise(log, chain):
    """(white σ m, wandering σ m, correlation time s) of the GNSS heights the chain used, from the
    manifest's ``gnss.height_noise`` (the variances averaged over the chain's fixes by count); None
    when the manifest states none for a fix quality the chain used."""
    stated = log.manifest.gnss.height_noise
    g = log.gnss
    if not stated or g is None:
        return None
    t = chain["t_s"]
    k = np.isin(g.fix, chain.get("fixes", (4,))) & (g.t_s >= t[0]) & (g.t_s <= t[-1])
    qs, counts = np.unique(g.fix[k], return_counts=True)
    if not len(qs) or any(str(int(q)) not in stated for q in qs):
        return None
    w = counts / counts.sum()
    parts = [stated[str(int(q))] for q in qs]
    white = float(np.sqrt(np.sum(w * [p.white_m**2 for p in parts])))
    corr = float(np.sqrt(np.sum(w * [p.correlated_m**2 for p in parts])))
    tau = float(np.sum(w * [p.correlation_s for p in parts]))
    return white, corr, tau


def block(res: Evaluation, lowpass: Lowpass, trim_s: float, aiding: str, floor: dict) -> dict:
    """The summary block of one chain: filter, lines, coincidence beside its floor, crossovers (mGal, m, s).

    Parameters
    ----------
    res : Evaluation
        :func:`evaluate` of the chain.
    lowpass : Lowpass
        The gravity filter.
    trim_s : float
        Trimmed at both ends of every line, s.
    aiding : str
        What the chain's vertical acceleration comes from ("ldv", "gnss", "ldv+gnss").
    floor : dict
        :func:`floor_of` (with the drift and IMU-bridge terms where present).

    Returns
    -------
    dict
        The block as the summary holds it.
    """
    out = {
        "fir_length_s": lowpass.length_s,
        "aiding": aiding,
        "resolution_m": res.resolution_m,
        "median_speed_mps": res.median_speed_mps,
        "repeated_lines": res.repeated,
        "line_end_trim_s": trim_s,
        "line_ends": f"{trim_s:g} s trimmed at both ends of every line (FIR leakage of turnarounds, "
        "acceleration and braking)"
        if trim_s > 0
        else "lines not trimmed",
        "noise_floor": floor,
    }
    co = res.coincidence
    stats = {}
    if co is not None:
        stats = {
            nm: {
                "max_mgal": float(mx),
                "min_mgal": float(mn),
                "rms_mgal": float(r),
                "mean_mgal": float(me),
                "std_mgal": float(sd),
            }
            for nm, mx, mn, r, me, sd in zip(
                co.names, co.per_line_max, co.per_line_min, co.per_line_rms, co.per_line_mean, co.per_line_std
            )
        }
    none = {"max_mgal": None, "min_mgal": None, "rms_mgal": None, "mean_mgal": None, "std_mgal": None}
    out["lines"] = [{"name": ln.name, **stats.get(ln.name, none), **ln.info()} for ln in res.lines]
    out["total_mgal"] = co.total if co is not None else None
    out["n_lines_compared"] = len(co.names) if co is not None else 0
    out["common_length_m"] = float(co.distance_m[-1] - co.distance_m[0]) if co is not None else None
    out["common_points"] = int(len(co.distance_m)) if co is not None else 0
    out["floor_ratio"] = co.total / floor["total_mgal"] if co is not None and floor.get("total_mgal") else None
    comb = floor.get("combined_mgal")
    out["combined_floor_ratio"] = co.total / comb if co is not None and comb else None
    if res.line_offsets_mgal is not None:
        lin = res.line_slopes_mgal_per_km is not None
        out["line_leveling"] = {
            "method": ("linear drift per line" if lin else "bias") + " about the mean line (repeat-line adjustment)",
            "offsets_mgal": res.line_offsets_mgal,
            "note": "coincidence of the adjusted lines: internal and optimistic (the adjustment "
            f"takes {2 if lin else 1} degree(s) of freedom per line and removes the "
            "lines' differing drift, not the drift they share, which stays in the "
            "absolute values)",
        }
        if lin:
            out["line_leveling"]["slopes_mgal_per_km"] = res.line_slopes_mgal_per_km
    if res.coincidence_note is not None:
        out["coincidence_note"] = res.coincidence_note
    out["crossover_mgal"] = res.crossover_mgal
    out["n_crossings"] = len(res.crossings)
    out["bridged_s"] = float(sum(ln.bridged_s for ln in res.lines))
    return out


def chain_difference(res_a: Evaluation, chains_a, res_b: Evaluation, chains_b) -> list[dict]:
    """Per line: mean and RMS (mGal) of filtered chain A minus chain B at A's (trimmed) line samples."""
    out = []
    for pa, pb in zip(res_a.lines, res_b.lines):
        if not pa.has_data or not pb.has_data:
            out.append({"name": pa.name, "mean_mgal": None, "rms_mgal": None})
            continue
        ta = chains_a[pa.chain]["t_s"][pa.samples]
        tb = chains_b[pb.chain]["t_s"]
        fb = res_b.filtered[pb.chain]
        d = (res_a.filtered[pa.chain][pa.samples] - np.interp(ta, tb, fb)) / MGAL  # withheld (NaN) stay out
        d = d[np.isfinite(d)]
        out.append(
            {
                "name": pa.name,
                "mean_mgal": float(np.mean(d)) if len(d) else None,
                "rms_mgal": float(np.sqrt(np.mean(d**2))) if len(d) else None,
                "std_mgal": float(np.std(d)) if len(d) else None,
                "compared_s": len(d) / chains_a[pa.chain]["fs"],
            }
        )
    return out


#: the frame tilt is estimated only from at least this many compared samples …
FRAME_TILT_MIN_SAMPLES = 100
#: … and when the filtered horizontal acceleration varies by at least this much (m/s², RMS)
FRAME_TILT_MIN_ACCEL_MPS2 = 0.002


def frame_tilt(res_a: Evaluation, chains_a, res_b: Evaluation, chains_b, lowpass: Lowpass):
    """The navigation frame's tilt against the ellipsoidal normal, from SINS/LDV minus SINS/GNSS.

    The two chains share f_U; the SINS/LDV one is in the navigation's (plumb-levelled) frame, the
    SINS/GNSS one against ellipsoidal heights, so their difference is ξ·a_N + η·a_E (+ noise, + a
    constant): a least-squares fit of the filtered difference on the equally filtered horizontal
    accelerations at the compared line samples, with one offset per line (the chains' constant
    difference, and each chain's own line leveling when chosen). ξ, η are the deflection of the vertical the
    navigation levelled to (rad). Returns a dict (xi_rad, eta_rad, their 1-σ from the fit's residual,
    n samples) or None when the drive gives too few samples or too little horizontal acceleration."""
    ys, xs, line = [], [], []
    for pa, pb in zip(res_a.lines, res_b.lines):
        if not pa.has_data or not pb.has_data:
            continue
        chb = chains_b[pb.chain]
        tb = chb["t_s"][pb.samples]
        fb = res_b.filtered[pb.chain][pb.samples]
        fa = np.interp(tb, chains_a[pa.chain]["t_s"], res_a.filtered[pa.chain])
        lp = lowpass.at(chb["fs"])
        an = lp.apply(chb["a_n"])[pb.samples]
        ae = lp.apply(chb["a_e"])[pb.samples]
        ok = np.isfinite(fa) & np.isfinite(fb) & np.isfinite(an) & np.isfinite(ae)
        ys.append((fa - fb)[ok])
        xs.append(np.column_stack([an[ok], ae[ok]]))
        line.append(np.full(int(ok.sum()), len(line)))
    if not ys:
        return None
    y, x, line = np.concatenate(ys), np.vstack(xs), np.concatenate(line)
    if len(y) < FRAME_TILT_MIN_SAMPLES or np.sqrt(np.mean((x - x.mean(axis=0)) ** 2)) < FRAME_TILT_MIN_ACCEL_MPS2:
        return None
    # one offset per line: the chains' constant difference, and each chain's own line leveling if chosen
    offsets = (line[:, None] == np.unique(line)[None, :]).astype(float)
    a = np.column_stack([x, offsets])
    c, *_ = np.linalg.lstsq(a, y, rcond=None)
    r = y - a @ c
    # the filtered residual is correlated over ~the FIR length: σ from the effective number of samples
    fs = chains_b[0]["fs"]
    n_eff = max(len(y) / max(lowpass.length_s * fs / 2.0, 1.0), 4.0)
    cov = np.linalg.pinv(a.T @ a) * float(np.sum(r**2)) / max(len(y) - a.shape[1], 1) * len(y) / n_eff
    # the difference is SINS/LDV − SINS/GNSS = −(ξ a_N + η a_E) in the GNSS chain's error: sign flipped
    return {
        "xi_rad": float(-c[0]),
        "eta_rad": float(-c[1]),
        "xi_sigma_rad": float(np.sqrt(cov[0, 0])),
        "eta_sigma_rad": float(np.sqrt(cov[1, 1])),
        "n_samples": int(len(y)),
    }
