"""The survey report: one self-contained HTML file per job or per project, to hand to a client.

Everything is inside the file: the style sheet, the figures as static SVG (drawn on the server by
matplotlib from the same figures the dashboard shows, :mod:`ldvsurvey.api.views`, and a map in
projected metres with a scale bar and a north arrow), the tables, the warnings and the provenance
(each input's SHA-256, every parameter, the software version, the dates). No script, no link to
fetch: it opens offline and prints to PDF from the browser (``@page`` A4, figures kept whole).

Pure functions of their inputs (:class:`ReportJob`, holding a job's summary and a table reader);
the routes in :mod:`ldvsurvey.api.reports` gather those from the database.
"""

from __future__ import annotations

import datetime as dt
import html
import io
import math
import re
from dataclasses import dataclass, field

import numpy as np

from ldvsurvey.api.views import VIEWS, MissingResult, Tables, build_view, views_of
from ldvsurvey.nav.localframe import local_metres
from ldvsurvey.pipelines.labels import label_unit
from ldvsurvey.units import RAD_PER_DEG

#: points per trace in a report figure (enough for print; keeps the file small)
REPORT_POINTS = 800
#: points per layer on a report map
MAP_POINTS = 1000
#: the headline figures of each pipeline: (summary key path, label)
HEADLINES = {
    "gravity": [
        ("total_mgal", "Repeatability: 1σ of the residuals about the mean line"),
        ("noise_floor.total_mgal", "White-noise floor of the sensors after the same processing"),
        ("floor_ratio", "Ratio of the repeatability to the white-noise floor"),
        ("noise_floor.combined_mgal", "Floor with the accelerometer drift"),
        ("combined_floor_ratio", "Ratio to the floor with the drift"),
        ("crossover_mgal", "Crossover differences, 1σ"),
        ("n_lines_compared", "Lines compared"),
        ("common_length_m", "Common length of the lines"),
        ("resolution_m", "Spatial resolution (half wavelength)"),
        ("fir_length_s", "FIR filter length"),
    ],
    "height": [
        ("std_error_m_fix4", "Height error against RTK fixed (fix 4), 1σ"),
        ("max_error_m_fix4", "Height error against RTK fixed (fix 4), largest"),
        ("n_reference_fix4", "RTK-fixed reference epochs"),
        ("std_error_m", "Height error against RTK fixed and DGPS (fix 4, 2), 1σ"),
        ("max_error_m", "Height error against RTK fixed and DGPS (fix 4, 2), largest"),
        ("n_reference", "Reference epochs (fix 4, 2)"),
        ("std_error_m_uncompensated", "Without tilt compensation, 1σ"),
        ("alpha_rad", "Base tilt α"),
        ("beta_rad", "Base tilt β"),
    ],
    "navigate": [
        ("rms_horizontal_error_m", "Horizontal error against GNSS, RMS"),
        ("max_horizontal_error_m", "Horizontal error against GNSS, largest"),
        ("max_height_error_m", "Height error against GNSS, largest"),
        ("n_reference", "Reference epochs"),
        ("alignment_method", "How the start heading was found (alignment)"),
        ("alignment_heading_sigma_deg", "Start heading 1σ from the alignment"),
    ],
}

CSS = """
:root { color-scheme: light; }
body { font: 10.5pt/1.4 "DejaVu Sans", "Liberation Sans", Arial, sans-serif; color: #111; margin: 2em auto;
  max-width: 60em; padding: 0 1em; }
h1 { font-size: 17pt; margin: 0 0 .2em; } h2 { font-size: 13pt; margin: 1.4em 0 .4em; border-bottom: 1px solid #999; }
h3 { font-size: 11pt; margin: 1em 0 .3em; }
table { border-collapse: collapse; margin: .3em 0 .8em; font-size: 9.5pt; max-width: 100%; }
table.kv { width: 100%; table-layout: fixed; } table.kv td:first-child, table.kv th:first-child { width: 55%; }
th, td { border: 1px solid #bbb; padding: .15em .45em; text-align: left; vertical-align: top; overflow-wrap: anywhere; }
td.num { text-align: right; font-variant-numeric: tabular-nums; }
th { overflow-wrap: normal; } table.lines { font-size: 8pt; } table.lines td, table.lines th { padding: .1em .3em; }
thead { display: table-header-group; }
tr, .figure, .map { break-inside: avoid; page-break-inside: avoid; }
code, .hash { font: 8.5pt "DejaVu Sans Mono", monospace; word-break: break-all; }
.figure svg, .map svg { width: 100%; height: auto; display: block; }
.meta { color: #444; } .warn { color: #8a4b00; } .ok { color: #1d6b2a; }
.job { break-before: page; page-break-before: always; }
.job:first-of-type { break-before: auto; page-break-before: auto; }
@page { size: A4; margin: 14mm 12mm; }
@media print { body { margin: 0; max-width: none; padding: 0; font-size: 9.5pt; }
  a { color: inherit; text-decoration: none; } }
"""


