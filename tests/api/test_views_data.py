"""Every view's figure checked against the tables it draws, on tables built to trip a view up.

The tables have a time gap, a stretch of missing values, paths that are not functions of x and more
rows than a trace may carry, so thinning is at work. For every trace the test maps each plotted point
back to its row (exact values) and checks: the rows come in the data's order; consecutive plotted
points of one segment have no missing row and no gap of the data's own step between them (so no
segment is longer than the data's steps allow and there is a break at every gap); the plotted values
lie inside the data's; every axis title ends with a known unit in parentheses; every title line fits.
A view the test has no branch for in :func:`_rows_of_trace` is checked on the columns of its files it draws.
"""

import re

import numpy as np
import pytest

from ldvsurvey.api import views as V
from ldvsurvey.pipelines.labels import SUFFIX_UNIT
from tests.api.helpers import SUMMARIES, path, summary_of, tables

N_POINTS = 400  #: points requested per trace (fewer than the rows: thinning is exercised)


def _rows_of_trace(v, name, tabs, arrays, tr=None):
    """The (x, y, order) arrays a trace of view ``v`` is drawn from, by the trace's name; None for
    a drawn reference (a noise-floor band). A view without a branch here: :func:`_columns_of_trace`
    on the drawn trace ``tr``."""
    h, a, c, g, d, dm = (
        tabs[k] for k in ("height.csv", "attitude.csv", "coincidence.csv", "gravity.csv", "dov.csv", "damping.csv")
    )
    if "floor" in name:
        return None
    if v in ("trajectory", "calibration_track"):
        tr = tabs["trajectory.csv"]
        lat0, lon0 = np.radians(tr["lat_deg"][0]), np.radians(tr["lon_deg"][0])
        if name == "solution":
            _, e, n = path()
            return e, n, tr["t_s"]
        gn = arrays["gnss"]
        tt, e, n = path()
        del lat0, lon0
        q = int(re.search(r"GNSS, (\d)", name).group(1))
        k = gn["fix"] == q
        return (e[::10] + 0.5)[k], (n[::10] - 0.5)[k], gn["t_s"][k]
    if v == "gravity_map":
        if name.startswith("GNSS"):
            return _rows_of_trace("trajectory", name, tabs, arrays)
        on = g["line"] != ""
        return 0.6 * g["distance_m"][on], 0.8 * g["distance_m"][on], g["t_s"][on]
    if v == "gravity_network_map":
        if name.startswith("base ties"):
            return np.array([0.6 * 5000.0]), np.array([0.8 * 5000.0]), np.array([0.0])
        on = g["line"] != ""
        return 0.6 * g["distance_m"][on], 0.8 * g["distance_m"][on], g["t_s"][on]
    if v == "height":
        col = {"LDV height (tilt compensated)": "h_m", "LDV height (uncompensated)": "h_uncompensated_m"}
        return h["t_s"], h[col.get(name, "h_gnss_m")], h["t_s"]
    if v == "height_error":
        q = int(re.search(r"against (\d)", name).group(1))
        col = "h_m" if name.startswith("tilt compensated") else "h_uncompensated_m"
        return h["t_s"], np.where(h["fix_quality"] == q, h[col] - h["h_gnss_m"], np.nan), h["t_s"]
    if v == "attitude":
        col = {"pitch raw": "pitch_raw_deg", "pitch compensated": "pitch_deg", "roll raw": "roll_raw_deg"}
        return a["t_s"], a[col.get(name, "roll_deg")], a["t_s"]
    if v in ("gravity_lines", "gravity_residuals"):
        line = "L1" if name == "mean line" else name
        k = c["line"] == line
        col = "mean_mgal" if name == "mean line" else ("residual_mgal" if v == "gravity_residuals" else "dg_mgal")
        return c["distance_m"][k], c[col][k], c["distance_m"][k]
    if v == "gravity_compare_gnss":
        line = name.split(":")[0]
        k = g["line"] == line
        other = "dg_sins_gnss_mgal" if "SINS/GNSS" in name else "dg_gnss_aided_mgal"
        return g["distance_m"][k], g["dg_mgal"][k] - g[other][k], g["t_s"][k]
    if v == "dov_deflection":
        return d["t_s"], d["xi_arcsec" if name == "ξ" else "eta_arcsec"], d["t_s"]
    if v == "dov_error":
        comp, mth = name.split(", ")
        return d["t_s"], d[f"d{comp[0]}_{mth}_m"], d["t_s"]
    if v == "damping":
        mth = name.rsplit(",", 1)[0].replace(" ", "_")
        return dm["t_s"], dm[f"{mth}_north_error_m"], dm["t_s"]
    return _columns_of_trace(v, tr, tabs)


