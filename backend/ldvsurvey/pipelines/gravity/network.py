"""The survey network of the ``gravity`` pipeline: base ties, repeated lines and crossovers across logs.

Takes what :func:`report.evaluate` left (every line's filtered δg on its trimmed samples) and
the stops of every log, ties the stops near a base station (``base_ties``) to the station's absolute
g, and adjusts all lines of all logs together (:mod:`ldvsurvey.nav.network`): a bias (and, where
ties at the start and end support it, a linear drift) per log, a bias per line, weights from each
line's noise floor. The adjusted values come out as absolute g, the gravity disturbance δg and the
free-air anomaly Δg (through EGM2008's height anomaly, :mod:`ldvsurvey.nav.gravmodel`), each with
its 1-σ; beside them the external check against EGM2008 (or a given grid) with the model's
omission error, and each line's half-wavelength resolution from the filter's response.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from ldvsurvey.errors import ParameterError
from ldvsurvey.nav import network as net
from ldvsurvey.nav.earth import MGAL, normal_gravity
from ldvsurvey.nav.gravity import G0, Lowpass
from ldvsurvey.nav.gravmodel import free_air_anomaly_mgal, height_anomaly_grid, omission_mgal
from ldvsurvey.pipelines.gravity.chains import multipath_screen
from ldvsurvey.pipelines.gravity.drift import stop_means
from ldvsurvey.pipelines.gravity.tieheight import check_tie_heights
from ldvsurvey.pipelines.stages.aids import local_metres

#: a tie's absolute g must be a plausible value on the Earth's surface (mGal)
G_RANGE_MGAL = (976000.0, 984000.0)
#: samples of a line the network takes per second (the filtered values are smooth at 1/L)
NETWORK_RATE_HZ = 1.0
#: at most this many flagged residuals are listed in the summary
MAX_LISTED = 50
#: the 1-σ of a tie's absolute g (``base_ties``' fifth value, mGal) must lie in (0, TIE_SIGMA_MAX_MGAL]
TIE_SIGMA_MAX_MGAL = 100.0
#: fewer GNSS fixes than this along a SINS/LDV line: its height 1-σ stays the navigation filter's
MIN_HEIGHT_FIXES = 10
#: a tie given with four values: its g is taken as exact (σ 0 mGal), its weight the stop mean's σ alone
DEFAULT_TIE_SIGMA_MGAL = 0.0
#: horizontal gradient of g a tie's stop may stand in, beside the station (mGal/m): 5 mGal/km (50 E) is a
#: steep regional gradient and the order of the near-field effect of a building or embankment; a stop d metres
#: from the station reads the station's g to ±k·d, added in quadrature to its stop mean's σ
TIE_GRADIENT_MGAL_PER_M = 0.005
#: GNSS heights departing from the line's running median difference by more than this many robust σ (at least
#: 3 σ of their fix quality) are screened out of the height check, as :func:`chains.gnss_chain` screens them
HEIGHT_SCREEN_K = 4.0


def parse_ties(text) -> list[tuple[float, float, float, float]]:
    """``LAT,LON,H_M,G_MGAL[,SIGMA_MGAL];...`` into [(lat_deg, lon_deg, h_m, g_mgal)] (ParameterError naming
    the item); the ties' 1-σ: :func:`tie_sigmas_mgal`."""
    return [t[:4] for t in _tie_items(text)]


def tie_sigmas_mgal(text) -> list[float]:
    """Per tie of ``base_ties``, the 1-σ of its absolute g (mGal): the fifth value, else
    :data:`DEFAULT_TIE_SIGMA_MGAL` (the g taken as exact)."""
    return [t[4] for t in _tie_items(text)]


def _tie_items(text) -> list[tuple[float, float, float, float, float]]:
    """``base_ties`` checked item by item: (lat deg, lon deg, h m, g mGal, 1-σ of g mGal)."""
    out = []
    for k, item in enumerate(str(text).split(";")):
        if not item.strip():
            continue
        parts = item.split(",")
        try:
            if len(parts) not in (4, 5):
                raise ValueError
            lat, lon, h, g = (float(x) for x in parts[:4])
            sigma = float(parts[4]) if len(parts) == 5 else None
        except ValueError:
            raise ParameterError(
                f"tie {k + 1} ({item.strip()!r}): expected LAT,LON,H_M,G_MGAL or LAT,LON,H_M,G_MGAL,SIGMA_MGAL "
                "(degrees, metres, mGal, mGal)",
                field="base_ties",
            ) from None
        if not all(np.isfinite([lat, lon, h, g, 1.0 if sigma is None else sigma])):
            raise ParameterError(f"tie {k + 1}: values must be finite numbers", field="base_ties")
        if not (-90 <= lat <= 90 and -180 <= lon <= 360):
            raise ParameterError(f"tie {k + 1}: latitude {lat:g} or longitude {lon:g} out of range", field="base_ties")
        if not -500 <= h <= 9000:
            raise ParameterError(f"tie {k + 1}: ellipsoidal height {h:g} m out of range", field="base_ties")
        if not G_RANGE_MGAL[0] <= g <= G_RANGE_MGAL[1]:
            raise ParameterError(
                f"tie {k + 1}: g = {g:g} mGal is not an absolute gravity value (expected "
                f"{G_RANGE_MGAL[0]:.0f} to {G_RANGE_MGAL[1]:.0f} mGal)",
                field="base_ties",
            )
        if sigma is not None and not 0.0 < sigma <= TIE_SIGMA_MAX_MGAL:
            raise ParameterError(
                f"tie {k + 1}: SIGMA_MGAL, the 1-σ of g, {sigma:g} mGal out of range (more than 0, at most "
                f"{TIE_SIGMA_MAX_MGAL:g})",
                field="base_ties",
            )
        sigma = DEFAULT_TIE_SIGMA_MGAL if sigma is None else sigma
        out.append((lat, lon - 360.0 if lon > 180.0 else lon, h, g, sigma))  # east of 180° negative, as the navigation
    if not out:
        raise ParameterError("no tie given", field="base_ties")
    return out


