"""gravity on a short realistic drive (sim-realistic's effects): gaps cost only their own data,
IMU gaps are surfaced, the noise floor is printed, the chains agree, the views show it.

Short version of the realistic six-line survey for the suite: three 4-km lines (25 min). The
accelerometer's in-run errors (scale, non-orthogonality, bias drift) are switched off here (and
with them the drift tie at stops) so the figures test the chain itself; the full drive with every
effect is the benchmark's job
(benchmarks/bench_gravity.py, docs/accuracy.md).
"""

import numpy as np
import pytest

from ldvsurvey.io.drivelog import parse_files
from ldvsurvey.nav.earth import MGAL
from ldvsurvey.nav.gravity import Lowpass, noise_floor_mgal
from ldvsurvey.pipelines.base import run_pipeline
from ldvsurvey.pipelines.registry import get
from ldvsurvey.sim import catalog
from ldvsurvey.sim.scenario import bundle_files, simulate

FIR_S = 150.0


def _run(**effects):
    sc = catalog.realistic_gravity(seed=3, n_lines=3, line_km=4.0, imu_errors=None, **effects)
    sim = simulate(sc)
    log = parse_files(bundle_files(sim))
    # no accelerometer drift in this drive (imu_errors off): the stop tie would only add its noise
    res = run_pipeline(get("gravity"), [log], {"fir_length_s": FIR_S, "gnss_aided": True, "drift_correction": "none"})
    res.log = log
    return sim, res


@pytest.fixture(scope="module")
def with_dropouts():
    return _run()


@pytest.fixture(scope="module")
def without_dropouts():
    return _run(ldv_dropouts=None)


def _truth_error(sim, res, column="dg_mgal"):
    """Per line: filtered result minus the equally filtered true Δg, after one constant (the
    unobservable vertical accelerometer bias); from the simulator's field, never the pipeline."""
    g = res.tables["gravity"]
    im = sim.imu
    _, _, dg = sim.extras["gravity_field"](
        0.5 * (im.lat_rad[1:] + im.lat_rad[:-1]),
        0.5 * (im.lon_rad[1:] + im.lon_rad[:-1]),
        0.5 * (im.h_m[1:] + im.h_m[:-1]),
    )
    tf = Lowpass(FIR_S, 100.0).apply(dg) / MGAL
    on = np.array([x != "" for x in g["line"]])
    e = g[column][on] - np.interp(g["t_s"][on], 0.5 * (im.t_s[1:] + im.t_s[:-1]), tf)
    if np.isfinite(e).any():
        e -= np.nanmean(e)
    names = np.array(g["line"])[on]
    return {
        n: float(np.sqrt(np.nanmean(e[names == n] ** 2))) if np.isfinite(e[names == n]).any() else np.nan
        for n in sorted(set(names))
    }


def test_dropouts_cost_only_their_own_data(with_dropouts, without_dropouts):
    sim, res = with_dropouts
    _, clean = without_dropouts
    s, s0 = res.summary, clean.summary
    # the drive really had bursts inside the lines, and the summary says how much they removed
    bursts = sim.extras["ldv_bursts"]
    assert len(bursts) >= 5
    assert sum(ln["bridged_s"] for ln in s["lines"]) > 5 * sum(ln["bridged_s"] for ln in s0["lines"]) + 1.0
    assert all(0.0 <= ln["bridged_share"] < 0.2 for ln in s["lines"])
    # the coincidence barely notices (the former NaN chain leaked every burst into δg)
    assert s["total_mgal"] == pytest.approx(s0["total_mgal"], rel=0.15)
    err = _truth_error(sim, res)
    assert max(err.values()) <= 1.0, err


def test_ldv_gaps_are_named_per_line_in_a_warning(with_dropouts, without_dropouts):
    """LDV dropouts bridged through the navigation velocity were only in the summary's per-line
    figures; a warning now names every line's bridged seconds (the drive had bursts inside lines)."""
    _, res = with_dropouts
    warn = [w for w in res.warnings if w.startswith("LDV gaps")]
    assert len(warn) == 1
    for ln in res.summary["lines"]:
        if ln["bridged_s"] > 0:
            assert f"{ln['name']} {ln['bridged_s']:.1f} s" in warn[0]
    _, clean = without_dropouts
    named = [w for w in clean.warnings if w.startswith("LDV gaps")]
    # without the dropout effect only the simulator's rare low-quality samples remain: far fewer seconds
    if named:
        assert sum(ln["bridged_s"] for ln in clean.summary["lines"]) < 0.2 * sum(
            ln["bridged_s"] for ln in res.summary["lines"]
        )


def test_imu_gaps_are_surfaced(with_dropouts):
    sim, res = with_dropouts
    dropped = int(np.count_nonzero(~sim.extras["imu_keep"]))
    assert dropped > 0  # the simulated recorder lost rows
    gaps = res.summary["imu_gaps"]
    assert gaps["bridged_rows"] == dropped
    assert gaps["notes"] and "imu.csv" in gaps["notes"][0]
    assert any("imu.csv" in w and "gap" in w for w in res.summary["warnings"])


