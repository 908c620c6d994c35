"""Plotly figures of the stored results, downsampled on the server (MinMax-LTTB).

Each view reads the job's CSV files (the same files the CLI writes) and returns figure JSON;
``x0``/``x1`` re-fetch detail for a zoomed range.
"""

from __future__ import annotations

import io

import numpy as np
import pyarrow.csv as pacsv
from fastapi import HTTPException
from tsdownsample import MinMaxLTTBDownsampler

from ldvsurvey.store.models import Job

ARCSEC_PER_RAD = 180.0 * 3600.0 / np.pi
#: NMEA GGA fix quality
FIX_NAMES = {0: "0 no fix", 1: "1 GPS", 2: "2 DGPS", 3: "3 PPS", 4: "4 RTK fixed", 5: "5 RTK float",
             6: "6 dead reckoning", 7: "7 manual", 8: "8 simulation"}
VIEWS = {
    "height": ["height", "height_error"],
    "tilt": ["attitude"],
    "navigate": ["trajectory"],
    "calibrate": ["calibration_track"],
    "gravity": ["gravity_lines", "gravity_residuals", "gravity_compare_gnss"],
    "dov": ["dov_deflection", "dov_error"],
    "damping": ["damping"],
}


def _csv(session, job: Job, name: str) -> dict[str, np.ndarray]:
    from ldvsurvey.api.jobs import job_file

    table = pacsv.read_csv(io.BytesIO(job_file(session, job.id, name)))
    out = {}
    for c in table.column_names:
        col = table.column(c)
        try:
            out[c] = col.to_numpy(zero_copy_only=False).astype(float)
        except (ValueError, TypeError):
            out[c] = np.array([("" if v is None else str(v)) for v in col.to_pylist()], dtype=object)
    return out


def _down(x, y, x0, x1, n):
    """Indices of at most n points of (x, y) within [x0, x1] (MinMax-LTTB)."""
    k = np.flatnonzero(np.isfinite(x) & np.isfinite(y) & ((x >= x0) if x0 is not None else True)
                       & ((x <= x1) if x1 is not None else True))
    if len(k) <= n:
        return k
    order = np.argsort(x[k], kind="stable")
    k = k[order]
    sel = MinMaxLTTBDownsampler().downsample(np.ascontiguousarray(x[k]), np.ascontiguousarray(y[k]), n_out=n)
    return k[np.sort(sel)]


def _trace(x, y, name, x0, x1, n, **kw):
    k = _down(np.asarray(x, float), np.asarray(y, float), x0, x1, n)
    return {"type": "scatter", "mode": kw.pop("mode", "lines"), "name": name, "x": np.asarray(x)[k].tolist(),
            "y": np.asarray(y)[k].tolist(), **kw}


def _fig(traces, title, xt, yt, **layout):
    return {"data": traces, "layout": {"title": {"text": title}, "xaxis": {"title": {"text": xt}},
                                       "yaxis": {"title": {"text": yt}}, "margin": {"t": 50, "r": 20, "b": 90},
                                       "legend": {"orientation": "h", "y": -0.22}, **layout}}


def _floor_text(block: dict) -> str:
    """'±measured mGal (white-noise floor ±f mGal, ×ratio)' of a gravity summary block."""
    tot = block.get("total_mgal")
    fl = (block.get("noise_floor") or {}).get("total_mgal")
    if tot is None:
        return "no coincidence"
    txt = f"±{tot:.3f} mGal"
    if fl:
        txt += f" (white-noise floor ±{fl:.3f} mGal, ×{tot / fl:.2f}"
        nf = block.get("noise_floor") or {}
        dr, comb = nf.get("drift_mgal"), nf.get("combined_mgal")
        if dr is not None and comb:  # the manifest's accelerometer bias instability after the same processing
            txt += f"; with the accelerometer drift ±{dr:.3f}: ±{comb:.3f} mGal, ×{tot / comb:.2f}"
        txt += ")"
    return txt