def _columns_of_trace(v, tr, tabs, tol=1e-6):
    """A view without a branch in _rows_of_trace: each of its traces must draw one column of one of its
    declared files against another, row by row (then it is checked like any other, in the file's time
    order, ``t_s``, or else x's); a trace drawn from anything computed needs a branch there."""
    files = V.VIEWS[v].files
    missing = [f for f in files if f not in tabs]
    assert not missing, f"view '{v}' reads {missing}: add those tables to tables() in tests/api/helpers.py"
    px = np.array([p for p in (tr or {}).get("x", []) if p is not None], float)
    py = np.array([p for p in (tr or {}).get("y", []) if p is not None], float)

    def inside(col, pts):  # every plotted value is a value of the column
        s = np.sort(col[np.isfinite(col)])
        if len(s) < 2 or not len(pts):
            return False
        k = np.clip(np.searchsorted(s, pts), 1, len(s) - 1)
        near = np.minimum(np.abs(s[k - 1] - pts), np.abs(s[k] - pts))
        return bool(np.all(near <= tol * np.maximum(1, np.abs(pts))))

    for f in files:
        cols = {c: np.asarray(a, float) for c, a in tabs[f].items() if a.dtype != object}
        for cx in (c for c in cols if inside(cols[c], px)):
            for cy in (c for c in cols if c != cx and inside(cols[c], py)):
                return cols[cx], cols[cy], cols.get("t_s", cols[cx])
    name = (tr or {}).get("name")
    raise AssertionError(
        f"trace '{name}' of view '{v}' is not one column of {list(files)} against another: add a branch for"
        f" view '{v}' to _rows_of_trace in tests/api/test_views_data.py returning the (x, y, order) arrays"
        " the trace draws, from the tables of tests/api/helpers.py"
    )


def check_trace(tr, x, y, order, tol=1e-6):
    """The figure-against-data checks of one trace (see the module's docstring)."""
    px = [np.nan if p is None else p for p in tr["x"]]
    py = [np.nan if p is None else p for p in tr["y"]]
    px, py = np.array(px, float), np.array(py, float)
    assert len(px) == len(py)
    brk = np.isnan(px)
    assert not np.any(np.isnan(py) != brk), "a break in x only or y only"
    assert len(px) - brk.sum() <= 2 * N_POINTS + 4, "not thinned"
    x, y = np.asarray(x, float), np.asarray(y, float)
    ok = np.isfinite(x) & np.isfinite(y)
    # plotted values inside the data's (the axis ranges Plotly derives from them then are too)
    assert np.nanmin(px) >= x[ok].min() - tol and np.nanmax(px) <= x[ok].max() + tol
    assert np.nanmin(py) >= y[ok].min() - tol and np.nanmax(py) <= y[ok].max() + tol
    # each plotted point's row
    rows = []
    for xi, yi in zip(px[~brk], py[~brk]):
        k = np.flatnonzero(ok & (np.abs(x - xi) <= tol * max(1, abs(xi))) & (np.abs(y - yi) <= tol * max(1, abs(yi))))
        assert len(k), f"({xi}, {yi}) is not in the data"
        rows.append(k)
    # data order: a strictly increasing choice of rows exists (greedy smallest above the previous)
    idx, last = [], -1
    for k in rows:
        k = k[k > last]
        assert len(k), f"{tr['name']}: point {len(idx)} comes before the previous one in the data"
        last = int(k[0])
        idx.append(last)
    idx = np.array(idx)
    if tr.get("mode", "lines") == "markers":
        return
    # segments: no missing row and no gap of the data's own step between consecutive points
    o = np.asarray(order, float)
    step = np.abs(np.diff(o))
    med = np.median(step[np.isfinite(step) & (step > 0)])
    seg_id = np.cumsum(brk)[~brk]
    for i in range(len(idx) - 1):
        if seg_id[i] != seg_id[i + 1]:
            continue
        a, b = idx[i], idx[i + 1]
        assert ok[a : b + 1].all(), f"{tr['name']}: a line joins rows {a}-{b} across missing values"
        assert (step[a:b] <= 5 * med).all(), f"{tr['name']}: a line joins rows {a}-{b} across a gap"
        # and so no segment is longer than the path the data itself takes between its ends
        chord = np.hypot(x[b] - x[a], y[b] - y[a])
        path = np.hypot(np.diff(x[a : b + 1]), np.diff(y[a : b + 1])).sum()
        assert chord <= path + tol