def weigh_ties(ties: list[net.Tie], sigmas_mgal: list[float]) -> list[net.Tie]:
    """The observed ties with the 1-σ of their stations' g: ``stop_sigma_mgal`` the stop mean's own (with the
    distance term), ``g_sigma_mgal`` the station's, ``sigma_mgal`` their root-sum-square (a single
    observation's marginal σ, for its residual). The adjustment weighs each stop by its own σ and gives each
    station with σ_g > 0 one unknown held by 0 ± σ_g (:func:`nav.network.adjust`): the station's error is
    common to all its stops, never averaged down by repeat visits (mGal)."""
    out = []
    for t in ties:
        s_g = float(sigmas_mgal[int(t.name[1:]) - 1])
        out.append(
            replace(t, sigma_mgal=float(np.hypot(t.sigma_mgal, s_g)), stop_sigma_mgal=t.sigma_mgal, g_sigma_mgal=s_g)
        )
    return out


def network_lines(chains, res, floors, origin) -> tuple[list[net.Line], list]:
    """The lines with data as :class:`network.Line` (1 Hz; δg in mGal, local metres about ``origin``, lat/lon
    in rad), and the (:class:`report.LineResult`, sample indices) they come from."""
    lines, src = [], []
    for p in res.used:
        name, ci, k = p.name, p.chain, p.samples
        ch = chains[ci]
        step = max(1, int(round(ch["fs"] / NETWORK_RATE_HZ)))
        kk = k[::step]
        e, n = local_metres(origin[0], origin[1], ch["lat"][kk], ch["lon"][kk])
        lines.append(
            net.Line(
                name,
                ci,
                np.asarray(ch["t_s"][kk], float),
                np.asarray(e, float),
                np.asarray(n, float),
                res.filtered[ci][kk] / MGAL,
                float(floors[ci]),
                float(np.nanmedian(ch["speed"][kk])),
            )
        )
        src.append((p, kk))
    return lines, src


def observed_ties(chains, logs, ties, radius_m, origin) -> tuple[list[net.Tie], list[dict]]:
    """Every stop of every log within ``radius_m`` of a tie: its mean δg (drift removed as on the lines).

    A stop's 1-σ is the data's own (the scatter of its 3-s means floored at the manifest's white
    noise, :func:`drift.stop_sigma`, lost IMU rows included); only where a stop is too short for that,
    the white accelerometer noise the manifest states over its duration; in quadrature with it
    :data:`TIE_GRADIENT_MGAL_PER_M` · distance, the g the stop may miss standing beside the station.
    Both chains read a stop alike: SINS/LDV and SINS/GNSS (no LDV) each carry their static δg,
    f_U − γ where the vehicle stands (``dg_static``, :mod:`chains`)."""
    out, unused = [], []
    seen = set()
    for ci, ch in enumerate(chains):
        noise = logs[ci].manifest.imu.accel_noise_ug_per_rthz
        drift = ch.get("drift_mps2")
        for tc, la, lo, mean, dur, stop_sigma_mps2 in stop_means(ch, ch["still"]):
            for k, (lat, lon, h, g) in enumerate(ties):
                e, n = local_metres(np.radians(lat), np.radians(lon), la, lo)
                d = float(np.hypot(e, n))
                if d > radius_m:
                    continue
                meas = mean - (float(np.interp(tc, ch["t_s"], drift)) if drift is not None else 0.0)
                dg_tie = g - normal_gravity(np.radians(lat), h) / MGAL
                if np.isfinite(stop_sigma_mps2) and stop_sigma_mps2 > 0:
                    sigma = stop_sigma_mps2 / MGAL
                else:
                    sigma = (noise or 0.0) * 1e-6 * G0 / np.sqrt(dur) / MGAL
                if not sigma > 0:  # the stop mean's own σ must be known before the distance term joins it
                    raise ParameterError(
                        f"bundle {ci + 1}: a stop near tie T{k + 1} is too short to measure its own scatter and "
                        "the manifest gives no imu.accel_noise_ug_per_rthz, so the tie's weight is unknown",
                        field="base_ties",
                    )
                sigma = float(np.hypot(sigma, TIE_GRADIENT_MGAL_PER_M * d))  # g may change over the d metres
                out.append(net.Tie(f"T{k + 1}", ci, float(tc), float(meas / MGAL), float(dg_tie), sigma, d))
                seen.add(k)
    for k, t in enumerate(ties):
        if k not in seen:
            unused.append({"tie": f"T{k + 1}", "lat_deg": t[0], "lon_deg": t[1]})
    return out, unused


