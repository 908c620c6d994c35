"""Plotly figures of the stored results, downsampled on the server (MinMax-LTTB).

Each view is a small function registered with :func:`view`: its name, the pipeline whose jobs it
draws, a title, the units of its y axis and the result files it reads (the same files the CLI
writes). ``GET /api/views`` lists the registry and ``GET /api/jobs/{id}`` names a job's views, so
the dashboard draws whatever is registered here; ``x0``/``x1`` re-fetch detail for a zoomed range.
"""

from __future__ import annotations

import io
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import pyarrow.csv as pacsv
from fastapi import HTTPException
from sqlalchemy import select
from tsdownsample import MinMaxLTTBDownsampler

from ldvsurvey.store.models import Job, JobFile

ARCSEC_PER_RAD = 180.0 * 3600.0 / np.pi
#: NMEA GGA fix quality
FIX_NAMES = {
    0: "0 no fix",
    1: "1 GPS",
    2: "2 DGPS",
    3: "3 PPS",
    4: "4 RTK fixed",
    5: "5 RTK float",
    6: "6 dead reckoning",
    7: "7 manual",
    8: "8 simulation",
}


def job_file(session, job_id: int, name: str) -> bytes:
    """The bytes of a job's result file; 404 naming it when the job has none of that name."""
    f = session.scalar(select(JobFile).where(JobFile.job_id == job_id, JobFile.name == name))
    if f is None:
        raise HTTPException(404, f"job {job_id} has no file '{name}'")
    return f.content


@dataclass
class ViewInput:
    """What a view function gets: the job, its summary and the requested range and point count."""

    session: object
    job: Job
    summary: dict
    x0: float | None
    x1: float | None
    n: int  #: at most this many points per trace
    files: tuple[str, ...] = ()  #: the result files the view declared (read no others)

    def csv(self, name: str) -> dict[str, np.ndarray]:
        """The columns of one of the job's result files (numbers as float, text as object arrays)."""
        if self.files and name not in self.files:
            raise RuntimeError(f"a view read '{name}' without declaring it (declared: {self.files})")
        return _csv(self.session, self.job, name)

    def trace(self, x, y, name, **kw) -> dict:
        """A scatter trace of (x, y) within the requested range, downsampled to ``n`` points."""
        return _trace(x, y, name, self.x0, self.x1, self.n, **kw)


@dataclass(frozen=True)
class View:
    name: str
    pipeline: str
    title: str  #: what the figure shows
    units: str  #: units of the y axis
    files: tuple[str, ...]  #: the job's result files it reads
    build: Callable[[ViewInput], dict]
    #: shown only for jobs whose summary passes this (e.g. a gravity job that adjusted a network)
    when: Callable[[dict], bool] | None = None

    def info(self) -> dict:
        return {
            "name": self.name,
            "pipeline": self.pipeline,
            "title": self.title,
            "units": self.units,
            "files": list(self.files),
        }


#: every view by name, in registration order (the order a job's page shows them)
VIEWS: dict[str, View] = {}


def view(name: str, pipeline: str, title: str, units: str, files: tuple[str, ...], when=None):
    """Register the decorated ``f(v: ViewInput) -> figure dict`` as the view ``name`` of ``pipeline``
    (``when(summary)``: shown only for the jobs whose summary passes it)."""

    def register(build: Callable[[ViewInput], dict]) -> Callable[[ViewInput], dict]:
        if name in VIEWS:
            raise ValueError(f"view '{name}' registered twice")
        VIEWS[name] = View(name, pipeline, title, units, tuple(files), build, when)
        return build

    return register


def views_of(pipeline: str, summary: dict | None = None) -> list[View]:
    """The views of a pipeline's jobs, in the order they are shown (with ``summary``: those that apply to it)."""
    return [
        v for v in VIEWS.values() if v.pipeline == pipeline and (v.when is None or summary is None or v.when(summary))
    ]