@dataclass
class ReportJob:
    """What a report needs of one job (no database in here)."""

    id: int
    pipeline: str
    status: str
    summary: dict
    tables: Tables
    logs: list[dict] = field(default_factory=list)  #: [{"id", "name", "sha256", "survey_date"}]
    finished_at: str | None = None
    project: str | None = None


def esc(x) -> str:
    """``x`` as text escaped for HTML (quotes included)."""
    return html.escape(str(x), quote=True)


#: units written against the number (12.5°, 3.2″), as angles are
SYMBOL_UNITS = ("°", "′", "″")


def _with_unit(s: str, unit: str) -> str:
    """A number's text with its unit: after a space, a degree/minute/second sign against it."""
    return s + ("" if not unit else unit if unit in SYMBOL_UNITS else f" {unit}")


def fmt(v, unit: str = "") -> str:
    """A value as a person reads it, with its unit; radians also in arcseconds."""
    if v is None:
        return "–"
    if isinstance(v, bool):
        return "yes" if v else "no"
    if isinstance(v, int):
        return _with_unit(f"{v}", unit)
    if isinstance(v, float):
        if not math.isfinite(v):
            return "–"
        a = abs(v)
        if a and (a < 1e-3 or a >= 1e7):
            s = f"{v:.4g}"
        else:  # four significant digits, never fewer than the integer part
            s = f"{v:.{max(0, 3 - math.floor(math.log10(a))) if a else 0}f}"
        if unit == "rad":
            return f"{s} rad ({v * 180 / math.pi * 3600:.2f}″)"
        return _with_unit(s, unit)
    if isinstance(v, (list, tuple)) and all(isinstance(x, (int, float)) for x in v):
        return _with_unit(", ".join(fmt(x) for x in v), unit)
    return str(v)


def summary_value(d: dict, path: str):
    """The value at a dotted ``path`` of a summary (``noise_floor.total_mgal``); None where absent."""
    for p in path.split("."):
        if not isinstance(d, dict) or p not in d:
            return None
        d = d[p]
    return d


def _table(head: list[str], rows: list[list[str]], num_cols=(), cls: str = "") -> str:
    h = "".join(f"<th>{esc(c)}</th>" for c in head)
    body = "".join(
        "<tr>"
        + "".join(f'<td class="num">{c}</td>' if i in num_cols else f"<td>{c}</td>" for i, c in enumerate(r))
        + "</tr>"
        for r in rows
    )
    c = f' class="{cls}"' if cls else ""
    return f"<table{c}><thead><tr>{h}</tr></thead><tbody>{body}</tbody></table>"


# --- figures as SVG ----------------------------------------------------------------------------------


def _plain(text: str) -> str:
    """Plotly title markup to plain text lines (matplotlib draws newlines)."""
    return re.sub(r"<[^>]+>", "", (text or "").replace("<br>", "\n"))


def _svg(fig) -> str:
    from matplotlib.backends.backend_svg import FigureCanvasSVG

    buf = io.StringIO()
    FigureCanvasSVG(fig).print_svg(buf)
    s = buf.getvalue()
    return s[s.index("<svg") :]


def _new_figure(w_in=7.2, h_in=3.4):
    import matplotlib

    matplotlib.rcParams.update({"svg.fonttype": "none", "font.size": 8})
    from matplotlib.figure import Figure

    return Figure(figsize=(w_in, h_in), layout="constrained")