def network_origin(chains, res) -> tuple[float, float]:
    """The survey's local origin (lat, lon in rad): the first kept sample of the first line with data."""
    first = next((ln for ln in res.lines if ln.has_data), None)
    if first is None:
        raise ParameterError("no line holds data: nothing to adjust", field="lines")
    ch0 = chains[first.chain]
    return float(ch0["lat"][first.samples[0]]), float(ch0["lon"][first.samples[0]])


def tie_observations(chains, logs, params, origin, warnings: list) -> tuple[list[net.Tie], list]:
    """The base ties the logs observe (:func:`observed_ties`) and the ties as given; a warning per tie
    no stop observes, a ParameterError when ties are given and none is observed."""
    ties_given = parse_ties(params.base_ties) if params.base_ties else []
    ties, unused = observed_ties(chains, logs, ties_given, params.tie_radius_m, origin)
    if ties_given and not ties:
        raise ParameterError(
            f"no log stands still within {params.tie_radius_m:g} m of any tie: the ties cannot be "
            "applied (check the coordinates, or widen tie_radius_m)",
            field="base_ties",
        )
    for u in unused:
        warnings.append(
            f"base tie {u['tie']} ({u['lat_deg']:.6f}, {u['lon_deg']:.6f}): no stop within "
            f"{params.tie_radius_m:g} m, not used"
        )
    return ties, ties_given


def network_points(lines, lowpass: Lowpass, spacing_m: float) -> tuple[list, list]:
    """The repeat groups of the lines and the network's points: common along-track points of every
    group (``spacing_m`` apart, m) and the crossings of the groups' tracks."""
    groups = net.repeat_groups(lines)
    clusters = []
    for gi, grp in enumerate(groups):
        clusters += net.repeat_clusters(lines, grp, gi, spacing_m, lowpass.correlation_time_s)
    clusters += net.crossing_clusters(lines, groups, lowpass=lowpass)
    return groups, clusters


def fit_statistics(lines, clusters, groups, adj, loo) -> dict:
    """Repeat and crossover RMS (mGal) before and after the adjustment and left out line by line, beside
    the lines' white-noise floor (RMS over lines)."""

    def raw(cl):
        return cl.values

    def adjusted(cl):
        return np.array([v - adj.correction(lines[i].log, i, t)[0] for i, v, t in zip(cl.lines, cl.values, cl.t_s)])

    rep_before, rep_after = net.repeat_rms(clusters, raw), net.repeat_rms(clusters, adjusted)
    x_before, _ = net.crossover_rms(clusters, groups, raw)
    x_after, _ = net.crossover_rms(clusters, groups, adjusted)
    floor_rms = float(np.sqrt(np.mean([ln.sigma_mgal**2 for ln in lines])))

    def ratio(x):
        return x / floor_rms if x is not None else None

    return {
        "repeat_rms_before_mgal": rep_before,
        "repeat_rms_after_mgal": rep_after,
        "crossover_rms_before_mgal": x_before,
        "crossover_rms_after_mgal": x_after,
        "noise_floor_mgal": floor_rms,
        "repeat_floor_ratio": ratio(rep_after),
        "crossover_floor_ratio": ratio(x_after),
        "repeat_loo_rms_mgal": loo["repeat"],
        "crossover_loo_rms_mgal": loo["crossing"],
        "repeat_loo_floor_ratio": ratio(loo["repeat"]),
        "crossover_loo_floor_ratio": ratio(loo["crossing"]),
    }


def parameter_rows(adj, lines) -> list[dict]:
    """The adjusted parameters with their 1-σ: log biases (mGal), log drifts (mGal/h), line biases (mGal), the
    offsets of the stations given with a σ of g (mGal)."""
    sig = np.sqrt(np.maximum(np.diag(adj.cov), 0.0))
    pars = []
    for nm, v, s in zip(adj.names, adj.x, sig):
        kind, idx = nm.split(":")
        if kind == "station":
            pars.append({"parameter": "station g offset", "tie": idx, "value_mgal": v, "sigma_mgal": s})
            continue
        idx = int(idx)
        if kind == "bias":
            pars.append({"parameter": "log bias", "log": f"B{idx + 1}", "value_mgal": v, "sigma_mgal": s})
        elif kind == "drift":
            pars.append({"parameter": "log drift", "log": f"B{idx + 1}", "value_mgal_per_h": v, "sigma_mgal_per_h": s})
        else:
            pars.append({"parameter": "line bias", "line": lines[idx].name, "value_mgal": v, "sigma_mgal": s})
    return pars