def _csv(session, job: Job, name: str) -> dict[str, np.ndarray]:
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
    k = np.flatnonzero(
        np.isfinite(x)
        & np.isfinite(y)
        & ((x >= x0) if x0 is not None else True)
        & ((x <= x1) if x1 is not None else True)
    )
    if len(k) <= n:
        return k
    order = np.argsort(x[k], kind="stable")
    k = k[order]
    sel = MinMaxLTTBDownsampler().downsample(np.ascontiguousarray(x[k]), np.ascontiguousarray(y[k]), n_out=n)
    return k[np.sort(sel)]


def _trace(x, y, name, x0, x1, n, **kw):
    k = _down(np.asarray(x, float), np.asarray(y, float), x0, x1, n)
    return {
        "type": "scatter",
        "mode": kw.pop("mode", "lines"),
        "name": name,
        "x": np.asarray(x)[k].tolist(),
        "y": np.asarray(y)[k].tolist(),
        **kw,
    }


def _fig(traces, title, xt, yt, **layout):
    return {
        "data": traces,
        "layout": {
            "title": {"text": title},
            "xaxis": {"title": {"text": xt}},
            "yaxis": {"title": {"text": yt}},
            "margin": {"t": 50, "r": 20, "b": 90},
            "legend": {"orientation": "h", "y": -0.22},
            **layout,
        },
    }


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


# --- height ---------------------------------------------------------------------------------------


@view(
    "height",
    "height",
    "Height of the IMU centre: LDV (tilt compensated, uncompensated) and GNSS",
    "m (ellipsoidal)",
    ("height.csv",),
)
def _height(v: ViewInput) -> dict:
    h = v.csv("height.csv")
    t = h["t_s"]
    tr = [
        v.trace(t, h["h_m"], "LDV height (tilt compensated)"),
        v.trace(t, h["h_uncompensated_m"], "LDV height (uncompensated)"),
        v.trace(t, h["h_gnss_m"], "GNSS height (fix 4/2)", mode="markers", marker={"size": 3}),
    ]
    return _fig(tr, "Height of the IMU centre", "t (s of day)", "h (m, ellipsoidal)")


@view("height_error", "height", "Height error against GNSS, tilt compensated and uncompensated", "m", ("height.csv",))
def _height_error(v: ViewInput) -> dict:
    h, s = v.csv("height.csv"), v.summary
    t = h["t_s"]
    tr = [
        v.trace(t, h["h_m"] - h["h_gnss_m"], "error, tilt compensated", mode="markers", marker={"size": 3}),
        v.trace(t, h["h_uncompensated_m"] - h["h_gnss_m"], "error, uncompensated", mode="markers", marker={"size": 3}),
    ]
    return _fig(
        tr,
        f"Height error against GNSS: std {s.get('std_error_m', float('nan')):.3f} m, "
        f"max {s.get('max_error_m', float('nan')):.3f} m",
        "t (s of day)",
        "LDV − GNSS (m)",
    )


# --- tilt -----------------------------------------------------------------------------------------


@view("attitude", "tilt", "Pitch and roll, raw and tilt compensated", "deg", ("attitude.csv",))
def _attitude(v: ViewInput) -> dict:
    a, s = v.csv("attitude.csv"), v.summary
    t = a["t_s"]
    tr = [
        v.trace(t, a["pitch_raw_deg"], "pitch raw"),
        v.trace(t, a["pitch_deg"], "pitch compensated"),
        v.trace(t, a["roll_raw_deg"], "roll raw"),
        v.trace(t, a["roll_deg"], "roll compensated"),
    ]
    al, be = s.get("alpha_rad", 0.0), s.get("beta_rad", 0.0)
    return _fig(
        tr,
        f"Attitude: α = {al:.2e} rad ({al * ARCSEC_PER_RAD:.1f}″), β = {be:.2e} rad ({be * ARCSEC_PER_RAD:.1f}″)",
        "t (s of day)",
        "angle (deg)",
    )


# --- navigate, calibrate: the track -----------------------------------------------------------------


