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
from typing import Protocol

import numpy as np
import pyarrow.csv as pacsv
from tsdownsample import MinMaxLTTBDownsampler

from ldvsurvey.io.nmea import FIX_QUALITY_NAMES
from ldvsurvey.nav.localframe import local_latlon, local_metres
from ldvsurvey.units import ARCSEC_PER_RAD, DEG_PER_RAD, RAD_PER_DEG

#: a step of the data's own order (time or distance) this many times its median step is a gap
GAP_FACTOR = 5.0
#: a title line longer than this many characters is broken (Plotly cuts titles wider than the plot)
TITLE_LINE_CHARS = 80


def fix_name(q: int) -> str:
    """'4 RTK fixed' for GGA fix quality 4 (``fix 9`` for a code without a name)."""
    return FIX_QUALITY_NAMES.get(int(q), f"fix {int(q)}")


class MissingResult(LookupError):
    """A view asked for a result table the job does not have (the route answers 404)."""


class UnknownView(LookupError):
    """No view of that name for the job's pipeline (the route answers 404)."""


class Tables(Protocol):
    """Where a view's data comes from: the job's result tables and its first log's stored arrays."""

    def csv(self, name: str) -> dict[str, np.ndarray]:
        """The columns of result file ``name``; raises :class:`MissingResult` when there is none."""

    def log_array(self, name: str) -> dict[str, np.ndarray] | None:
        """A stored stream of the job's first log (``gnss``, ``imu``, ``ldv``), or None."""


def read_csv_bytes(data: bytes) -> dict[str, np.ndarray]:
    """The columns of a result CSV (numbers as float, text as object arrays of str)."""
    table = pacsv.read_csv(io.BytesIO(data))
    out = {}
    for c in table.column_names:
        col = table.column(c)
        try:
            out[c] = col.to_numpy(zero_copy_only=False).astype(float)
        except (ValueError, TypeError):
            out[c] = np.array([("" if v is None else str(v)) for v in col.to_pylist()], dtype=object)
    return out


@dataclass
class DictTables:
    """:class:`Tables` held in memory (a CLI run's tables, a test's): ``{"height.csv": {column: array}}``."""

    tables: dict[str, dict[str, np.ndarray]]
    arrays: dict[str, dict[str, np.ndarray]] | None = None

    def csv(self, name: str) -> dict[str, np.ndarray]:
        """The columns of result file ``name``; :class:`MissingResult` when there is none."""
        if name not in self.tables:
            raise MissingResult(f"no result file '{name}'")
        return self.tables[name]

    def log_array(self, name: str) -> dict[str, np.ndarray] | None:
        """A stored stream of the log (``gnss``, ``imu``, ``ldv``), or None."""
        return (self.arrays or {}).get(name)


@dataclass
class ViewInput:
    """What a view function gets: its tables, the job's summary and the requested range and point count."""

    tables: Tables
    summary: dict
    x0: float | None
    x1: float | None
    n: int  #: at most this many points per trace
    files: tuple[str, ...] = ()  #: the result files the view declared (read no others)

    def csv(self, name: str) -> dict[str, np.ndarray]:
        """The columns of one of the job's result files (numbers as float, text as object arrays)."""
        if self.files and name not in self.files:
            raise RuntimeError(f"a view read '{name}' without declaring it (declared: {self.files})")
        return self.tables.csv(name)

    def trace(self, x, y, name, order=None, **kw) -> dict:
        """A scatter trace of (x, y) within the requested x range, thinned to ``n`` points in data order,
        broken (``None``) where the data has a gap: a non-finite value, a point outside the range, or a
        step of ``order`` (default: x when it increases, else the row number) over ``GAP_FACTOR`` × its
        median step."""
        return _trace(x, y, name, self.x0, self.x1, self.n, order=order, **kw)