def datum_sigma_mgal(adj, lines) -> float:
    """1-σ (mGal) of the datum: of the mean correction over all line samples."""
    a_mean = np.mean(np.vstack([adj._row(ln.log, i, ln.t_s) for i, ln in enumerate(lines)]), axis=0)
    return float(np.sqrt(max(a_mean @ adj.cov @ a_mean, 0.0)))


def tie_rows(ties, adj) -> list[dict]:
    """Per observed tie: the stop's and the tie's δg, the residual after the adjustment and the 1-σ (mGal):
    ``sigma_mgal`` the observation's, of the stop mean (``stop_sigma_mgal``, with the distance term
    ``distance_sigma_mgal`` = :data:`TIE_GRADIENT_MGAL_PER_M` · ``distance_m``) and the station's g
    (``tie_sigma_mgal``) combined."""
    rows = []
    for t in ties:
        pred = adj.correction(t.log, None, t.t_s)[0]
        rows.append(
            {
                "tie": t.name,
                "log": f"B{t.log + 1}",
                "t_s": t.t_s,
                "distance_m": t.distance_m,
                "tie_dg_mgal": t.tie_mgal,
                "stop_dg_mgal": t.measured_mgal,
                "residual_mgal": t.measured_mgal - t.tie_mgal - pred,
                "sigma_mgal": t.sigma_mgal,
                "stop_sigma_mgal": t.sigma_mgal if t.stop_sigma_mgal is None else t.stop_sigma_mgal,
                "tie_sigma_mgal": t.g_sigma_mgal,
                "distance_sigma_mgal": TIE_GRADIENT_MGAL_PER_M * t.distance_m,
            }
        )
    return rows


HEIGHT_SIGMA_NOTE = (
    "σ_h of δg's height term (0.3086 mGal/m · σ_h): on SINS/LDV lines with GNSS fixes, the navigated height "
    "against the fixes (RMS difference less the receiver's stated height noise; lines[].h_sigma_source); "
    "else the navigation filter's own height σ (on SINS/LDV without fixes its prior, a flat metre)"
)

NETWORK_NOTE = (
    "adjusted values = filtered δg − (log bias + log drift·(t − t_ref) + line bias); the floor is the "
    "lines' combined floor, white noise and accelerometer drift (RMS over lines; per log: log_floors); "
    "repeat RMS is the internal coincidence about each point's "
    "mean, crossover RMS sqrt(Σd²/2N); both after the adjustment are residuals of the fit itself (it has "
    "spent its degrees of freedom on them: they sit below the floor by construction). The honest figures "
    "are the leave-one-line-out ones (*_loo_*): each line predicted from the other lines and the ties, "
    "scaled to compare with the floor"
)