#: the units an axis title may end with: every unit of the one table (pipelines/labels.py), and the
#: angle units spelt out as the views write them
KNOWN_UNITS = set(SUFFIX_UNIT.values()) | {"deg", "arcmin", "arcsec"}


def axis_unit(text):
    """The unit of an axis title: its trailing parenthesised group (nested parentheses kept), without
    a qualifier after a comma or ' of day' ('h (m, ellipsoidal)' → 'm'); None when it has none."""
    if not text.endswith(")"):
        return None
    depth = 0
    for i in range(len(text) - 1, -1, -1):
        depth += {")": 1, "(": -1}.get(text[i], 0)
        if depth == 0:
            unit = text[i + 1 : -1]
            return re.sub(r"( of day|, [^()]*)$", "", unit) if i > 0 and text[i - 1] == " " else None
    return None


def test_axis_units_are_read_as_the_views_write_them():
    assert axis_unit("h (m, ellipsoidal)") == "m" and axis_unit("t (s of day)") == "s"
    assert axis_unit("k (rad/(m/s²))") == "rad/(m/s²)" and axis_unit("v (m/s)") == "m/s"
    assert axis_unit("angle") is None and axis_unit("(m)") is None and axis_unit("v (m/s") is None


def check_layout(fig):
    lay = fig["layout"]
    for ax, spec in lay.items():
        if re.fullmatch(r"[xy]axis\d*", ax) and not spec.get("matches"):
            text = spec["title"]["text"]
            assert axis_unit(text) in KNOWN_UNITS, (
                f"{ax} title '{text}' does not end with a known unit in parentheses; a new unit goes into"
                " SUFFIX_UNIT of backend/ldvsurvey/pipelines/labels.py"
            )
    title = lay["title"]["text"]
    for line in title.split("<br>"):
        assert len(re.sub(r"<[^>]+>", "", line)) <= V.TITLE_LINE_CHARS, f"title line too long: {line!r}"
    assert lay["margin"]["t"] >= 20 * (title.count("<br>") + 1), "the title's lines do not fit the top margin"


@pytest.fixture(scope="module")
def data():
    return tables()


@pytest.mark.parametrize("name", list(V.VIEWS))
def test_every_view_against_its_data(name, data):
    tabs, arrays = data
    v = V.VIEWS[name]
    missing = [f for f in v.files if f not in tabs]
    assert not missing, f"view '{name}' reads {missing}: add those tables to tables() in tests/api/helpers.py"
    fig = V.build_view(V.DictTables(tabs, arrays), v.pipeline, summary_of(name), name, None, None, N_POINTS)
    assert fig["data"], "no trace"
    check_layout(fig)
    for tr in fig["data"]:
        src = _rows_of_trace(name, tr["name"], tabs, arrays, tr)
        if src is not None:
            check_trace(tr, *src)


@pytest.mark.parametrize("name", ["height", "attitude", "gravity_lines", "trajectory"])
def test_a_zoomed_view_stays_in_its_range_and_order(name, data):
    tabs, arrays = data
    v = V.VIEWS[name]
    x0, x1 = (30050.0, 30200.0) if v.pipeline in ("height", "tilt") else (-500.0, 800.0)
    fig = V.build_view(V.DictTables(tabs, arrays), v.pipeline, summary_of(name), name, x0, x1, N_POINTS)
    for tr in fig["data"]:
        src = _rows_of_trace(name, tr["name"], tabs, arrays, tr)
        if src is None or tr.get("mode") == "markers":
            continue
        xs = np.array([p for p in tr["x"] if p is not None])
        assert xs.min() >= x0 and xs.max() <= x1
        x, y, o = src
        inside = np.where((np.asarray(x) >= x0) & (np.asarray(x) <= x1), y, np.nan)
        check_trace(tr, x, inside, o)