def test_noise_floor_beside_the_measured_figure(with_dropouts):
    sim, res = with_dropouts
    s = res.summary
    fl = s["noise_floor"]
    assert fl["accel_noise_ug_rthz"] == sim.scenario.accel_vrw_ug_rthz == 5.0
    # independent of the pipeline's own sums: 5 µg/√Hz through a 150-s Blackman FIR forward and back
    assert fl["accel_mgal"] == pytest.approx(noise_floor_mgal(Lowpass(FIR_S), 5.0)["accel_mgal"])
    assert 0.35 < fl["accel_mgal"] < 0.5
    assert fl["total_mgal"] >= fl["accel_mgal"]
    assert s["floor_ratio"] == pytest.approx(s["total_mgal"] / fl["total_mgal"])
    assert s["floor_ratio"] < 3.0
    assert s["line_end_trim_s"] == FIR_S / 2 and "trimmed" in s["line_ends"]
    assert all(ln["mean_mgal"] is not None and ln["std_mgal"] >= 0 for ln in s["lines"])
    assert s["resolution_m"] == pytest.approx(0.5 * s["median_speed_mps"] * FIR_S)


def test_sins_gnss_and_gnss_aided_beside(with_dropouts):
    sim, res = with_dropouts
    s = res.summary
    gc = s["gnss_comparison"]
    assert gc["aiding"] == "gnss" and gc["gnss_fixes"] == [4]
    diff = {d["name"]: d for d in gc["ldv_minus_gnss"]}
    assert set(diff) == {ln["name"] for ln in s["lines"]}
    err = _truth_error(sim, res, "dg_sins_gnss_mgal")
    # this short drive keeps RTK on ~100 s of a line at most (outages, degraded fixes, multipath):
    # shorter than the FIR's reach, so next to the breaks the values are withheld (the former chain
    # showed them, up to 5 mGal off the truth). What is shown must hold the 3-mGal acceptance; the
    # rest is reported as withheld. The full drive: benchmarks/bench_gravity.py.
    shown = [v for v in err.values() if np.isfinite(v)]
    assert all(v <= 3.0 for v in shown), err
    # on this drive every RTK stretch is shorter than the FIR, so nothing may be shown (the accuracy of
    # shown values is tested where RTK lasts: tests/pipelines/test_gravity_chains.py); what is withheld
    # must be said, line by line
    assert any(ln["unsupported_s"] > 0 for ln in gc["lines"])
    for name, v in err.items():
        ln = next(x for x in gc["lines"] if x["name"] == name)
        assert np.isfinite(v) or ln.get("no_data") or ln["unsupported_s"] > 0, (name, ln)
    for ln in gc["lines"]:
        assert ln.get("no_data") or ln["rms_mgal"] is not None or ln["unsupported_s"] > 0
    aided = s["gnss_aided"]
    assert aided["aiding"] == "ldv+gnss"
    err_a = _truth_error(sim, res, "dg_gnss_aided_mgal")
    assert max(err_a.values()) <= 1.0, err_a
    g = res.tables["gravity"]
    assert list(g)[:10] == [
        "t_s", "gps_week", "gps_sow_s", "line", "distance_m", "lat_deg", "lon_deg", "h_m", "dg_raw_mgal", "dg_mgal"
    ]  # fmt: skip
    assert {"dg_sins_gnss_mgal", "dg_gnss_aided_mgal"} <= set(g)


def test_views_show_floor_and_chain_difference(with_dropouts):
    from ldvsurvey.api import views

    _, res = with_dropouts
    tables = {
        f"{k}.csv": {c: (np.array(v, dtype=object) if c == "line" else np.asarray(v, float)) for c, v in t.items()}
        for k, t in res.tables.items()
    }
    s = res.summary
    fig = views.build_view(views.DictTables(tables), "gravity", s, "gravity_residuals", None, None, 500)
    title = fig["layout"]["title"]["text"]
    assert f"{s['total_mgal']:.3f}" in title and f"floor ±{s['noise_floor']['total_mgal']:.3f}" in title
    assert any("white-noise floor" in tr["name"] for tr in fig["data"])
    fig = views.build_view(views.DictTables(tables), "gravity", s, "gravity_compare_gnss", None, None, 500)
    names = [tr["name"] for tr in fig["data"]]
    assert sum("SINS/LDV − SINS/GNSS" in nm for nm in names) == len(s["lines"])


def test_bad_gravity_parameters_are_named():
    from ldvsurvey.errors import ParameterError
    from ldvsurvey.pipelines.gravity.pipeline import parse_fixes

    assert parse_fixes("4,5") == (4, 5)
    for bad in ("x", "3", ""):
        with pytest.raises(ParameterError) as e:
            parse_fixes(bad)
        assert e.value.field == "gnss_fixes"


def test_line_leveling_shifts_lines_by_their_mean_residual(with_dropouts):
    _, res = with_dropouts
    lev = run_pipeline(
        get("gravity"),
        [res.log],
        {"fir_length_s": FIR_S, "drift_correction": "none", "gnss_comparison": False, "line_leveling": "bias"},
    )
    s0, s1 = res.summary, lev.summary
    offs = s1["line_leveling"]["offsets_mgal"]
    assert sum(offs.values()) == pytest.approx(0.0, abs=1e-9)
    for ln in s0["lines"]:  # the offsets are the unlevelled lines' mean residuals
        assert offs[ln["name"]] == pytest.approx(ln["mean_mgal"], abs=1e-9)
    assert all(abs(ln["mean_mgal"]) < 1e-9 for ln in s1["lines"])
    assert s1["total_mgal"] < s0["total_mgal"]
    # the levelled values in gravity.csv are the unlevelled ones minus the line's offset
    g0, g1 = res.tables["gravity"], lev.tables["gravity"]
    for name, o in offs.items():
        k = np.array([x == name for x in g0["line"]])
        np.testing.assert_allclose(g1["dg_mgal"][k], g0["dg_mgal"][k] - o, atol=1e-9)