def survey_network(logs, chains, res, params, lowpass: Lowpass, floors, progress=None):
    """Adjust all lines of all logs as one network: its summary block, tables, files and warnings.

    Parameters
    ----------
    logs : list of DriveLog
        The logs (their manifests' accelerometer noise weighs short stops at ties).
    chains : list of dict
        Per log, the main chain (:mod:`chains`), drift removed as on the lines.
    res : report.Evaluation
        :func:`report.evaluate` of the chains.
    params : GravityParams
        ``base_ties``, ``tie_radius_m``, ``spacing_m``, ``network_drift``, ``network_line_bias``,
        ``outlier_sigma``, ``map_grid`` and the external check's fields.
    lowpass : Lowpass
        The gravity filter (the points' weights, each line's resolution).
    floors : list of float
        Per log, the 1-σ floor (mGal) of one filtered line value the lines are weighted by (the
        pipeline gives the combined one, white noise and drift: :func:`netfloor.network_floors`).
    progress : callable or None
        ``progress(message, fraction)``.

    Returns
    -------
    tuple
        (summary block, tables ``gravity_adjusted`` and ``network_residuals``, files (the gridded map's
        netCDF), warnings).
    """
    warnings = []
    origin = network_origin(chains, res)
    lines, src = network_lines(chains, res, floors, origin)
    ties, ties_given = tie_observations(chains, logs, params, origin, warnings)
    ties = weigh_ties(ties, tie_sigmas_mgal(params.base_ties) if params.base_ties else [])
    groups, clusters = network_points(lines, lowpass, params.spacing_m)
    fit_kw = {"drift": params.network_drift, "line_bias": params.network_line_bias}
    try:
        adj = net.adjust(lines, clusters, ties, len(logs), **fit_kw)
    except ValueError as exc:
        raise ParameterError(str(exc), field="base_ties" if not ties else "network_drift") from None
    if progress:
        progress("network: leave-one-line-out prediction", 0.8)
    loo = net.leave_one_line_out(lines, clusters, ties, len(logs), **fit_kw)
    residuals, flagged = _residuals(lines, clusters, ties, adj, params.outlier_sigma, origin, ties_given)
    if progress:
        progress("network: absolute values, external check", 0.85)
    fixes = tuple(int(x) for x in str(params.gnss_fixes or "4").split(","))  # validated at the door: "4,5"
    h_sigma = [line_height_sigma(chains[ln.log], logs[ln.log], ln.t_s, fixes, lowpass.length_s) for ln in lines]
    table, per_line = _adjusted_table(lines, src, chains, adj, lowpass, h_sigma)
    for pl, r in zip(per_line, loo["lines"]):
        pl["loo_rms_mgal"] = r
    external = _external_check(
        table, per_line, params.external_model, grid_paths=params.external_grid, grid_id=params.external_grid_id
    )
    rows = tie_rows(ties, adj)
    warnings += check_tie_heights(rows, ties_given, chains, logs, fixes)
    summary = {
        "datum": adj.datum,
        "datum_sigma_mgal": datum_sigma_mgal(adj, lines),
        "ties": rows,
        "tie_radius_m": params.tie_radius_m,
        "n_logs": len(logs),
        "n_lines": len(lines),
        "repeat_groups": [[lines[i].name for i in g] for g in groups],
        "n_repeat_points": sum(1 for c in clusters if c.kind == "repeat"),
        "n_crossings": sum(1 for c in clusters if c.kind == "crossing"),
        **fit_statistics(lines, clusters, groups, adj, loo),
        "sigma0": adj.sigma0,
        "dof": adj.dof,
        "drift_logs": [f"B{i + 1}" for i in adj.drift_logs],
        "line_bias": adj.line_bias,
        "parameters": parameter_rows(adj, lines),
        "correlation_time_s": lowpass.correlation_time_s,
        "height_sigma_note": HEIGHT_SIGMA_NOTE,
        "n_downweighted": int(sum(np.count_nonzero(w < 1.0) for w in adj.weights)),
        "robust": f"Huber down-weighting beyond {net.ROBUST_K:g} σ ({net.ROBUST_ITERATIONS} passes)",
        "n_outliers": len(flagged),
        "outliers": flagged[:MAX_LISTED],
        "lines": per_line,
        "external_check": external,
        "note": NETWORK_NOTE,
    }
    tables = {"gravity_adjusted": table, "network_residuals": residuals}
    files = {}
    if params.map_grid:
        from ldvsurvey.pipelines.gravity.map import survey_grid

        res_m = float(np.median([pl["resolution_m"] for pl in per_line]))
        data, summary["map"] = survey_grid(table["lat_deg"], table["lon_deg"], table["dg_mgal"], res_m)
        if data is not None:
            files["gravity_grid.nc"] = data
    return summary, tables, files, warnings


def _residuals(lines, clusters, ties, adj, k_sigma, origin, ties_given):
    """Per observation: the residual about its point's adjusted mean, standardized by its marginal σ."""
    from ldvsurvey.nav.earth import radii

    rm, rn = radii(origin[0])
    cols = {
        k: []
        for k in (
            "kind",
            "point",
            "log",
            "line",
            "t_s",
            "lat_deg",
            "lon_deg",
            "residual_mgal",
            "standardized",
            "outlier",
        )
    }
    flagged = []
    for pi, cl in enumerate(clusters):
        v = np.array([x - adj.correction(lines[i].log, i, t)[0] for i, x, t in zip(cl.lines, cl.values, cl.t_s)])
        # about the point's mean as the adjustment formed it (robust weights: a bad sample does not move it)
        w = np.array([1.0 / lines[i].sigma_mgal ** 2 for i in cl.lines])
        if pi < len(adj.weights):
            w = w * adj.weights[pi]
        wm = w / np.sum(w)
        r = v - np.sum(wm * v)
        sr = np.array([lines[i].sigma_mgal for i in cl.lines]) * np.sqrt(np.maximum(1.0 - wm, 1e-9))
        z = r / sr
        for i, ri, zi, t in zip(cl.lines, r, z, cl.t_s):
            out = bool(abs(zi) > k_sigma)
            cols["kind"].append(cl.kind)
            cols["point"].append(pi)
            cols["log"].append(lines[i].log + 1)
            cols["line"].append(lines[i].name)
            cols["t_s"].append(t)
            cols["lat_deg"].append(np.degrees(origin[0] + cl.n_m / rm))
            cols["lon_deg"].append(np.degrees(origin[1] + cl.e_m / (rn * np.cos(origin[0]))))
            cols["residual_mgal"].append(ri)
            cols["standardized"].append(zi)
            cols["outlier"].append(int(out))
            if out:
                flagged.append(
                    {
                        "kind": cl.kind,
                        "line": lines[i].name,
                        "t_s": float(t),
                        "residual_mgal": float(ri),
                        "standardized": float(zi),
                    }
                )
    for t in ties:
        r = t.measured_mgal - t.tie_mgal - adj.correction(t.log, None, t.t_s)[0]
        z = r / t.sigma_mgal
        out = bool(abs(z) > k_sigma)
        cols["kind"].append("tie")
        cols["point"].append(-1)
        cols["log"].append(t.log + 1)
        cols["line"].append(t.name)
        cols["t_s"].append(t.t_s)
        k = int(t.name[1:]) - 1
        cols["lat_deg"].append(ties_given[k][0])
        cols["lon_deg"].append(ties_given[k][1])
        cols["residual_mgal"].append(r)
        cols["standardized"].append(z)
        cols["outlier"].append(int(out))
        if out:
            flagged.append({"kind": "tie", "line": t.name, "t_s": t.t_s, "residual_mgal": r, "standardized": z})
    table = {k: (np.array(v, float) if k not in ("kind", "line") else v) for k, v in cols.items()}
    table["point"] = np.array(cols["point"], dtype=np.int64)
    table["log"] = np.array(cols["log"], dtype=np.int64)  # 1-based, as gravity_adjusted.csv (and its date)
    table["outlier"] = np.array(cols["outlier"], dtype=np.int64)
    return table, flagged