def test_the_trajectory_is_the_path_driven(data):
    """The defect of issue 26: points sorted by east made a path the data never drove."""
    tabs, arrays = data
    fig = V.build_view(V.DictTables(tabs, arrays), "navigate", {}, "trajectory", None, None, N_POINTS)
    sol = fig["data"][0]
    x = np.array([np.nan if p is None else p for p in sol["x"]])
    y = np.array([np.nan if p is None else p for p in sol["y"]])
    jumps = np.hypot(np.diff(x), np.diff(y))
    # at most ~4.5 m per row and 3700 rows thinned to about 400 points: a drawn step spans the path of
    # a few dozen rows (check_trace bounds each by the path itself); sorted by east, steps ran to km
    _, e, n = path()
    assert np.nanmax(jumps) < 0.05 * max(np.ptp(e), np.ptp(n))
    assert np.isnan(x).sum() == 1  # one break: the gap
    # equal axis scales without stretching the ranges past the data
    lay = fig["layout"]
    assert lay["yaxis"]["scaleanchor"] == "x" and lay["xaxis"]["constrain"] == lay["yaxis"]["constrain"] == "domain"


def test_the_height_error_names_the_fixes_it_is_judged_against(data):
    tabs, arrays = data
    s = SUMMARIES["height"]
    fig = V.build_view(V.DictTables(tabs, arrays), "height", s, "height_error", None, None, N_POINTS)
    title = fig["layout"]["title"]["text"]
    rtk, both = title.split("<br>")[1:3]
    assert "RTK fixed" in rtk and "-0.130 m" in rtk and "n = 140" in rtk and "DGPS" not in rtk
    assert "RTK fixed + DGPS" in both and "-1.780 m" in both and "n = 270" in both
    assert {tr["name"] for tr in fig["data"]} == {
        f"{w}, against {q}" for w in ("tilt compensated", "uncompensated") for q in ("4 RTK fixed", "2 DGPS")
    }


def test_one_list_of_fix_names(client):
    """The dashboard takes the fix names from the API; the JavaScript holds no copy."""
    from pathlib import Path

    from ldvsurvey.io.nmea import FIX_QUALITY_NAMES

    got = client.get("/api/names").json()["fix_quality"]
    assert got == {str(k): v for k, v in FIX_QUALITY_NAMES.items()} and got["4"] == "4 RTK fixed"
    js = "".join(p.read_text() for p in (Path(V.__file__).parents[3] / "frontend" / "js").glob("*.js"))
    assert "RTK fixed" not in js and "/api/names" in js


def test_views_are_pure_functions_of_their_tables():
    """No database, no HTTP in the view module: what it needs comes through its table reader."""
    import ast
    from pathlib import Path

    tree = ast.parse(Path(V.__file__).read_text())
    mods = {n.module for n in ast.walk(tree) if isinstance(n, ast.ImportFrom)}
    mods |= {a.name for n in ast.walk(tree) if isinstance(n, ast.Import) for a in n.names}
    assert not {m for m in mods if m and m.split(".")[0] in ("fastapi", "sqlalchemy", "starlette")}
    assert not any(m and m.startswith("ldvsurvey.store") for m in mods)
    assert not hasattr(V, "_gravity_view")
    with pytest.raises(V.MissingResult):
        V.build_view(V.DictTables({}), "height", {}, "height", None, None, 100)
    with pytest.raises(V.UnknownView):
        V.build_view(V.DictTables({}), "height", {}, "attitude", None, None, 100)