@dataclass(frozen=True)
class View:
    """A registered view: its name, pipeline, title, y units, the result files it reads, its builder and whether a job's
    summary has something to show in it."""

    name: str
    pipeline: str
    title: str  #: what the figure shows
    units: str  #: units of the y axis
    files: tuple[str, ...]  #: the job's result files it reads
    build: Callable[[ViewInput], dict]
    #: whether a job with this summary has something to show in it (None: always); a job's page
    #: lists only those (no empty panels, e.g. no SINS/LDV comparison on a log without an LDV)
    shows: Callable[[dict], bool] | None = None

    def info(self) -> dict:
        """The view as ``GET /api/views`` lists it: name, pipeline, title, units and files."""
        return {
            "name": self.name,
            "pipeline": self.pipeline,
            "title": self.title,
            "units": self.units,
            "files": list(self.files),
        }


#: every view by name, in registration order (the order a job's page shows them)
VIEWS: dict[str, View] = {}


def view(name: str, pipeline: str, title: str, units: str, files: tuple[str, ...], shows=None):
    """Register the decorated ``f(v: ViewInput) -> figure dict`` as the view ``name`` of ``pipeline``
    (``shows(summary) -> bool``: whether a job has anything for it; default always)."""

    def register(build: Callable[[ViewInput], dict]) -> Callable[[ViewInput], dict]:
        if name in VIEWS:
            raise ValueError(f"view '{name}' registered twice")
        VIEWS[name] = View(name, pipeline, title, units, tuple(files), build, shows)
        return build

    return register


def views_of(pipeline: str, summary: dict | None = None) -> list[View]:
    """The views of a pipeline's jobs, in the order they are shown (with ``summary``: those that
    have something to show for that job)."""
    return [
        v for v in VIEWS.values() if v.pipeline == pipeline and (summary is None or v.shows is None or v.shows(summary))
    ]


def _lttb(x, y, n):
    """Indices (ascending) of at most n points of a series whose x increases (MinMax-LTTB)."""
    if len(x) <= n:
        return np.arange(len(x))
    sel = MinMaxLTTBDownsampler().downsample(np.ascontiguousarray(x), np.ascontiguousarray(y), n_out=n)
    return np.sort(sel)