def _adjusted_table(lines, src, chains, adj, lowpass: Lowpass, h_sigma=None):
    """gravity_adjusted.csv (1 Hz on the lines' trimmed samples) and the per-line summary; ``h_sigma``: per
    line, the height 1-σ (m) at its samples and its source (:func:`line_height_sigma`; default the
    navigation filter's)."""
    cols = {
        k: []
        for k in (
            "t_s",
            "log",
            "line",
            "lat_deg",
            "lon_deg",
            "h_m",
            "g_mgal",
            "dg_mgal",
            "free_air_mgal",
            "sigma_mgal",
            "g_sigma_mgal",
            "adjustment_sigma_mgal",
            "h_sigma_m",
            "height_anomaly_m",
            "dg_unadjusted_mgal",
            "correction_mgal",
        )
    }
    per_line = []
    lat_all = np.concatenate([np.asarray(chains[ln.log]["lat"][kk]) for ln, (_, kk) in zip(lines, src)])
    lon_all = np.concatenate([np.asarray(chains[ln.log]["lon"][kk]) for ln, (_, kk) in zip(lines, src)])
    h_mean = float(np.mean(np.concatenate([np.asarray(chains[ln.log]["h"][kk]) for ln, (_, kk) in zip(lines, src)])))
    zeta_all = height_anomaly_grid(np.degrees(lat_all), np.degrees(lon_all), h_mean)
    at = 0
    for i, (ln, (_p, kk)) in enumerate(zip(lines, src)):
        ch = chains[ln.log]
        lat, lon, h = np.asarray(ch["lat"][kk]), np.asarray(ch["lon"][kk]), np.asarray(ch["h"][kk])
        zeta = zeta_all[at : at + len(kk)]
        at += len(kk)
        c = adj.correction(ln.log, i, ln.t_s)
        cs = adj.correction_sigma(ln.log, i, ln.t_s)
        dg = ln.dg_mgal - c
        # δg and Δg depend on the navigated height: γ evaluated at h_nav + δh moves them by −∂γ/∂h·δh =
        # 0.3086 mGal/m · δh. Absolute g = δg + γ(h_nav) does not (γ cancels), but it is reported AT h_m: the
        # field there differs from the field where it was measured by the free-air gradient times δh, so its
        # σ holds the same height term; ``adjustment_sigma_mgal`` is the adjustment's alone
        sigma_g = np.sqrt(ln.sigma_mgal**2 + cs**2)
        h_sig, h_source = h_sigma[i] if h_sigma is not None else (height_sigma_m(ch, ln.t_s), "navigation filter")
        grad = (normal_gravity(lat, h - 0.5) - normal_gravity(lat, h + 0.5)) / MGAL  # mGal/m
        sigma = np.sqrt(sigma_g**2 + (grad * h_sig) ** 2)
        cols["t_s"] += list(ln.t_s)
        cols["log"] += [ln.log + 1] * len(kk)
        cols["line"] += [ln.name] * len(kk)
        cols["lat_deg"] += list(np.degrees(lat))
        cols["lon_deg"] += list(np.degrees(lon))
        cols["h_m"] += list(h)
        cols["g_mgal"] += list(dg + normal_gravity(lat, h) / MGAL)
        cols["dg_mgal"] += list(dg)
        cols["free_air_mgal"] += list(free_air_anomaly_mgal(dg, lat, h, zeta))
        cols["sigma_mgal"] += list(sigma)
        cols["g_sigma_mgal"] += list(sigma)
        cols["adjustment_sigma_mgal"] += list(sigma_g)
        cols["h_sigma_m"] += list(h_sig)
        cols["height_anomaly_m"] += list(zeta)
        cols["dg_unadjusted_mgal"] += list(ln.dg_mgal)
        cols["correction_mgal"] += list(c)
        per_line.append(
            {
                "name": ln.name,
                "log": f"B{ln.log + 1}",
                "speed_mps": ln.speed_mps,
                "resolution_m": lowpass.half_wavelength_m(ln.speed_mps),
                "noise_floor_mgal": ln.sigma_mgal,
                "mean_correction_mgal": float(np.mean(c)),
                "sigma_mgal": float(np.sqrt(np.mean(sigma**2))),
                "g_sigma_mgal": float(np.sqrt(np.mean(sigma**2))),
                "adjustment_sigma_mgal": float(np.sqrt(np.mean(sigma_g**2))),
                "h_sigma_m": float(np.sqrt(np.mean(h_sig**2))),
                "h_sigma_source": h_source,
                "height_anomaly_m": float(np.mean(zeta)),
            }
        )
    table = {k: (np.array(v, float) if k != "line" else v) for k, v in cols.items()}
    table["log"] = np.array(cols["log"], dtype=np.int64)
    return table, per_line