def figure_svg(fig: dict) -> str:
    """A view's figure (Plotly JSON: scatter traces, lines broken at ``None``) as a static SVG."""
    lay = fig.get("layout", {})
    title = _plain(lay.get("title", {}).get("text", ""))
    f = _new_figure(7.2, 3.2 + 0.18 * title.count("\n"))
    ax = f.add_subplot()
    dashes = {"dot": ":", "dash": "--", "dashdot": "-."}
    for tr in fig.get("data", []):
        x = np.array([np.nan if p is None else p for p in tr.get("x", [])], float)
        y = np.array([np.nan if p is None else p for p in tr.get("y", [])], float)
        line = tr.get("line") or {}
        kw = {"label": tr.get("name")}
        if line.get("color"):
            kw["color"] = line["color"]
        if tr.get("mode") == "markers":
            ax.plot(x, y, ".", markersize=2.5, **kw)
        else:
            ax.plot(x, y, dashes.get(line.get("dash"), "-"), linewidth=min(line.get("width", 1.2), 2.5), **kw)
    ax.set_xlabel(lay.get("xaxis", {}).get("title", {}).get("text", ""))
    ax.set_ylabel(lay.get("yaxis", {}).get("title", {}).get("text", ""))
    if lay.get("yaxis", {}).get("scaleanchor"):
        ax.set_aspect("equal", adjustable="datalim")
    ax.set_title(title, fontsize=8.5)
    ax.grid(True, linewidth=0.3, color="#ccc")
    if len(fig.get("data", [])) > 1:
        ax.legend(fontsize=6.5, loc="upper left", bbox_to_anchor=(1.01, 1.0), frameon=False)
    return _svg(f)


def nice_length(span_m: float) -> float:
    """A round scale-bar length (1, 2 or 5 × 10^k m) near a fifth of ``span_m``."""
    target = max(span_m / 5.0, 1e-3)
    k = 10 ** math.floor(math.log10(target))
    return min((c * k for c in (1, 2, 5, 10)), key=lambda c: abs(c - target))


@dataclass
class MapLayer:
    """One thing on a map: a track (``e``, ``n`` in metres), optionally coloured by ``value``."""

    name: str
    lat_deg: np.ndarray
    lon_deg: np.ndarray
    value: np.ndarray | None = None
    value_label: str = ""
    kind: str = "line"  #: "line" (a track) or "points" (e.g. GNSS fixes)


def map_origin(layers: list[MapLayer]) -> tuple[float, float]:
    """The map's origin (rad): the first finite position of the first layer."""
    for ly in layers:
        ok = np.isfinite(ly.lat_deg) & np.isfinite(ly.lon_deg)
        if ok.any():
            k = int(np.flatnonzero(ok)[0])
            return ly.lat_deg[k] * RAD_PER_DEG, ly.lon_deg[k] * RAD_PER_DEG
    raise ValueError("no position to map")


