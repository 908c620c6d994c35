"""Every view's figure checked against the tables it draws, on tables built to trip a view up.

The tables have a time gap, a stretch of missing values, paths that are not functions of x and more
rows than a trace may carry, so thinning is at work. For every trace the test maps each plotted point
back to its row (exact values) and checks: the rows come in the data's order; consecutive plotted
points of one segment have no missing row and no gap of the data's own step between them (so no
segment is longer than the data's steps allow and there is a break at every gap); the plotted values
lie inside the data's; every axis title carries a unit in parentheses; every title line fits.
"""

import re

import numpy as np
import pytest

from ldvsurvey.api import views as V

N_POINTS = 400  #: points requested per trace (fewer than the rows: thinning is exercised)
GAP_T = (1200, 1500)  #: rows removed from every time series: a 30-s gap at 10 Hz
NAN_ROWS = (2000, 2100)  #: a stretch where the values are missing
#: WGS-84 (the track's east/north metres turned into latitude/longitude on the test's own formulas)
A_M, F = 6378137.0, 1 / 298.257223563
LAT0_DEG, LON0_DEG = 48.0, 11.0


def _t(n=3000, rate_hz=10.0):
    keep = np.ones(n, bool)
    keep[GAP_T[0] : GAP_T[1]] = False
    return 30000.0 + np.arange(n)[keep] / rate_hz


def _nan(a):
    a = np.array(a, float)
    a[NAN_ROWS[0] : NAN_ROWS[1]] = np.nan
    return a


def _lat_lon(e_m, n_m):
    """Latitude, longitude (deg) of east/north offsets from (LAT0, LON0), meridian and prime-vertical
    radii of WGS-84 at LAT0 (a small area: the offsets are a few km)."""
    e2 = F * (2 - F)
    s = np.sin(np.radians(LAT0_DEG))
    rn = A_M / np.sqrt(1 - e2 * s * s)
    rm = A_M * (1 - e2) / (1 - e2 * s * s) ** 1.5
    return LAT0_DEG + np.degrees(n_m / rm), LON0_DEG + np.degrees(e_m / (rn * np.cos(np.radians(LAT0_DEG))))


def _path():
    """A figure-of-eight drive sampled at 10 Hz (at most 4.5 m per row), its time and east/north (m)."""
    t = _t(4000)
    s = (t - t[0]) * 10.0
    ph = 2 * np.pi * s / s[-1]
    return t, 2000.0 * np.sin(ph), 1000.0 * np.sin(2 * ph) + 0.2 * s