def _gravity_view(session, job: Job, view: str, s: dict, x0, x1, n) -> dict:
    """The gravity views: lines on common points, residuals beside the noise floor, the chains' difference."""
    if view in ("gravity_lines", "gravity_residuals"):
        c = _csv(session, job, "coincidence.csv")
        names = sorted(set(c["line"]))
        tr = []
        for name in names:
            k = c["line"] == name
            y = c["dg_mgal"][k] if view == "gravity_lines" else c["residual_mgal"][k]
            tr.append(_trace(c["distance_m"][k], y, str(name), x0, x1, n))
        if view == "gravity_lines":
            k = c["line"] == names[0]
            tr.append(_trace(c["distance_m"][k], c["mean_mgal"][k], "mean line", x0, x1, n,
                             line={"width": 3, "color": "black"}))
            return _fig(tr, f"Gravity disturbance on the repeated lines (FIR {s.get('fir_length_s')} s, "
                            f"resolution {s.get('resolution_m', 0):.0f} m, line ends trimmed "
                            f"{s.get('line_end_trim_s', 0):g} s)", "along-track distance (m)", "δg (mGal)")
        fl = (s.get("noise_floor") or {}).get("total_mgal")
        if fl:  # the ±1σ band white sensor noise alone would give
            d = c["distance_m"][c["line"] == names[0]]
            lo, hi = float(np.nanmin(d)), float(np.nanmax(d))
            tr.append({"type": "scatter", "mode": "lines", "name": f"white-noise floor ±{fl:.3f} mGal",
                       "x": [lo, hi, None, lo, hi], "y": [fl, fl, None, -fl, -fl],
                       "line": {"dash": "dash", "color": "black"}})
            comb = (s.get("noise_floor") or {}).get("combined_mgal")
            if comb and (s.get("noise_floor") or {}).get("drift_mgal") is not None:
                tr.append({"type": "scatter", "mode": "lines", "name": f"floor with the drift ±{comb:.3f} mGal",
                           "x": [lo, hi, None, lo, hi], "y": [comb, comb, None, -comb, -comb],
                           "line": {"dash": "dot", "color": "gray"}})
        return _fig(tr, f"Residuals about the mean line: {_floor_text(s)}", "along-track distance (m)",
                    "residual (mGal)")
    if view == "gravity_compare_gnss":
        g = _csv(session, job, "gravity.csv")
        on = g["line"] != ""
        gc = s.get("gnss_comparison") or {}
        tr = []
        other = "dg_sins_gnss_mgal" if "dg_sins_gnss_mgal" in g else None
        for name in sorted(set(g["line"][on])):
            k = g["line"] == name
            if other is not None:  # the two chains' difference along each line
                tr.append(_trace(g["distance_m"][k], g["dg_mgal"][k] - g[other][k], f"{name}: SINS/LDV − SINS/GNSS",
                                 x0, x1, n))
            if "dg_gnss_aided_mgal" in g:
                tr.append(_trace(g["distance_m"][k], g["dg_mgal"][k] - g["dg_gnss_aided_mgal"][k],
                                 f"{name}: LDV − LDV+GNSS navigation", x0, x1, n, line={"dash": "dot"}))
        rms = [f"{d['name']} {d['rms_mgal']:.2f}" for d in gc.get("ldv_minus_gnss", [])
               if d.get("rms_mgal") is not None]
        title = (f"SINS/LDV {_floor_text(s)} vs SINS/GNSS {_floor_text(gc)}; difference RMS per line (mGal): "
                 + (", ".join(rms) if rms else "none"))
        return _fig(tr, title, "along-track distance (m)", "δg difference (mGal)")
    raise HTTPException(404, f"unknown view '{view}'")


