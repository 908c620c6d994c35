"""``gravity``: strapdown gravity from SINS/2-D LDV, repeated-line internal coincidence, SINS/GNSS beside.

Chain (methods §4): f_U from the smoothed attitude and the raw increments (no bias removed: the
vertical accelerometer bias is not separable from Δg without a base tie), v̇_U from the LDV
velocity differenced once over each IMU interval (the same interval the specific force is the
mean of), Eötvös and transport terms, normal gravity at the navigated position, then the
zero-phase Blackman FIR. SINS/GNSS: velocity and acceleration from GNSS positions (fix ≥ 1).
"""

from __future__ import annotations

import numpy as np

from ldvsurvey.errors import ParameterError
from ldvsurvey.nav.coincidence import along_track, common_points, crossovers, internal_coincidence
from ldvsurvey.nav.errmodel import c_db
from ldvsurvey.nav.gravity import MGAL, disturbance_mps2, half_wavelength_resolution_m, zero_phase_lowpass
from ldvsurvey.pipelines.base import Param, Pipeline, PipelineResult
from ldvsurvey.pipelines.navigate import run_navigation
from ldvsurvey.pipelines.prep import attitude_at, gnss_ins, local_metres
from ldvsurvey.pipelines.stages import calibration_params

PARAMS = [
    Param("fir_length_s", "float", 150.0, "FIR filter length L in s (cut-off 1/L Hz)"),
    Param("lines", "str", None, "survey lines as t0-t1 pairs, comma separated (default: manifest lines, "
          "else detected repeated passes)"),
    Param("spacing_m", "float", 10.0, "spacing of the common along-track points"),
    Param("output_rate_hz", "float", 1.0, "rate of gravity.csv"),
    Param("gnss_comparison", "bool", True, "also run the SINS/GNSS chain when GNSS is present"),
] + calibration_params()


def ldv_chain(inp, sol, setup):
    """Raw δg (m/s²) per IMU interval from SINS/LDV; returns dict of arrays at interval mid-times."""
    t = inp.t_s
    dt = np.diff(t)
    from ldvsurvey.nav.attitude import c_from_q

    c_sn = c_from_q(sol.q_sn)
    c_mid = 0.5 * (c_sn[1:] + c_sn[:-1])
    # horizontal accelerometer biases (sensor x, y) are observable and leak into f_U on slopes;
    # the vertical one is not separable from Δg and stays (a constant offset without a base tie)
    b_xy = np.array([sol.accel_bias_mps2[0], sol.accel_bias_mps2[1], 0.0])
    dth, dv = inp.dtheta_rad[1:], inp.dvel_mps[1:] - b_xy * dt[:, None]
    dv_c = dv + 0.5 * np.cross(dth, dv)
    f_u = np.einsum("kj,kj->k", c_mid[:, 2, :], dv_c) / dt
    c_bn = sol.c_bn()
    nu_u = inp.nu_u_mps if inp.nu_u_mps is not None else np.zeros_like(inp.nu_f_mps)
    vd = np.column_stack([np.zeros_like(inp.nu_f_mps), inp.nu_f_mps / setup.scale, nu_u / setup.scale_up])
    v_head = np.einsum("kij,kj->ki", c_bn, vd @ c_db(setup.pitch_rad, setup.heading_rad).T)
    rel = np.einsum("kji,kjl->kil", c_bn[:-1], c_bn[1:])
    w = np.column_stack([rel[:, 2, 1] - rel[:, 1, 2], rel[:, 0, 2] - rel[:, 2, 0], rel[:, 1, 0] - rel[:, 0, 1]])
    w = np.vstack([w[:1], w]) / (2 * np.r_[dt[:1], dt])[:, None]
    lever = np.asarray(inp.log.manifest.ldv.lever_arm_m, float)
    v_imu = v_head - np.einsum("kij,kj->ki", c_bn, np.cross(w, lever))
    v_imu[~inp.ldv_ok] = np.nan
    vdot_u = np.diff(v_imu[:, 2]) / dt
    v_mid = 0.5 * (v_imu[1:] + v_imu[:-1])
    lat = 0.5 * (sol.pos[1:, 0] + sol.pos[:-1, 0])
    lon = 0.5 * (sol.pos[1:, 1] + sol.pos[:-1, 1])
    h = 0.5 * (sol.pos[1:, 2] + sol.pos[:-1, 2])
    dg = disturbance_mps2(f_u, vdot_u, v_mid[:, 0], v_mid[:, 1], lat, h)
    return {"t_s": 0.5 * (t[1:] + t[:-1]), "dg": dg, "lat": lat, "lon": lon, "h": h,
            "speed": np.hypot(v_mid[:, 0], v_mid[:, 1]), "fs": 1.0 / np.median(dt)}