def map_svg(layers: list[MapLayer], title: str) -> str:
    """Tracks, survey lines and values on a plain projected map: east/north metres from the origin
    (local tangent plane; grid north is true north at the origin), equal scales, a scale bar and a
    north arrow."""
    lat0, lon0 = map_origin(layers)
    f = _new_figure(7.2, 5.0)
    ax = f.add_subplot()
    allx, ally, sc = [], [], None
    for ly in sorted(layers, key=lambda x: x.kind != "points"):  # fixes under the tracks
        step = max(1, len(ly.lat_deg) // MAP_POINTS)  # evenly thinned, in the data's order
        lat, lon = ly.lat_deg[::step], ly.lon_deg[::step]
        e, n = local_metres(lat0, lon0, lat * RAD_PER_DEG, lon * RAD_PER_DEG)
        allx.append(e[np.isfinite(e)])
        ally.append(n[np.isfinite(n)])
        if ly.value is not None:
            val = ly.value[::step]
            ok = np.isfinite(e) & np.isfinite(val)
            sc = ax.scatter(e[ok], n[ok], c=val[ok], s=4, cmap="viridis", label=ly.name, linewidths=0, zorder=3)
        elif ly.kind == "points":
            ax.plot(e, n, ".", markersize=1.5, color="#999", label=ly.name)
        else:
            ax.plot(e, n, "-", linewidth=1.0, label=ly.name)
    x, y = np.concatenate(allx), np.concatenate(ally)
    span = max(np.ptp(x), np.ptp(y), 1.0)
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("east (m) from the origin")
    ax.set_ylabel("north (m) from the origin")
    ax.grid(True, linewidth=0.3, color="#ddd")
    if sc is not None:
        cb = f.colorbar(sc, ax=ax, shrink=0.8)
        cb.set_label(next(ly.value_label for ly in layers if ly.value is not None))
    # scale bar (bottom left) and north arrow (top right), in data coordinates
    bar = nice_length(span)
    x0, y0 = x.min(), y.min() - 0.08 * span
    ax.plot([x0, x0 + bar], [y0, y0], "k-", linewidth=3, solid_capstyle="butt")
    ax.text(x0 + bar / 2, y0 + 0.02 * span, f"{bar:g} m" if bar < 1000 else f"{bar / 1000:g} km", ha="center")
    # north arrow: +y is north on an equal-scale east/north map
    ax.annotate(
        "",
        xy=(0.95, 0.93),
        xytext=(0.95, 0.78),
        xycoords="axes fraction",
        arrowprops={"arrowstyle": "-|>", "color": "k", "linewidth": 1.5},
    )
    ax.text(0.95, 0.935, "N", transform=ax.transAxes, ha="center", va="bottom", fontsize=10, fontweight="bold")
    ax.set_title(
        f"{title}\norigin {lat0 / RAD_PER_DEG:.6f}° N, {lon0 / RAD_PER_DEG:.6f}° E (WGS-84)\n"
        "east/north metres in the local tangent plane (north = true north at the origin)",
        fontsize=8,
    )
    if len(layers) > 1 or sc is None:
        ax.legend(fontsize=6.5, loc="lower center", bbox_to_anchor=(0.5, 1.16), frameon=False, ncols=3, markerscale=4)
    return _svg(f)


def _try_csv(t: Tables, name: str) -> dict | None:
    try:
        return t.csv(name)
    except MissingResult:
        return None


def map_layers(job: ReportJob) -> list[MapLayer]:
    """What a job puts on a map: its tables with positions (tracks; gravity values along the survey
    lines) and the log's GNSS fixes."""
    out = []
    t = job.tables
    for name, label in (("trajectory.csv", "trajectory"), ("calibration_track.csv", "calibration drive")):
        if (d := _try_csv(t, name)) is not None:
            out.append(MapLayer(label, d["lat_deg"], d["lon_deg"]))
    if job.pipeline == "gravity" and (g := _try_csv(t, "gravity.csv")) is not None and "lat_deg" in g:
        on = g["line"] != ""
        out.append(
            MapLayer(
                "gravity disturbance on the survey lines",
                g["lat_deg"][on],
                g["lon_deg"][on],
                value=g["dg_mgal"][on],
                value_label="δg (mGal)",
            )
        )
    if job.pipeline == "dov" and (d := _try_csv(t, "dov.csv")) is not None and "lat_deg" in d:
        out.append(MapLayer("track", d["lat_deg"], d["lon_deg"]))
    gn = t.log_array("gnss")
    if gn is not None and len(gn.get("lat_deg", [])):
        ok = np.isfinite(gn["lat_deg"])
        out.append(MapLayer("GNSS fixes", gn["lat_deg"][ok], gn["lon_deg"][ok], kind="points" if out else "line"))
    return out


# --- the report --------------------------------------------------------------------------------------


def _headlines(job: ReportJob) -> str:
    s = job.summary
    rows = []
    for key, lab in HEADLINES.get(job.pipeline, []):
        v = summary_value(s, key)
        if v is None:
            continue
        unit = label_unit(key.rsplit(".", 1)[-1])[1]
        rows.append([esc(lab), esc(fmt(v, unit))])
    if not rows:  # a pipeline without a chosen list: its top-level figures
        for k, v in s.items():
            if isinstance(v, (int, float)) and not isinstance(v, bool) and k not in ("elapsed_s",):
                lab, unit = label_unit(k)
                rows.append([esc(lab), esc(fmt(v, unit))])
    return _table(["figure", "value"], rows, num_cols=(1,), cls="kv") if rows else "<p>No figures.</p>"


def _lines_table(s: dict) -> str:
    lines = s.get("lines")
    if not isinstance(lines, list) or not lines or not isinstance(lines[0], dict):
        return ""
    keys = [k for k in lines[0] if k != "name" and not isinstance(lines[0][k], (dict, list))]
    head = ["line"] + [f"{lab} ({u})" if u else lab for lab, u in (label_unit(k) for k in keys)]
    rows = [[esc(ln.get("name", ""))] + [esc(fmt(ln.get(k))) for k in keys] for ln in lines]
    return "<h3>Per line</h3>" + _table(head, rows, num_cols=tuple(range(1, len(head))), cls="lines")


def _all_figures(s: dict) -> str:
    skip = {"inputs", "parameters", "warnings", "lines", "pipeline", "format_version", "software_version"}
    skip |= {"started_at", "elapsed_s"}
    rows = []

    def walk(prefix, d, depth):
        for k, v in d.items():
            if prefix == "" and k in skip:
                continue
            if isinstance(v, dict) and depth < 2:
                walk(f"{prefix}{k}.", v, depth + 1)
            elif isinstance(v, (int, float, str, bool)) or (
                isinstance(v, list) and v and all(isinstance(x, (int, float)) for x in v) and len(v) <= 6
            ):
                lab, unit = label_unit(k)
                rows.append([esc(prefix.replace(".", " › ").replace("_", " ") + lab), esc(fmt(v, unit))])

    walk("", s, 0)
    return _table(["quantity", "value"], rows, num_cols=(1,), cls="kv") if rows else ""


def _provenance(job: ReportJob) -> str:
    s = job.summary
    logs = _table(
        ["log", "name", "survey date", "bundle SHA-256"],
        [
            [
                esc(lg.get("id")),
                esc(lg.get("name")),
                esc(lg.get("survey_date", "")),
                f"<code>{esc(lg.get('sha256', ''))}</code>",
            ]
            for lg in job.logs
        ],
    )
    inputs = _table(
        ["bundle", "file", "SHA-256"],
        [
            [esc(i.get("bundle", "")), esc(i.get("file", "")), f"<code>{esc(i.get('sha256', ''))}</code>"]
            for i in s.get("inputs", [])
        ],
    )
    params = _table(
        ["parameter", "value"],
        [[f"<code>{esc(k)}</code>", esc(fmt(v))] for k, v in sorted((s.get("parameters") or {}).items())],
        cls="kv",
    )
    meta = _table(
        ["", ""],
        [
            ["pipeline", esc(job.pipeline)],
            ["job", esc(job.id)],
            ["software version (run)", esc(s.get("software_version", "–"))],
            ["bundle format", esc(s.get("format_version", "–"))],
            ["run started (UTC)", esc(s.get("started_at", "–"))],
            ["run finished (UTC)", esc(job.finished_at or "–")],
            ["processing time", esc(fmt(s.get("elapsed_s"), "s"))],
        ],
        cls="kv",
    )
    return (
        f'<section class="provenance" id="provenance-{job.id}"><h3>Provenance</h3>{meta}'
        f"<h3>Logs</h3>{logs}<h3>Input files</h3>{inputs}<h3>Parameters (every value used)</h3>{params}</section>"
    )


def job_section(job: ReportJob, heading: str = "h2") -> str:
    """One job's part of a report: headline figures, per-line table, warnings, map, figures, all
    summary figures, provenance."""
    s = job.summary
    warn = s.get("warnings") or []
    out = [
        f'<section class="job" id="job-{job.id}"><{heading}>Job {job.id}: {esc(job.pipeline)}'
        f" — {esc(', '.join(lg.get('name', '') for lg in job.logs))}</{heading}>",
        "<h3>Headline figures</h3>",
        _headlines(job),
        _lines_table(s),
        "<h3>Warnings</h3>",
        ("<ul>" + "".join(f'<li class="warn">{esc(w)}</li>' for w in warn) + "</ul>")
        if warn
        else '<p class="ok">none</p>',
    ]
    layers = map_layers(job)
    if layers:
        out.append(f'<div class="map" id="map-{job.id}">{map_svg(layers, "Map of job " + str(job.id))}</div>')
    for v in views_of(job.pipeline, s):
        try:
            fig = build_view(job.tables, job.pipeline, s, v.name, None, None, REPORT_POINTS)
        except MissingResult:
            continue
        if (fig["layout"].get("meta") or {}).get("map"):
            continue  # the report draws its own map (above) with scale bar and north arrow
        out.append(f'<div class="figure" id="figure-{job.id}-{esc(v.name)}">{figure_svg(fig)}</div>')
    out += ["<h3>All figures of the summary</h3>", _all_figures(s), _provenance(job), "</section>"]
    return "\n".join(out)


def _page(title: str, body: str, generated_by: str, generated_at: dt.datetime) -> str:
    return (
        "<!DOCTYPE html>\n"
        f'<html lang="en"><head><meta charset="utf-8"><title>{esc(title)}</title>'
        '<meta name="viewport" content="width=device-width, initial-scale=1">'
        f'<meta name="generator" content="{esc(generated_by)}"><style>{CSS}</style></head><body>'
        f"<header><h1>{esc(title)}</h1>"
        f'<p class="meta">Report generated {esc(generated_at.strftime("%Y-%m-%d %H:%M:%S UTC"))} by '
        f"{esc(generated_by)}. Heights are ellipsoidal (WGS-84) at the IMU centre; 1σ values unless "
        "stated; figures and tables come from the job's stored results.</p></header>"
        f"{body}</body></html>\n"
    )


def job_report(job: ReportJob, generated_by: str, generated_at: dt.datetime) -> str:
    """The self-contained HTML report of one job."""
    title = f"Survey report: {job.pipeline} job {job.id}" + (f" ({job.project})" if job.project else "")
    return _page(title, job_section(job), generated_by, generated_at)


def project_report(
    name: str, jobs: list[ReportJob], logs: list[dict], generated_by: str, generated_at: dt.datetime
) -> str:
    """The self-contained HTML report of a project: its logs, an overview of its finished jobs with
    their headline figure, a map of every log, then each job's section."""
    log_rows = [
        [
            esc(lg["id"]),
            esc(lg["name"]),
            esc(lg.get("survey_date", "")),
            esc(fmt(lg.get("duration_s"), "s")),
            f"<code>{esc(lg.get('sha256', ''))}</code>",
        ]
        for lg in logs
    ]
    overview = []
    for j in jobs:
        first = next(
            ((k, lab) for k, lab in HEADLINES.get(j.pipeline, []) if summary_value(j.summary, k) is not None), None
        )
        head = (
            f"{first[1]}: {fmt(summary_value(j.summary, first[0]), label_unit(first[0].rsplit('.', 1)[-1])[1])}"
            if first
            else ""
        )
        overview.append(
            [
                f'<a href="#job-{j.id}">{j.id}</a>',
                esc(j.pipeline),
                esc(", ".join(lg["name"] for lg in j.logs)),
                esc(head),
                esc(len(j.summary.get("warnings") or [])),
            ]
        )
    body = [
        "<h2>Logs</h2>",
        _table(["log", "name", "survey date", "duration", "bundle SHA-256"], log_rows) if logs else "<p>No logs.</p>",
        "<h2>Finished jobs</h2>",
        _table(["job", "pipeline", "logs", "headline figure", "warnings"], overview)
        if jobs
        else "<p>No finished jobs.</p>",
    ]
    layers = []
    for j in jobs:
        layers += [ly for ly in map_layers(j) if ly.kind == "line" or ly.value is not None]
    if layers:
        body.append(f'<div class="map" id="map-project">{map_svg(layers, "Map of the project " + name)}</div>')
    body += [job_section(j) for j in jobs]
    return _page(f"Survey report: project {name}", "\n".join(body), generated_by, generated_at)


__all__ = ["ReportJob", "job_report", "project_report", "figure_svg", "map_svg", "VIEWS"]