def _track(v: ViewInput, name: str) -> dict:
    """The solution's track in local east/north metres from its start, with the log's GNSS fixes
    (read from the log's stored ``gnss`` array), one legend entry per fix quality."""
    d = v.csv(name)
    n = v.n
    lat0, lon0 = np.radians(d["lat_deg"][0]), np.radians(d["lon_deg"][0])
    e = (np.radians(d["lon_deg"]) - lon0) * 6378137.0 * np.cos(lat0)
    nn = (np.radians(d["lat_deg"]) - lat0) * 6356752.0
    tr = [_trace(e, nn, "solution", None, None, n, mode="lines")]
    from ldvsurvey.store.logs import load_array

    g = load_array(v.session, v.job.log_ids[0], "gnss")
    if g is not None:
        ok = np.isfinite(g["lat_deg"])
        ge = (np.radians(g["lon_deg"][ok]) - lon0) * 6378137.0 * np.cos(lat0)
        gn = (np.radians(g["lat_deg"][ok]) - lat0) * 6356752.0
        fix = g["fix"][ok].astype(int)
        for q in sorted(set(fix.tolist())):  # one legend entry per fix quality (a discrete legend)
            kq = np.flatnonzero(fix == q)
            k = kq[_down(ge[kq], gn[kq], None, None, n)]
            tr.append(
                {
                    "type": "scatter",
                    "mode": "markers",
                    "name": f"GNSS, {FIX_NAMES.get(q, f'fix {q}')}",
                    "x": ge[k].tolist(),
                    "y": gn[k].tolist(),
                    "marker": {"size": 4},
                }
            )
    return _fig(
        tr,
        "Trajectory (local east/north from the start)",
        "east (m)",
        "north (m)",
        yaxis={"title": {"text": "north (m)"}, "scaleanchor": "x", "scaleratio": 1},
    )


@view(
    "trajectory",
    "navigate",
    "Trajectory in local east/north from the start, with the GNSS fixes",
    "m (north)",
    ("trajectory.csv",),
)
def _trajectory(v: ViewInput) -> dict:
    return _track(v, "trajectory.csv")


@view(
    "calibration_track",
    "calibrate",
    "Calibration drive in local east/north from the start, with the GNSS fixes",
    "m (north)",
    ("calibration_track.csv",),
)
def _calibration_track(v: ViewInput) -> dict:
    return _track(v, "calibration_track.csv")


# --- gravity ----------------------------------------------------------------------------------------


def _gravity_on_lines(v: ViewInput, residuals: bool) -> dict:
    c, s = v.csv("coincidence.csv"), v.summary
    names = sorted(set(c["line"]))
    tr = []
    for name in names:
        k = c["line"] == name
        y = c["residual_mgal"][k] if residuals else c["dg_mgal"][k]
        tr.append(v.trace(c["distance_m"][k], y, str(name)))
    if not residuals:
        k = c["line"] == names[0]
        tr.append(v.trace(c["distance_m"][k], c["mean_mgal"][k], "mean line", line={"width": 3, "color": "black"}))
        return _fig(
            tr,
            f"Gravity disturbance on the repeated lines (FIR {s.get('fir_length_s')} s, "
            f"resolution {s.get('resolution_m', 0):.0f} m, line ends trimmed "
            f"{s.get('line_end_trim_s', 0):g} s)",
            "along-track distance (m)",
            "δg (mGal)",
        )
    fl = (s.get("noise_floor") or {}).get("total_mgal")
    if fl:  # the ±1σ band white sensor noise alone would give
        d = c["distance_m"][c["line"] == names[0]]
        lo, hi = float(np.nanmin(d)), float(np.nanmax(d))
        tr.append(
            {
                "type": "scatter",
                "mode": "lines",
                "name": f"white-noise floor ±{fl:.3f} mGal",
                "x": [lo, hi, None, lo, hi],
                "y": [fl, fl, None, -fl, -fl],
                "line": {"dash": "dash", "color": "black"},
            }
        )
        comb = (s.get("noise_floor") or {}).get("combined_mgal")
        if comb and (s.get("noise_floor") or {}).get("drift_mgal") is not None:
            tr.append(
                {
                    "type": "scatter",
                    "mode": "lines",
                    "name": f"floor with the drift ±{comb:.3f} mGal",
                    "x": [lo, hi, None, lo, hi],
                    "y": [comb, comb, None, -comb, -comb],
                    "line": {"dash": "dot", "color": "gray"},
                }
            )
    return _fig(tr, f"Residuals about the mean line: {_floor_text(s)}", "along-track distance (m)", "residual (mGal)")