def height_sigma_m(ch, t_s) -> np.ndarray:
    """The navigation's height 1-σ (m) at the times ``t_s`` (zeros for a chain that carries none)."""
    ep = ch.get("h_sigma_epochs")
    if ep is None or not len(ep[0]):
        return np.zeros(len(t_s))
    return np.interp(t_s, ep[0], ep[1])


def line_height_sigma(ch, log, t_s, fixes=(4,), window_s: float = 100.0) -> tuple[np.ndarray, str]:
    """The height 1-σ (m) of a line's navigated heights at the times ``t_s`` (s), and where it comes from.

    A SINS/LDV chain has no height observation: its filter's σ_h stays at its prior (a flat metre) while
    the dead-reckoned height is good to centimetres on a survey line. Where the log has GNSS fixes of
    the ``fixes`` qualities on the line, the navigated height is compared with theirs (antenna brought
    down by the lever arm's up part, the vehicle about level; multipath screened as :func:`chains.gnss_chain`
    does, over a running median of ``window_s``): the mean square difference about the line's mean (a
    constant height offset moves δg by a constant, which the line's bias absorbs) less the
    receiver's stated height variance for those qualities (``gnss.height_noise``: white² +
    correlated²), floored at the receiver's white σ, is the navigated height's variance on the line.
    Otherwise (a SINS/GNSS chain, whose filter σ is GNSS-aided, or fewer than :data:`MIN_HEIGHT_FIXES`
    fixes) the navigation filter's own σ (:func:`height_sigma_m`).

    Parameters
    ----------
    ch : dict
        The line's chain (``kind``, ``t_s`` in s, ``h`` in m, ``h_sigma_epochs``).
    log : DriveLog
        Its log (``gnss``: ``t_s`` s, ``h_m`` m ellipsoidal at the antenna, ``fix``; the manifest's lever
        arm in m and height noise by fix quality in m).
    t_s : numpy.ndarray
        The line's sample times (s).
    fixes : sequence of int
        GGA fix qualities taken.
    window_s : float
        Window of the running median the GNSS heights are screened against (s; the pipeline's filter length).

    Returns
    -------
    tuple
        (σ_h in m at ``t_s``, the source as text for the summary).
    """
    t_s = np.asarray(t_s, float)
    g = getattr(log, "gnss", None)
    if ch.get("kind") != "ldv" or g is None or not len(t_s):
        return height_sigma_m(ch, t_s), "navigation filter"
    m = (g.t_s >= t_s[0]) & (g.t_s <= t_s[-1]) & np.isin(g.fix, list(fixes)) & np.isfinite(g.h_m)
    if np.count_nonzero(m) < MIN_HEIGHT_FIXES:
        return height_sigma_m(ch, t_s), f"navigation filter (fewer than {MIN_HEIGHT_FIXES} GNSS fixes on the line)"
    tc = np.asarray(ch["t_s"], float)
    a, b = np.searchsorted(tc, [t_s[0], t_s[-1]])
    k = slice(max(a - 1, 0), min(b + 1, len(tc)))
    up = float(np.asarray(log.manifest.gnss.lever_arm_m, float)[2])
    d = np.interp(g.t_s[m], tc[k], np.asarray(ch["h"][k], float)) - (g.h_m[m] - up)
    fix = g.fix[m]
    good = multipath_screen(g.t_s[m], d, fix, window_s=window_s, k_sigma=HEIGHT_SCREEN_K)
    d, fix = d[good], fix[good]
    if len(d) < MIN_HEIGHT_FIXES:
        return height_sigma_m(ch, t_s), f"navigation filter (fewer than {MIN_HEIGHT_FIXES} GNSS fixes on the line)"
    noise = log.manifest.gnss.height_noise
    spec = [noise.get(str(int(q))) for q in fix]
    var_g = float(np.mean([s.white_m**2 + s.correlated_m**2 if s else 0.0 for s in spec]))
    white = float(np.sqrt(np.mean([s.white_m**2 if s else 0.0 for s in spec])))
    ms = float(np.mean((d - np.mean(d)) ** 2))  # about the line's mean: the line's bias absorbs a constant
    sigma = float(np.sqrt(max(ms - var_g, white**2)))
    qual = "/".join(str(q) for q in sorted(set(int(q) for q in fix)))
    source = (
        f"GNSS fix {qual} on the line ({len(d)} fixes, {int(np.count_nonzero(~good))} screened out): RMS about "
        f"the line's mean of (navigated − GNSS) {np.sqrt(ms):.3f} m less the receiver's stated {np.sqrt(var_g):.3f} m"
    )
    return np.full(len(t_s), sigma), source