def gnss_chain(log, inp, sol):
    """Raw δg (m/s²) at the GNSS epochs from SINS/GNSS (positions differenced; fix ≥ 1)."""
    g = log.gnss
    ok = (g.fix >= 1) & np.isfinite(g.lat_deg) & (g.t_s > inp.t_s[1]) & (g.t_s < inp.t_s[-2])
    tg = g.t_s[ok]
    c = attitude_at(sol, tg)
    lev = c @ np.asarray(log.manifest.gnss.lever_arm_m, float)
    lat0, lon0 = np.radians(g.lat_deg[ok][0]), np.radians(g.lon_deg[ok][0])
    e, n = local_metres(lat0, lon0, np.radians(g.lat_deg[ok]), np.radians(g.lon_deg[ok]))
    p = np.column_stack([e - lev[:, 0], n - lev[:, 1], g.h_m[ok] - lev[:, 2]])
    # three-point velocity and acceleration (uneven spacing allowed; NaN across gaps > 1.5 s)
    d1, d2 = np.diff(tg)[:-1], np.diff(tg)[1:]
    good = (d1 < 1.5) & (d2 < 1.5)
    w1, w2 = d1[:, None], d2[:, None]
    a = 2 * (w1 * p[2:] - (w1 + w2) * p[1:-1] + w2 * p[:-2]) / (w1 * w2 * (w1 + w2))
    v = (p[2:] - p[:-2]) / (d1 + d2)[:, None]
    a[~good] = np.nan
    tc = tg[1:-1]
    # f_U averaged with the triangle weights the second difference applies to the acceleration
    from ldvsurvey.nav.attitude import c_from_q

    c_sn = c_from_q(sol.q_sn)
    dts = np.r_[np.diff(inp.t_s)[:1], np.diff(inp.t_s)]
    b_xy = np.array([sol.accel_bias_mps2[0], sol.accel_bias_mps2[1], 0.0])  # as in the LDV chain
    f_u_all = np.einsum("kj,kj->k", c_sn[:, 2, :], inp.dvel_mps - b_xy * dts[:, None]) / dts
    fs = 1.0 / np.median(np.diff(inp.t_s))
    half = int(round(np.median(d1) * fs))
    tri = np.concatenate([np.arange(1, half + 1), np.arange(half - 1, 0, -1)]).astype(float)
    tri /= tri.sum()
    f_tri = np.convolve(f_u_all, tri, mode="same")
    f_u = np.interp(tc, inp.t_s - 0.5 / fs, f_tri)
    lat = np.interp(tc, tg, np.radians(g.lat_deg[ok]))
    lon = np.interp(tc, tg, np.radians(g.lon_deg[ok]))
    h = p[1:-1, 2]
    dg = disturbance_mps2(f_u, a[:, 2], v[:, 0], v[:, 1], lat, h)
    # weight of each acceleration: 1/σ² of the second difference of the three heights it uses
    from ldvsurvey.pipelines.prep import GNSS_SIGMA

    sv = np.array([GNSS_SIGMA.get(int(f), (np.nan, np.nan))[1] for f in g.fix[ok]])
    var = sv[2:] ** 2 + 4 * sv[1:-1] ** 2 + sv[:-2] ** 2
    return {"t_s": tc, "dg": dg, "lat": lat, "lon": lon, "h": h, "speed": np.hypot(v[:, 0], v[:, 1]),
            "fs": 1.0 / np.median(np.diff(tg)), "weight": 1.0 / var}


def parse_lines(text):
    """``t0-t1,t0-t1,...`` into [(name, t0, t1)]."""
    out = []
    for k, item in enumerate(str(text).split(",")):
        try:
            a, b = (float(x) for x in item.strip().split("-", 1))
        except ValueError:
            raise ParameterError(f"expected t0-t1 pairs, got {item!r}", field="lines") from None
        if not b > a:
            raise ParameterError(f"line {item!r} ends before it starts", field="lines")
        out.append((f"L{k + 1}", a, b))
    return out