@view(
    "gravity_lines", "gravity", "Gravity disturbance on the repeated lines and their mean", "mGal", ("coincidence.csv",)
)
def _gravity_lines(v: ViewInput) -> dict:
    return _gravity_on_lines(v, residuals=False)


@view(
    "gravity_residuals",
    "gravity",
    "Residuals about the mean line beside the white-noise floor",
    "mGal",
    ("coincidence.csv",),
)
def _gravity_residuals(v: ViewInput) -> dict:
    return _gravity_on_lines(v, residuals=True)


@view(
    "gravity_compare_gnss",
    "gravity",
    "SINS/LDV against SINS/GNSS (and LDV+GNSS navigation) along each line",
    "mGal",
    ("gravity.csv",),
)
def _gravity_compare_gnss(v: ViewInput) -> dict:
    g, s = v.csv("gravity.csv"), v.summary
    on = g["line"] != ""
    gc = s.get("gnss_comparison") or {}
    tr = []
    other = "dg_sins_gnss_mgal" if "dg_sins_gnss_mgal" in g else None
    for name in sorted(set(g["line"][on])):
        k = g["line"] == name
        if other is not None:  # the two chains' difference along each line
            tr.append(v.trace(g["distance_m"][k], g["dg_mgal"][k] - g[other][k], f"{name}: SINS/LDV − SINS/GNSS"))
        if "dg_gnss_aided_mgal" in g:
            tr.append(
                v.trace(
                    g["distance_m"][k],
                    g["dg_mgal"][k] - g["dg_gnss_aided_mgal"][k],
                    f"{name}: LDV − LDV+GNSS navigation",
                    line={"dash": "dot"},
                )
            )
    rms = [f"{d['name']} {d['rms_mgal']:.2f}" for d in gc.get("ldv_minus_gnss", []) if d.get("rms_mgal") is not None]
    title = f"SINS/LDV {_floor_text(s)} vs SINS/GNSS {_floor_text(gc)}; difference RMS per line (mGal): " + (
        ", ".join(rms) if rms else "none"
    )
    return _fig(tr, title, "along-track distance (m)", "δg difference (mGal)")


@view(
    "gravity_network_map",
    "gravity",
    "Adjusted gravity disturbance of the survey network along all tracks, with the base ties",
    "mGal",
    ("gravity_adjusted.csv", "network_residuals.csv"),
    when=lambda s: "network" in s,
)
def _gravity_network_map(v: ViewInput) -> dict:
    g, net = v.csv("gravity_adjusted.csv"), v.summary.get("network") or {}
    lat0, lon0 = np.radians(np.nanmean(g["lat_deg"])), np.radians(np.nanmean(g["lon_deg"]))
    e = (np.radians(g["lon_deg"]) - lon0) * 6378137.0 * np.cos(lat0)
    nn = (np.radians(g["lat_deg"]) - lat0) * 6356752.0
    k = np.flatnonzero(np.isfinite(g["dg_mgal"]))
    k = k[np.linspace(0, len(k) - 1, min(len(k), v.n)).astype(int)] if len(k) else k
    tr = [
        {
            "type": "scatter",
            "mode": "markers",
            "name": "adjusted δg (mGal)",
            "x": e[k].tolist(),
            "y": nn[k].tolist(),
            "text": [
                f"{ln}: {x:.2f} ± {s:.2f} mGal" for ln, x, s in zip(g["line"][k], g["dg_mgal"][k], g["sigma_mgal"][k])
            ],
            "marker": {
                "size": 4,
                "color": g["dg_mgal"][k].tolist(),
                "colorscale": "Viridis",
                "showscale": True,
                "colorbar": {"title": {"text": "δg (mGal)"}},
            },
        }
    ]
    r = v.csv("network_residuals.csv")
    tie = r["kind"] == "tie"
    if tie.any():
        te = (np.radians(r["lon_deg"][tie]) - lon0) * 6378137.0 * np.cos(lat0)
        tn = (np.radians(r["lat_deg"][tie]) - lat0) * 6356752.0
        tr.append(
            {
                "type": "scatter",
                "mode": "markers",
                "name": "base ties (residual mGal)",
                "x": te.tolist(),
                "y": tn.tolist(),
                "text": [f"{n}: {x:+.2f} mGal" for n, x in zip(r["line"][tie], r["residual_mgal"][tie])],
                "marker": {"size": 12, "symbol": "triangle-up", "color": "red"},
            }
        )
    res = [ln.get("resolution_m") for ln in net.get("lines", []) if ln.get("resolution_m")]
    xo, rep, fl = net.get("crossover_rms_after_mgal"), net.get("repeat_rms_after_mgal"), net.get("noise_floor_mgal")
    nan = float("nan")
    title = (
        f"Network ({net.get('datum', '')[:4]} datum ±{net.get('datum_sigma_mgal', nan):.2f} mGal): "
        f"crossovers ±{nan if xo is None else xo:.2f}, repeats ±{nan if rep is None else rep:.2f} "
        f"mGal (floor ±{nan if fl is None else fl:.2f}); resolution "
        + (f"{min(res):.0f}–{max(res):.0f} m" if res else "–")
    )
    return _fig(
        tr, title, "east (m)", "north (m)", yaxis={"title": {"text": "north (m)"}, "scaleanchor": "x", "scaleratio": 1}
    )