def _external_check(table, per_line, model: str, *, grid_paths=None, grid_id=None) -> dict:
    """δg of the external model along the tracks (mGal, added to ``table`` as ``dg_external_mgal``), its
    difference from the adjusted δg per line; ``model`` "egm2008", "grid" (``grid_paths`` or ``grid_id``)
    or "none"."""
    choice = model
    if choice == "none":
        return {"model": "none"}
    lat, lon = table["lat_deg"], table["lon_deg"]
    if choice == "grid":
        grid = _user_grid(grid_paths, grid_id)
        problem = grid.missing_cover(lat, lon)
        if problem:
            raise ParameterError(f"the external grid does not cover the survey: {problem}", field="external_grid")
        if grid.dg_mgal is None:
            raise ParameterError(
                "the external grid holds no Δg (give a third .gdf of δg in mGal)", field="external_grid"
            )
        name, degree = grid.source or "user grid", None
    else:
        from ldvsurvey.pipelines.stages.plumb_line import EGM_DEGREE, _egm

        # δg at the tracks' height, not on the ellipsoid: the model's short wavelengths attenuate upward
        # (degree 2190 by ~(R/(R+h))^n, a third at 3 km), as the survey's own δg at the vehicle
        h_mean = float(np.nanmean(table["h_m"]))
        grid = _egm(lat, lon, lambda *a: None, h_m=h_mean)
        name, degree = f"EGM2008 to degree {EGM_DEGREE} (1′ grid, bilinear) at h = {round(h_mean):.0f} m", EGM_DEGREE
    model = grid.interpolate(lat, lon)[2] / MGAL
    table["dg_external_mgal"] = model
    out = {"model": name, "lines": []}
    for pl in per_line:
        k = np.array([x == pl["name"] for x in table["line"]])
        d = table["dg_mgal"][k] - model[k]
        d = d[np.isfinite(d)]
        row = {"name": pl["name"], "mean_mgal": None, "std_mgal": None, "rms_mgal": None}
        if len(d):
            row.update(mean_mgal=float(np.mean(d)), std_mgal=float(np.std(d)), rms_mgal=float(np.sqrt(np.mean(d**2))))
        if degree:
            row["omission_mgal"] = omission_mgal(degree, pl["resolution_m"])
        out["lines"].append(row)
    if degree:
        out["omission_note"] = (
            "EGM2008 lacks the field beyond degree 2190 (half-wavelength ~9 km): the signal between that and "
            "each line's resolution, from the Tscherning-Rapp degree variances (a global average), is the "
            "expected RMS of the difference beside the survey's own noise"
        )
        out["synthesis_height_m"] = float(round(h_mean))
        out["commission_note"] = (
            "EGM2008's own error within degree 2159 (commission) adds to the omission: NGA's propagated point "
            "σ of Δg (5′ grid, Pavlis et al. 2012) is a few mGal over land with dense terrestrial gravity and "
            "exceeds 10 mGal where the model was filled in from topography; not included in omission_mgal"
        )
    return out


def _user_grid(paths, grid_id):
    """The external grid: uploaded (``grid_id``), one ICGEM .gdf of δg, or ξ, η, δg grids (``paths``)."""
    from ldvsurvey.pipelines.stages.plumb_line import _uploaded, load_grids

    if grid_id:
        return _uploaded(grid_id)
    if not paths:
        raise ParameterError("external_model=grid needs external_grid (or external_grid_id)", field="external_grid")
    if len(paths) == 1:
        from pathlib import Path

        from ldvsurvey.io.gdf import parse_gdf
        from ldvsurvey.nav.dovgrid import DovGrid

        path = Path(paths[0])
        if not path.is_file():
            raise ParameterError("no such file", file=str(path), field="external_grid")
        _, la, lo, v = parse_gdf(path.read_bytes(), path.name)
        z = np.zeros_like(v)
        return DovGrid(la, lo, z, z, v, source=path.name)
    return load_grids(paths)