def build_view(session, job: Job, view: str, x0, x1, n) -> dict:
    if view not in VIEWS.get(job.pipeline, []):
        raise HTTPException(404, f"no view '{view}' for a {job.pipeline} job (views: {VIEWS.get(job.pipeline)})")
    s = job.summary or {}
    if view in ("height", "height_error"):
        h = _csv(session, job, "height.csv")
        t = h["t_s"]
        if view == "height":
            tr = [_trace(t, h["h_m"], "LDV height (tilt compensated)", x0, x1, n),
                  _trace(t, h["h_uncompensated_m"], "LDV height (uncompensated)", x0, x1, n),
                  _trace(t, h["h_gnss_m"], "GNSS height (fix 4/2)", x0, x1, n, mode="markers",
                         marker={"size": 3})]
            return _fig(tr, "Height of the IMU centre", "t (s of day)", "h (m, ellipsoidal)")
        tr = [_trace(t, h["h_m"] - h["h_gnss_m"], "error, tilt compensated", x0, x1, n, mode="markers",
                     marker={"size": 3}),
              _trace(t, h["h_uncompensated_m"] - h["h_gnss_m"], "error, uncompensated", x0, x1, n, mode="markers",
                     marker={"size": 3})]
        return _fig(tr, f"Height error against GNSS: std {s.get('std_error_m', float('nan')):.3f} m, "
                        f"max {s.get('max_error_m', float('nan')):.3f} m", "t (s of day)", "LDV − GNSS (m)")
    if view == "attitude":
        a = _csv(session, job, "attitude.csv")
        t = a["t_s"]
        tr = [_trace(t, a["pitch_raw_deg"], "pitch raw", x0, x1, n), _trace(t, a["pitch_deg"], "pitch compensated", x0, x1, n),
              _trace(t, a["roll_raw_deg"], "roll raw", x0, x1, n), _trace(t, a["roll_deg"], "roll compensated", x0, x1, n)]
        al, be = s.get("alpha_rad", 0.0), s.get("beta_rad", 0.0)
        return _fig(tr, f"Attitude: α = {al:.2e} rad ({al * ARCSEC_PER_RAD:.1f}″), "
                        f"β = {be:.2e} rad ({be * ARCSEC_PER_RAD:.1f}″)", "t (s of day)", "angle (deg)")
    if view in ("trajectory", "calibration_track"):
        name = "trajectory.csv" if view == "trajectory" else "calibration_track.csv"
        d = _csv(session, job, name)
        lat0, lon0 = np.radians(d["lat_deg"][0]), np.radians(d["lon_deg"][0])
        e = (np.radians(d["lon_deg"]) - lon0) * 6378137.0 * np.cos(lat0)
        nn = (np.radians(d["lat_deg"]) - lat0) * 6356752.0
        tr = [_trace(e, nn, "solution", None, None, n, mode="lines")]
        from ldvsurvey.store.logs import load_array

        g = load_array(session, job.log_ids[0], "gnss")
        if g is not None:
            ok = np.isfinite(g["lat_deg"])
            ge = (np.radians(g["lon_deg"][ok]) - lon0) * 6378137.0 * np.cos(lat0)
            gn = (np.radians(g["lat_deg"][ok]) - lat0) * 6356752.0
            fix = g["fix"][ok].astype(int)
            for q in sorted(set(fix.tolist())):  # one legend entry per fix quality (a discrete legend)
                kq = np.flatnonzero(fix == q)
                k = kq[_down(ge[kq], gn[kq], None, None, n)]
                tr.append({"type": "scatter", "mode": "markers", "name": f"GNSS, {FIX_NAMES.get(q, f'fix {q}')}",
                           "x": ge[k].tolist(), "y": gn[k].tolist(), "marker": {"size": 4}})
        return _fig(tr, "Trajectory (local east/north from the start)", "east (m)", "north (m)",
                    yaxis={"title": {"text": "north (m)"}, "scaleanchor": "x", "scaleratio": 1})
    if view.startswith("gravity_"):
        return _gravity_view(session, job, view, s, x0, x1, n)
    if view == "dov_deflection":
        d = _csv(session, job, "dov.csv")
        t = d["t_s"]
        return _fig([_trace(t, d["xi_arcsec"], "ξ", x0, x1, n), _trace(t, d["eta_arcsec"], "η", x0, x1, n)],
                    f"Deflection of the vertical along the track ({s.get('dov_source', '')})", "t (s of day)",
                    "arcsec")
    if view == "dov_error":
        d = _csv(session, job, "dov.csv")
        t = d["t_s"]
        tr = []
        for m in ("direct", "rk4", "theoretical"):
            tr.append(_trace(t, d[f"dn_{m}_m"], f"north, {m}", x0, x1, n))
            tr.append(_trace(t, d[f"de_{m}_m"], f"east, {m}", x0, x1, n, line={"dash": "dot"}))
        return _fig(tr, "DOV-caused position error", "t (s of day)", "m")
    if view == "damping":
        d = _csv(session, job, "damping.csv")
        t = d["t_s"]
        tr = [_trace(t, d[f"{m}_north_error_m"], f"{m.replace('_', ' ')}, north", x0, x1, n)
              for m in ("undamped", "conventional", "delayed_state")]
        return _fig(tr, f"Position error: delayed-state improves {s.get('position_improvement_pct', 0):.1f} % over "
                        "conventional", "t (s of day)", "north error (m)")
    raise HTTPException(404, f"unknown view '{view}'")