@pytest.mark.parametrize("name", ["trajectory", "gravity_map", "gravity_network_map"])
def test_maps_have_a_true_scale_bar_a_north_arrow_and_their_positions(name, data):
    tabs, arrays = data
    v = V.VIEWS[name]
    fig = V.build_view(V.DictTables(tabs, arrays), v.pipeline, summary_of(name), name, None, None, N_POINTS)
    lay = fig["layout"]
    # equal scales on east/north metres, north up
    assert lay["yaxis"]["scaleanchor"] == "x" and lay["yaxis"]["scaleratio"] == 1
    xs = [p for t in fig["data"] for p in t["x"] if p is not None]
    ys = [p for t in fig["data"] for p in t["y"] if p is not None]
    span = max(np.ptp(xs), np.ptp(ys))
    (bar,) = [sh for sh in lay["shapes"] if sh["type"] == "line"]
    length = bar["x1"] - bar["x0"]
    assert bar["y0"] == bar["y1"] and span / 10 <= length <= span / 2  # a fifth of the extent, rounded
    assert length / 10 ** np.floor(np.log10(length)) in (1, 2, 5)
    label = next(a["text"] for a in lay["annotations"] if a.get("name") == "scale bar")
    assert label == (f"{length:g} m" if length < 1000 else f"{length / 1000:g} km")
    arrow = next(a for a in lay["annotations"] if a.get("name") == "north arrow")
    assert arrow["ax"] == 0 and arrow["ay"] > 0  # the tail straight below the head: pointing up (north)
    assert any(a["text"] == "<b>N</b>" for a in lay["annotations"])
    # every point also carries its latitude/longitude (for a basemap), equal to the data's
    tr = tabs["trajectory.csv"] if name == "trajectory" else tabs["gravity.csv"]
    for t in fig["data"]:
        if t["name"].startswith("GNSS"):
            src_lat, src_lon = arrays["gnss"]["lat_deg"], arrays["gnss"]["lon_deg"]
        elif t["name"].startswith("base ties"):
            src_lat, src_lon = tabs["network_residuals.csv"]["lat_deg"], tabs["network_residuals.csv"]["lon_deg"]
        else:
            src_lat, src_lon = tr["lat_deg"], tr["lon_deg"]
        for la, lo in zip(t["meta"]["lat"], t["meta"]["lon"]):
            if la is None:
                continue
            assert np.min(np.hypot(src_lat - la, src_lon - lo)) < 1e-8  # deg: under a millimetre


def _register(monkeypatch, name, build, files):
    """A throwaway view of the test's own, registered for one test only."""
    monkeypatch.setattr(V, "VIEWS", dict(V.VIEWS))
    V.view(name, "height", "A view added later", "m/s", files)(build)


def test_a_new_view_on_its_files_columns_needs_no_test_edit(monkeypatch, data):
    """What docs/architecture.md promises of a new view: one that draws columns of a file tables() has,
    titled with any unit of the unit table, is checked without a branch of its own."""

    def speed(v):
        h = v.csv("height.csv")
        return V._fig([v.trace(h["t_s"], h["h_uncompensated_m"], "v")], "Speed", "t (s of day)", "v (m/s)")

    _register(monkeypatch, "test_speed", speed, ("height.csv",))
    test_every_view_against_its_data("test_speed", data)


def test_a_new_view_the_test_cannot_read_says_what_to_add(monkeypatch, data):
    """A trace computed from its columns, or an axis without a known unit, fails naming the edit."""

    def computed(v):
        h = v.csv("height.csv")
        return V._fig([v.trace(h["t_s"], 2 * h["h_uncompensated_m"], "2h")], "Twice", "t (s of day)", "2h (m)")

    _register(monkeypatch, "test_computed", computed, ("height.csv",))
    with pytest.raises(AssertionError, match="add a branch for view 'test_computed' to _rows_of_trace"):
        test_every_view_against_its_data("test_computed", data)

    def unitless(v):
        h = v.csv("height.csv")
        return V._fig([v.trace(h["t_s"], h["h_m"], "h")], "Odd unit", "t (s of day)", "h (furlong)")

    _register(monkeypatch, "test_unitless", unitless, ("height.csv",))
    with pytest.raises(AssertionError, match="a new unit goes into SUFFIX_UNIT"):
        test_every_view_against_its_data("test_unitless", data)

    _register(monkeypatch, "test_no_table", unitless, ("speed.csv",))
    with pytest.raises(AssertionError, match=r"add those tables to tables\(\) in tests/api/helpers.py"):
        test_every_view_against_its_data("test_no_table", data)


def test_the_view_module_loads_without_the_compiled_core():
    """The views and the report project with nav/localframe.py: importing them loads no numba and no filter."""
    import subprocess
    import sys

    heavy = ("numba", "ldvsurvey.nav.filter", "ldvsurvey.pipelines.stages.aids")
    code = (
        "import sys, ldvsurvey.api.views, ldvsurvey.api.report, ldvsurvey.api.headlines;"
        f"print(sorted(m for m in {heavy!r} if m in sys.modules))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[]"