def _gravity_view(session, job: Job, name: str, s: dict, x0, x1, n) -> dict:
    """A gravity view by name on a summary ``s`` (the registered function; kept for callers that
    pass the summary themselves)."""
    if not name.startswith("gravity_") or name not in VIEWS:
        raise HTTPException(404, f"unknown view '{name}'")
    v = VIEWS[name]
    return v.build(ViewInput(session, job, s, x0, x1, n, v.files))


# --- dov --------------------------------------------------------------------------------------------


@view("dov_deflection", "dov", "Deflection of the vertical ξ, η along the track", "arcsec", ("dov.csv",))
def _dov_deflection(v: ViewInput) -> dict:
    d, s = v.csv("dov.csv"), v.summary
    t = d["t_s"]
    return _fig(
        [v.trace(t, d["xi_arcsec"], "ξ"), v.trace(t, d["eta_arcsec"], "η")],
        f"Deflection of the vertical along the track ({s.get('dov_source', '')})",
        "t (s of day)",
        "arcsec",
    )


@view("dov_error", "dov", "Position error the DOV causes: direct, RK4 and theoretical", "m", ("dov.csv",))
def _dov_error(v: ViewInput) -> dict:
    d = v.csv("dov.csv")
    t = d["t_s"]
    tr = []
    for m in ("direct", "rk4", "theoretical"):
        tr.append(v.trace(t, d[f"dn_{m}_m"], f"north, {m}"))
        tr.append(v.trace(t, d[f"de_{m}_m"], f"east, {m}", line={"dash": "dot"}))
    return _fig(tr, "DOV-caused position error", "t (s of day)", "m")


# --- damping ----------------------------------------------------------------------------------------


@view(
    "damping",
    "damping",
    "North position error: undamped, conventional and delayed-state damping",
    "m",
    ("damping.csv",),
)
def _damping(v: ViewInput) -> dict:
    d, s = v.csv("damping.csv"), v.summary
    t = d["t_s"]
    tr = [
        v.trace(t, d[f"{m}_north_error_m"], f"{m.replace('_', ' ')}, north")
        for m in ("undamped", "conventional", "delayed_state")
    ]
    return _fig(
        tr,
        f"Position error: delayed-state improves {s.get('position_improvement_pct', 0):.1f} % over conventional",
        "t (s of day)",
        "north error (m)",
    )


def build_view(session, job: Job, name: str, x0, x1, n) -> dict:
    """The figure of view ``name`` of a (succeeded) job; 404 when the job's pipeline has no such view."""
    v = VIEWS.get(name)
    if v is None or v.pipeline != job.pipeline or (v.when is not None and not v.when(job.summary or {})):
        raise HTTPException(
            404,
            f"no view '{name}' for a {job.pipeline} job (views: {[x.name for x in views_of(job.pipeline)] or None})",
        )
    return v.build(ViewInput(session, job, job.summary or {}, x0, x1, n, v.files))