def _down(x, y, x0, x1, n):
    """Indices, in the data's own order, of at most about n points of (x, y) within [x0, x1].

    Never sorted by x: a path is not a function of x. A series whose x increases is thinned by
    MinMax-LTTB on x; a path (x not monotonic) by MinMax-LTTB of x and of y against the row number,
    half the points each, so that the extremes of both coordinates stay.
    """
    x, y = np.asarray(x, float), np.asarray(y, float)
    k = np.flatnonzero(
        np.isfinite(x)
        & np.isfinite(y)
        & ((x >= x0) if x0 is not None else True)
        & ((x <= x1) if x1 is not None else True)
    )
    if len(k) <= n:
        return k
    xk, yk = x[k], y[k]
    if np.all(np.diff(xk) >= 0):
        return k[_lttb(xk, yk, n)]
    row = k.astype(float)
    half = max(n // 2, 2)
    return k[np.union1d(_lttb(row, xk, half), _lttb(row, yk, half))]


def _breaks(k, ok, order):
    """For thinned indices ``k`` (ascending) of rows where ``ok``: True between k[i] and k[i+1] when a row
    between them is not ok or a step of ``order`` between them is a gap (> GAP_FACTOR × median step)."""
    if len(k) < 2:
        return np.zeros(0, bool)
    bad = np.concatenate([[0], np.cumsum(~ok)])  # not-ok rows before each row
    brk = bad[k[1:]] - bad[k[:-1] + 1] > 0
    if order is not None and len(order) > 2:
        step = np.diff(order)
        fin = step[np.isfinite(step) & (step > 0)]
        if len(fin):
            gap = ~(np.abs(step) <= GAP_FACTOR * np.median(fin))  # NaN steps are gaps too
            ng = np.concatenate([[0], np.cumsum(gap)])  # gap steps before each row
            brk |= ng[k[1:]] - ng[k[:-1]] > 0
    return brk


def _trace(x, y, name, x0, x1, n, order=None, **kw):
    x, y = np.asarray(x, float), np.asarray(y, float)
    k = _down(x, y, x0, x1, n)
    ok = (
        np.isfinite(x)
        & np.isfinite(y)
        & ((x >= x0) if x0 is not None else True)
        & ((x <= x1) if x1 is not None else True)
    )
    if order is None:
        fx = x[np.isfinite(x)]
        order = x if len(fx) > 1 and np.all(np.diff(fx) >= 0) else None
    brk = _breaks(k, ok, None if order is None else np.asarray(order, float))
    xs, ys = [], []
    for i, j in enumerate(k):
        if i and brk[i - 1]:
            xs.append(None)
            ys.append(None)
        xs.append(float(x[j]))
        ys.append(float(y[j]))
    return {"type": "scatter", "mode": kw.pop("mode", "lines"), "name": name, "x": xs, "y": ys, **kw}


def title_layout(title: str) -> dict:
    """A title block hung from the top of the figure, centred (it grows down into the top margin)."""
    return {
        "text": title,
        "x": 0.5,
        "xanchor": "center",
        "y": 1.0,
        "yref": "container",
        "yanchor": "top",
        "pad": {"t": 8},
        "font": {"size": 15},
    }


def title_margin(title: str) -> int:
    """The top margin (px) that holds a title of this many lines above the plot area."""
    return 24 + 21 * (title.count("<br>") + 1)


def fit_title(text: str, width: int = TITLE_LINE_CHARS) -> str:
    """A title broken into lines of at most ``width`` characters (at '; ', ', ' or spaces, '<br>' between)."""
    lines = []
    for part in text.split("<br>"):
        while len(part) > width:
            cut = max(part.rfind("; ", 0, width), part.rfind(", ", 0, width))
            cut = cut + 1 if cut > width // 3 else part.rfind(" ", 0, width)
            if cut <= 0:
                cut = width
            lines.append(part[:cut].rstrip())
            part = part[cut:].lstrip()
        lines.append(part)
    return "<br>".join(lines)


def _fig(traces, title, xt, yt, **layout):
    """A figure: the title broken to fit (the top margin grows with its lines), axis titles with units."""
    title = fit_title(title)
    return {
        "data": traces,
        "layout": {
            "title": title_layout(title),
            "xaxis": {"title": {"text": xt}},
            "yaxis": {"title": {"text": yt}},
            "margin": {"t": title_margin(title), "r": 20, "b": 90},
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


def _m(x) -> str:
    return "–" if x is None else f"{x:.3f} m"


@view(
    "height_error",
    "height",
    "Height error against GNSS by fix quality (RTK fixed and DGPS), tilt compensated and uncompensated",
    "m",
    ("height.csv",),
)
def _height_error(v: ViewInput) -> dict:
    h, s = v.csv("height.csv"), v.summary
    t = h["t_s"]
    fix = h["fix_quality"] if "fix_quality" in h else np.zeros(len(t))
    tr = []
    for q in sorted(set(fix[np.isfinite(h["h_gnss_m"])].astype(int).tolist())):  # each reference fix apart
        k = fix == q
        err = np.where(k, h["h_m"] - h["h_gnss_m"], np.nan)
        err_raw = np.where(k, h["h_uncompensated_m"] - h["h_gnss_m"], np.nan)
        tr.append(v.trace(t, err, f"tilt compensated, against {fix_name(q)}", mode="markers", marker={"size": 3}))
        tr.append(
            v.trace(
                t, err_raw, f"uncompensated, against {fix_name(q)}", mode="markers", marker={"size": 3, "symbol": "x"}
            )
        )
    rtk = (
        f"against RTK fixed (fix 4; n = {s.get('n_reference_fix4')}): std {_m(s.get('std_error_m_fix4'))}, "
        f"max {_m(s.get('max_error_m_fix4'))}"
        if s.get("n_reference_fix4")
        else "no RTK-fixed reference"
    )
    both = (
        f"against RTK fixed + DGPS (fix 4, 2; n = {s.get('n_reference')}): std {_m(s.get('std_error_m'))}, "
        f"max {_m(s.get('max_error_m'))}"
    )
    return _fig(tr, f"Height error, tilt compensated<br>{rtk}<br>{both}", "t (s of day)", "LDV − GNSS height (m)")


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


def nice_length(span_m: float) -> float:
    """A round scale-bar length (1, 2 or 5 × 10^k m) near a fifth of ``span_m``."""
    target = max(span_m / 5.0, 1e-3)
    k = 10 ** np.floor(np.log10(target))
    return float(min((c * k for c in (1, 2, 5, 10)), key=lambda c: abs(c - target)))


def _map_fig(traces: list[dict], title: str, lat0: float, lon0: float, **layout) -> dict:
    """A plain projected map: east/north metres of the local tangent plane at (lat0, lon0) (rad),
    equal scales, a scale bar (bottom left, in data units so it stays true) and a north arrow.
    ``layout.meta.map`` carries the origin, so a page may redraw the traces on a basemap."""
    xs = np.array([p for t in traces for p in t["x"] if p is not None], float)
    ys = np.array([p for t in traces for p in t["y"] if p is not None], float)
    shapes, notes = [], []
    if len(xs):
        span = max(np.ptp(xs), np.ptp(ys), 1.0)
        bar = nice_length(span)
        x0, y0 = float(xs.min()), float(ys.min())
        shapes.append({"type": "line", "xref": "x", "yref": "y", "x0": x0, "x1": x0 + bar, "y0": y0, "y1": y0,
                       "line": {"width": 4, "color": "black"}})  # fmt: skip
        notes.append({"xref": "x", "yref": "y", "x": x0 + bar / 2, "y": y0, "yshift": 12, "showarrow": False,
                      "text": f"{bar:g} m" if bar < 1000 else f"{bar / 1000:g} km", "name": "scale bar"})  # fmt: skip
    notes += [
        {"xref": "paper", "yref": "paper", "x": 1.0, "y": 0.93, "ax": 0, "ay": 45, "showarrow": True,
         "arrowhead": 2, "arrowwidth": 2, "text": "", "name": "north arrow"},
        {"xref": "paper", "yref": "paper", "x": 1.0, "y": 0.93, "yanchor": "bottom", "showarrow": False,
         "text": "<b>N</b>", "name": "north"},
    ]  # fmt: skip
    return _fig(
        traces,
        f"{title}<br>origin {lat0 * DEG_PER_RAD:.6f}°, {lon0 * DEG_PER_RAD:.6f}° (WGS-84); north up",
        "east (m)",
        "north (m)",
        # the data's extent (5 % margin) on equal scales: the plot area shrinks to fit, the ranges do not grow
        xaxis={"title": {"text": "east (m)"}, "constrain": "domain", **_padded(xs)},
        yaxis={
            "title": {"text": "north (m)"},
            "scaleanchor": "x",
            "scaleratio": 1,
            "constrain": "domain",
            **_padded(ys),
        },
        shapes=shapes,
        annotations=notes,
        meta={"map": {"lat0_deg": lat0 * DEG_PER_RAD, "lon0_deg": lon0 * DEG_PER_RAD}},
        **layout,
    )


def _padded(v: np.ndarray) -> dict:
    if not len(v):
        return {}
    pad = 0.05 * max(float(np.ptp(v)), 1.0)
    return {"range": [float(v.min()) - pad, float(v.max()) + pad]}


def _gnss_traces(v: ViewInput, lat0: float, lon0: float) -> list[dict]:
    """The log's GNSS fixes in local metres, one trace (and legend entry) per fix quality."""
    g = v.tables.log_array("gnss")
    if g is None:
        return []
    ok = np.isfinite(g["lat_deg"]) & np.isfinite(g["lon_deg"])
    ge, gn = local_metres(lat0, lon0, g["lat_deg"][ok] * RAD_PER_DEG, g["lon_deg"][ok] * RAD_PER_DEG)
    fix = np.asarray(g["fix"])[ok].astype(int)
    lat, lon = g["lat_deg"][ok], g["lon_deg"][ok]
    out = []
    for q in sorted(set(fix.tolist())):  # a discrete legend
        kq = np.flatnonzero(fix == q)
        k = kq[_down(ge[kq], gn[kq], None, None, v.n)]
        out.append(
            {
                "type": "scatter",
                "mode": "markers",
                "name": f"GNSS, {fix_name(q)}",
                "x": ge[k].tolist(),
                "y": gn[k].tolist(),
                "marker": {"size": 4},
                "meta": {"lat": lat[k].tolist(), "lon": lon[k].tolist()},
            }
        )
    return out


def _with_latlon(tr: dict, lat0: float, lon0: float) -> dict:
    """The trace's points also as latitude/longitude (``meta``), for a basemap: the inverse of
    local_metres (a small area), breaks kept."""
    lat, lon = local_latlon(lat0, lon0, _floats(tr["x"]), _floats(tr["y"]))
    return {**tr, "meta": {"lat": _points(lat * DEG_PER_RAD), "lon": _points(lon * DEG_PER_RAD)}}


def _floats(p: list) -> np.ndarray:
    """A trace's coordinates as floats, a break (None) as NaN."""
    return np.array([np.nan if x is None else x for x in p], float)


def _points(a: np.ndarray) -> list:
    """Floats as a trace's coordinates, NaN as a break (None)."""
    return [None if np.isnan(x) else x for x in a.tolist()]


def _track(v: ViewInput, name: str) -> dict:
    """The solution's track in local east/north metres from its start, with the log's GNSS fixes
    (the log's stored ``gnss`` array), one legend entry per fix quality; thinned in time order."""
    d = v.csv(name)
    lat0, lon0 = d["lat_deg"][0] * RAD_PER_DEG, d["lon_deg"][0] * RAD_PER_DEG
    e, nn = local_metres(lat0, lon0, d["lat_deg"] * RAD_PER_DEG, d["lon_deg"] * RAD_PER_DEG)
    sol = _with_latlon(v.trace(e, nn, "solution", order=d.get("t_s"), mode="lines"), lat0, lon0)
    return _map_fig([sol, *_gnss_traces(v, lat0, lon0)], "Trajectory (local east/north from the start)", lat0, lon0)


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
    shows=lambda s: "gnss_comparison" in s or "gnss_aided" in s,  # a log without an LDV has neither
)
def _gravity_compare_gnss(v: ViewInput) -> dict:
    g, s = v.csv("gravity.csv"), v.summary
    on = g["line"] != ""
    gc = s.get("gnss_comparison") or {}
    tr = []
    other = "dg_sins_gnss_mgal" if "dg_sins_gnss_mgal" in g else None
    for name in sorted(set(g["line"][on])):
        k = g["line"] == name
        t = g["t_s"][k] if "t_s" in g else None  # the data's order; NaN where a chain has no value: a break
        if other is not None:  # the two chains' difference along each line
            tr.append(
                v.trace(g["distance_m"][k], g["dg_mgal"][k] - g[other][k], f"{name}: SINS/LDV − SINS/GNSS", order=t)
            )
        if "dg_gnss_aided_mgal" in g:
            tr.append(
                v.trace(
                    g["distance_m"][k],
                    g["dg_mgal"][k] - g["dg_gnss_aided_mgal"][k],
                    f"{name}: LDV − LDV+GNSS navigation",
                    order=t,
                    line={"dash": "dot"},
                )
            )
    rms = [f"{d['name']} {d['rms_mgal']:.2f}" for d in gc.get("ldv_minus_gnss", []) if d.get("rms_mgal") is not None]
    title = (
        f"SINS/LDV − SINS/GNSS along each line<br>repeatability SINS/LDV {_floor_text(s)}<br>"
        f"repeatability SINS/GNSS {_floor_text(gc)}<br>difference RMS per line (mGal): "
        + (", ".join(rms) if rms else "none")
    )
    return _fig(tr, title, "along-track distance (m)", "δg difference (mGal)")


@view(
    "gravity_map",
    "gravity",
    "Map: the gravity disturbance along the survey lines, with the GNSS fixes",
    "m (north)",
    ("gravity.csv",),
)
def _gravity_map(v: ViewInput) -> dict:
    g = v.csv("gravity.csv")
    on = np.flatnonzero((g["line"] != "") & np.isfinite(g["lat_deg"]) & np.isfinite(g["lon_deg"]))
    if not len(on):
        return _fig([], "No position on the survey lines to map", "east (m)", "north (m)")
    lat0, lon0 = g["lat_deg"][on[0]] * RAD_PER_DEG, g["lon_deg"][on[0]] * RAD_PER_DEG
    e, n = local_metres(lat0, lon0, g["lat_deg"][on] * RAD_PER_DEG, g["lon_deg"][on] * RAD_PER_DEG)
    dg = g["dg_mgal"][on]
    k = _down(np.arange(len(on), dtype=float), dg, None, None, v.n)  # in the data's order, extremes of δg kept
    tr = {
        "type": "scatter",
        "mode": "markers",
        "name": "δg on the survey lines",
        "x": e[k].tolist(),
        "y": n[k].tolist(),
        "marker": {"size": 5, "color": dg[k].tolist(), "colorscale": "Viridis", "showscale": True,
                   "colorbar": {"title": {"text": "δg (mGal)"}}},
        "meta": {"lat": g["lat_deg"][on][k].tolist(), "lon": g["lon_deg"][on][k].tolist()},
    }  # fmt: skip
    return _map_fig([*_gnss_traces(v, lat0, lon0), tr], "Gravity disturbance along the survey lines", lat0, lon0)


@view(
    "gravity_network_map",
    "gravity",
    "Map: the adjusted gravity disturbance of the survey network along all tracks, with the base ties",
    "m (north)",
    ("gravity_adjusted.csv", "network_residuals.csv"),
    shows=lambda s: "network" in s,
)
def _gravity_network_map(v: ViewInput) -> dict:
    g, net = v.csv("gravity_adjusted.csv"), v.summary.get("network") or {}
    on = np.flatnonzero(np.isfinite(g["dg_mgal"]) & np.isfinite(g["lat_deg"]) & np.isfinite(g["lon_deg"]))
    if not len(on):
        return _fig([], "No adjusted value to map", "east (m)", "north (m)")
    lat0, lon0 = g["lat_deg"][on[0]] * RAD_PER_DEG, g["lon_deg"][on[0]] * RAD_PER_DEG
    e, nn = local_metres(lat0, lon0, g["lat_deg"][on] * RAD_PER_DEG, g["lon_deg"][on] * RAD_PER_DEG)
    dg, sig, line = g["dg_mgal"][on], g["sigma_mgal"][on], g["line"][on]
    k = _down(np.arange(len(on), dtype=float), dg, None, None, v.n)  # in the data's order, extremes of δg kept
    tr = [
        {
            "type": "scatter",
            "mode": "markers",
            "name": "adjusted δg",
            "x": e[k].tolist(),
            "y": nn[k].tolist(),
            "text": [f"{ln}: {x:.2f} ± {sg:.2f} mGal" for ln, x, sg in zip(line[k], dg[k], sig[k])],
            "marker": {
                "size": 4,
                "color": dg[k].tolist(),
                "colorscale": "Viridis",
                "showscale": True,
                "colorbar": {"title": {"text": "δg (mGal)"}},
            },
            "meta": {"lat": g["lat_deg"][on][k].tolist(), "lon": g["lon_deg"][on][k].tolist()},
        }
    ]
    r = v.csv("network_residuals.csv")
    tie = np.flatnonzero(r["kind"] == "tie")
    if len(tie):
        te, tn = local_metres(lat0, lon0, r["lat_deg"][tie] * RAD_PER_DEG, r["lon_deg"][tie] * RAD_PER_DEG)
        tr.append(
            {
                "type": "scatter",
                "mode": "markers",
                "name": "base ties (residual in mGal)",
                "x": te.tolist(),
                "y": tn.tolist(),
                "text": [f"{n}: {x:+.2f} mGal" for n, x in zip(r["line"][tie], r["residual_mgal"][tie])],
                "marker": {"size": 12, "symbol": "triangle-up", "color": "red"},
                "meta": {"lat": r["lat_deg"][tie].tolist(), "lon": r["lon_deg"][tie].tolist()},
            }
        )
    res = [ln.get("resolution_m") for ln in net.get("lines", []) if ln.get("resolution_m")]
    xo, rep, fl = net.get("crossover_rms_after_mgal"), net.get("repeat_rms_after_mgal"), net.get("noise_floor_mgal")
    nan = float("nan")
    title = (
        f"Adjusted δg ({net.get('datum', '')[:4]} datum ±{net.get('datum_sigma_mgal', nan):.2f} mGal)<br>"
        f"crossovers ±{nan if xo is None else xo:.2f}, repeats ±{nan if rep is None else rep:.2f} mGal "
        f"(floor ±{nan if fl is None else fl:.2f}); resolution " + (f"{min(res):.0f}–{max(res):.0f} m" if res else "–")
    )
    return _map_fig(tr, title, lat0, lon0)


# --- dov --------------------------------------------------------------------------------------------


@view("dov_deflection", "dov", "Deflection of the vertical ξ, η along the track", "arcsec", ("dov.csv",))
def _dov_deflection(v: ViewInput) -> dict:
    d, s = v.csv("dov.csv"), v.summary
    t = d["t_s"]
    return _fig(
        [v.trace(t, d["xi_arcsec"], "ξ"), v.trace(t, d["eta_arcsec"], "η")],
        f"Deflection of the vertical along the track ({s.get('dov_source', '')})",
        "t (s of day)",
        "deflection (arcsec)",
    )


@view("dov_error", "dov", "Position error the DOV causes: direct, RK4 and theoretical", "m", ("dov.csv",))
def _dov_error(v: ViewInput) -> dict:
    d = v.csv("dov.csv")
    t = d["t_s"]
    tr = []
    for m in ("direct", "rk4", "theoretical"):
        tr.append(v.trace(t, d[f"dn_{m}_m"], f"north, {m}"))
        tr.append(v.trace(t, d[f"de_{m}_m"], f"east, {m}", line={"dash": "dot"}))
    return _fig(tr, "DOV-caused position error", "t (s of day)", "position error (m)")


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


def build_view(tables: Tables, pipeline: str, summary: dict, name: str, x0, x1, n) -> dict:
    """The figure of view ``name`` of a job of ``pipeline`` on its tables; :class:`UnknownView` when that
    pipeline has no such view, :class:`MissingResult` when a table is missing."""
    v = VIEWS.get(name)
    if v is None or v.pipeline != pipeline or (v.shows is not None and not v.shows(summary or {})):
        raise UnknownView(
            f"no view '{name}' for a {pipeline} job (views: {[x.name for x in views_of(pipeline)] or None})"
        )
    return v.build(ViewInput(tables, summary or {}, x0, x1, n, v.files))