def detect_lines(chain, min_length_m=1000.0):
    """Straight passes between stops/turnarounds: moving stretches of similar length over the same ground."""
    t, sp = chain["t_s"], np.nan_to_num(chain["speed"])
    moving = sp > 2.0
    edges = np.flatnonzero(np.diff(np.r_[0, moving.astype(int), 0]))
    segs = []
    for a, b in zip(edges[::2], edges[1::2]):
        dist = np.sum(sp[a:b]) / chain["fs"]
        if dist >= min_length_m:
            segs.append((t[a], t[b - 1], dist))
    if len(segs) < 2:
        return []
    med = np.median([s[2] for s in segs])
    return [(f"L{k + 1}", a, b) for k, (a, b, d) in enumerate(s for s in segs if abs(s[2] - med) < 0.25 * med)]


def evaluate(chains, lines, fir_s, spacing_m):
    """Filter each chain, cut the lines, put them on common points, compute the coincidence."""
    filtered = []
    for ch in chains:
        dgf = zero_phase_lowpass(ch["dg"], fir_s, ch["fs"], weights=ch.get("weight"))
        filtered.append(dgf)
    # the along-track axis: the first line's track
    ref = None
    per_line = []
    for name, ci, a, b in lines:
        ch = chains[ci]
        k = (ch["t_s"] >= a) & (ch["t_s"] <= b)
        if k.sum() < 10:
            raise ParameterError(f"line {name} [{a}, {b}] s holds no data", field="lines")
        if ref is None:
            lat0, lon0 = ch["lat"][k][0], ch["lon"][k][0]
            e, n = local_metres(lat0, lon0, ch["lat"][k], ch["lon"][k])
            step = max(1, int(len(e) // 4000))
            ref = (lat0, lon0, e[::step], n[::step])
        e, n = local_metres(ref[0], ref[1], ch["lat"][k], ch["lon"][k])
        s, lateral = along_track(ref[2], ref[3], e, n)
        per_line.append((name, ci, k, s, lateral, e, n))
    repeated = all(np.median(p[4]) < 50.0 for p in per_line)
    result = {"repeated": repeated, "filtered": filtered, "per_line": per_line}
    if repeated and len(per_line) >= 2:
        grid, vals = common_points([(p[3], filtered[p[1]][p[2]] / MGAL) for p in per_line], spacing_m)
        result["coincidence"] = internal_coincidence(vals, [p[0] for p in per_line], grid)
    tracks = [(p[5][::50], p[6][::50], filtered[p[1]][p[2]][::50] / MGAL) for p in per_line]
    if not repeated:
        result["crossings"], result["crossover_mgal"] = crossovers(tracks)
    speeds = np.concatenate([chains[p[1]]["speed"][p[2]] for p in per_line])
    result["resolution_m"] = half_wavelength_resolution_m(float(np.nanmedian(speeds)), fir_s)
    return result


def block(res, fir_s, aiding):
    out = {"fir_length_s": fir_s, "aiding": aiding, "resolution_m": res["resolution_m"],
           "repeated_lines": res["repeated"]}
    co = res.get("coincidence")
    if co is not None:
        out["lines"] = [{"name": nm, "max_mgal": float(mx), "min_mgal": float(mn), "rms_mgal": float(r)}
                        for nm, mx, mn, r in zip(co.names, co.per_line_max, co.per_line_min, co.per_line_rms)]
        out["total_mgal"] = co.total
        out["common_length_m"] = float(co.distance_m[-1] - co.distance_m[0])
    else:
        out["lines"] = [{"name": p[0], "max_mgal": None, "min_mgal": None, "rms_mgal": None}
                        for p in res["per_line"]]
        out["total_mgal"] = None
    if "crossover_mgal" in res:
        out["crossover_mgal"] = res["crossover_mgal"]
        out["n_crossings"] = len(res["crossings"])
    return out


def run(logs, params, progress) -> PipelineResult:
    fir_s = params["fir_length_s"]
    if not fir_s > 0:
        raise ParameterError("must be positive", field="fir_length_s")
    chains, gchains, lines, warnings = [], [], [], []
    nav_params = {**params, "aiding": "ldv", "smooth": True}
    for i, log in enumerate(logs):
        progress(f"bundle {i + 1}/{len(logs)}: SINS/LDV navigation", 0.05 + 0.6 * i / len(logs))
        inp, setup, sol = run_navigation(log, nav_params, progress)
        warnings += setup.warnings
        chains.append(ldv_chain(inp, sol, setup))
        if params["gnss_comparison"] and log.gnss is not None and np.count_nonzero(log.gnss.fix >= 1) > 100:
            progress(f"bundle {i + 1}/{len(logs)}: SINS/GNSS chain", 0.05 + 0.6 * (i + 0.5) / len(logs))
            sol_g = gnss_ins(inp, setup.cbs)
            gchains.append(gnss_chain(log, inp, sol_g))
        else:
            gchains.append(None)
        prefix = f"B{i + 1}-" if len(logs) > 1 else ""
        if params["lines"]:
            found = parse_lines(params["lines"])
        elif log.manifest.lines:
            found = [(ln.name, ln.t_start, ln.t_end) for ln in log.manifest.lines]
        else:
            found = detect_lines(chains[-1])
        lines += [(prefix + nm, i, a, b) for nm, a, b in found]
    if len(lines) < 2:
        raise ParameterError("fewer than two survey lines: give manifest lines or --set lines=t0-t1,t0-t1",
                             field="lines")
    progress("filtering and coincidence", 0.75)
    res = evaluate(chains, lines, fir_s, params["spacing_m"])
    summary = block(res, fir_s, "ldv")
    if all(g is not None for g in gchains):
        try:
            gres = evaluate(gchains, lines, fir_s, params["spacing_m"])
            summary["gnss_comparison"] = block(gres, fir_s, "gnss")
        except ValueError as exc:  # e.g. no common stretch with usable GNSS
            warnings.append(f"SINS/GNSS comparison skipped: {exc}")
    # tables
    progress("writing", 0.9)
    cols = {k: [] for k in ("t_s", "line", "distance_m", "lat_deg", "lon_deg", "h_m", "dg_raw_mgal", "dg_mgal")}
    line_of = {}
    for name, ci, k, s, *_ in res["per_line"]:
        line_of.setdefault(ci, []).append((name, k, s))
    for ci, ch in enumerate(chains):
        fs = ch["fs"]
        step = max(1, int(round(fs / params["output_rate_hz"])))
        n = len(ch["t_s"]) // step * step
        raw = np.nanmean(ch["dg"][:n].reshape(-1, step), axis=1) / MGAL
        idx = np.arange(step // 2, n, step)
        name_col = np.array([""] * len(idx), dtype=object)
        dist = np.full(len(idx), np.nan)
        for name, k, s in line_of.get(ci, []):
            sel = k[idx]
            name_col[sel] = name
            dist[sel] = np.interp(idx[sel], np.flatnonzero(k), s)
        cols["t_s"] += list(ch["t_s"][idx])
        cols["line"] += list(name_col)
        cols["distance_m"] += list(dist)
        cols["lat_deg"] += list(np.degrees(ch["lat"][idx]))
        cols["lon_deg"] += list(np.degrees(ch["lon"][idx]))
        cols["h_m"] += list(ch["h"][idx])
        cols["dg_raw_mgal"] += list(raw)
        cols["dg_mgal"] += list(res["filtered"][ci][idx] / MGAL)
    tables = {"gravity": {k: (np.array(v, dtype=float) if k != "line" else v) for k, v in cols.items()}}
    co = res.get("coincidence")
    if co is not None:
        n, m = co.values.shape
        tables["coincidence"] = {"line": [nm for nm in co.names for _ in range(m)],
                                 "distance_m": np.tile(co.distance_m, n), "dg_mgal": co.values.ravel(),
                                 "mean_mgal": np.tile(co.mean, n), "residual_mgal": co.residual.ravel()}
    return PipelineResult(summary=summary, tables=tables, warnings=warnings)


PIPELINE = Pipeline("gravity", run, PARAMS, "Strapdown gravity, repeated-line coincidence, SINS/GNSS comparison",
                    multi_input=True)