def tables():
    t = _t()
    rng = np.random.default_rng(7)
    w = np.sin((t - t[0]) / 40.0)
    h_gnss = np.full(len(t), np.nan)
    h_gnss[::10] = 100.0 + w[::10]
    fix = np.where((np.arange(len(t)) // 500) % 2 == 0, 4, 2)
    height = {
        "t_s": t,
        "h_m": _nan(100.0 + w + 0.01 * rng.standard_normal(len(t))),
        "h_uncompensated_m": 100.0 + w + 0.3 * np.cos(t / 7.0),
        "h_gnss_m": h_gnss,
        "fix_quality": fix.astype(float),
    }
    attitude = {"t_s": t}
    for k in ("pitch_raw_deg", "pitch_deg", "roll_raw_deg", "roll_deg"):
        attitude[k] = _nan(rng.standard_normal(len(t)).cumsum() * 0.01)
    tt, e, n = _path()
    lat, lon = _lat_lon(e, n)
    track = {"t_s": tt, "lat_deg": lat, "lon_deg": lon, "h_m": np.full(len(tt), 100.0)}
    g_lat, g_lon = _lat_lon(e[::10] + 0.5, n[::10] - 0.5)
    gnss = {"t_s": tt[::10], "lat_deg": g_lat, "lon_deg": g_lon, "fix": np.where(np.arange(len(g_lat)) < 150, 4, 2)}
    # gravity: two 11-km lines, 10 m apart rows; L2 driven back (distance falls with time); the
    # SINS/GNSS chain missing over 3-6 km; coincidence rows missing 5.0-5.5 km on L1
    grav = {k: [] for k in ("t_s", "line", "distance_m", "dg_mgal", "dg_sins_gnss_mgal", "dg_gnss_aided_mgal")}
    coin = {k: [] for k in ("line", "distance_m", "dg_mgal", "mean_mgal", "residual_mgal")}
    d = np.arange(0.0, 11000.0 + 1e-9, 10.0)
    t0 = 40000.0
    for name, dd in (("L1", d), ("", np.full(60, np.nan)), ("L2", d[::-1])):
        m = len(dd)
        grav["t_s"].append(t0 + np.arange(m))
        grav["line"] += [name] * m
        grav["distance_m"].append(dd)
        g = 10 * np.sin(dd / 900.0) + 0.2 * rng.standard_normal(m)
        grav["dg_mgal"].append(g)
        grav["dg_sins_gnss_mgal"].append(np.where((dd > 3000) & (dd < 6000), np.nan, g + 0.3))
        grav["dg_gnss_aided_mgal"].append(g - 0.1)
        t0 += m + 100.0
    for name in ("L1", "L2"):
        keep = ~((d > 5000) & (d < 5500)) if name == "L1" else np.ones(len(d), bool)
        dd = d[keep]
        mean = 10 * np.sin(dd / 900.0)
        res = 0.2 * rng.standard_normal(len(dd))
        coin["line"] += [name] * len(dd)
        coin["distance_m"].append(dd)
        coin["dg_mgal"].append(mean + res)
        coin["mean_mgal"].append(mean)
        coin["residual_mgal"].append(res)
    grav = {k: (np.array(v, dtype=object) if k == "line" else np.concatenate(v)) for k, v in grav.items()}
    coin = {k: (np.array(v, dtype=object) if k == "line" else np.concatenate(v)) for k, v in coin.items()}
    dov = {"t_s": t, "xi_arcsec": _nan(3 * w), "eta_arcsec": -2 * w}
    for mth in ("direct", "rk4", "theoretical"):
        dov[f"dn_{mth}_m"] = _nan(0.1 * w * (t - t[0]) / 100)
        dov[f"de_{mth}_m"] = 0.05 * w
    damping = {"t_s": t}
    for mth in ("undamped", "conventional", "delayed_state"):
        damping[f"{mth}_north_error_m"] = _nan(np.sin((t - t[0]) / 500.0) * (3 if mth == "undamped" else 1))
    return {
        "height.csv": height,
        "attitude.csv": attitude,
        "trajectory.csv": track,
        "calibration_track.csv": track,
        "gravity.csv": grav,
        "coincidence.csv": coin,
        "dov.csv": dov,
        "damping.csv": damping,
    }, {"gnss": gnss}


SUMMARIES = {
    "height": {
        "std_error_m": 0.41,
        "max_error_m": -1.78,
        "n_reference": 270,
        "std_error_m_fix4": 0.05,
        "max_error_m_fix4": -0.13,
        "n_reference_fix4": 140,
    },
    "tilt": {"alpha_rad": 1e-4, "beta_rad": -2e-4},
    "gravity": {
        "total_mgal": 0.2,
        "noise_floor": {"total_mgal": 0.15, "drift_mgal": 0.05, "combined_mgal": 0.16},
        "fir_length_s": 120,
        "resolution_m": 900,
        "line_end_trim_s": 60,
        "lines": [{"name": "L1"}, {"name": "L2"}],
        "gnss_comparison": {
            "total_mgal": 0.9,
            "noise_floor": {"total_mgal": 0.5},
            "ldv_minus_gnss": [{"name": "L1", "rms_mgal": 0.31}, {"name": "L2", "rms_mgal": 0.29}],
        },
    },
    "dov": {"dov_source": "EGM2008 to degree 2190"},
    "damping": {"position_improvement_pct": 41.5},
    "navigate": {},
    "calibrate": {},
}


def _rows_of_trace(v, name, tabs, arrays):
    """The (x, y, order) arrays a trace of view ``v`` is drawn from, by the trace's name; None for
    a drawn reference (a noise-floor band)."""
    h, a, c, g, d, dm = (
        tabs[k] for k in ("height.csv", "attitude.csv", "coincidence.csv", "gravity.csv", "dov.csv", "damping.csv")
    )
    if "floor" in name:
        return None
    if v in ("trajectory", "calibration_track"):
        tr = tabs["trajectory.csv"]
        lat0, lon0 = np.radians(tr["lat_deg"][0]), np.radians(tr["lon_deg"][0])
        if name == "solution":
            _, e, n = _path()
            return e, n, tr["t_s"]
        gn = arrays["gnss"]
        tt, e, n = _path()
        del lat0, lon0
        q = int(re.search(r"GNSS, (\d)", name).group(1))
        k = gn["fix"] == q
        return (e[::10] + 0.5)[k], (n[::10] - 0.5)[k], gn["t_s"][k]
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
    raise AssertionError(f"the test does not know the trace '{name}' of view '{v}'")


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


UNIT = re.compile(r"\((s of day|m|m, ellipsoidal|deg|mGal|arcsec)\)$")


def check_layout(fig):
    lay = fig["layout"]
    for ax, spec in lay.items():
        if re.fullmatch(r"[xy]axis\d*", ax) and not spec.get("matches"):
            text = spec["title"]["text"]
            assert UNIT.search(text), f"{ax} title '{text}' carries no unit"
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
    fig = V.build_view(V.DictTables(tabs, arrays), v.pipeline, SUMMARIES[v.pipeline], name, None, None, N_POINTS)
    assert fig["data"], "no trace"
    check_layout(fig)
    for tr in fig["data"]:
        src = _rows_of_trace(name, tr["name"], tabs, arrays)
        if src is not None:
            check_trace(tr, *src)


@pytest.mark.parametrize("name", ["height", "attitude", "gravity_lines", "trajectory"])
def test_a_zoomed_view_stays_in_its_range_and_order(name, data):
    tabs, arrays = data
    v = V.VIEWS[name]
    x0, x1 = (30050.0, 30200.0) if v.pipeline in ("height", "tilt") else (-500.0, 800.0)
    fig = V.build_view(V.DictTables(tabs, arrays), v.pipeline, SUMMARIES[v.pipeline], name, x0, x1, N_POINTS)
    for tr in fig["data"]:
        src = _rows_of_trace(name, tr["name"], tabs, arrays)
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
    _, e, n = _path()
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
