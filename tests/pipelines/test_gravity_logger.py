"""Gravity from a sloppy logger (issue 29): IMU time tags that jitter by a fraction of a
millisecond about the sampling instants together with lost rows (runs of 1-5).

Each alone was harmless; together the bridged rows were rescaled by the jittered gap length, which put
g·δt (~3 mm/s) of velocity into every gap: 0.44 -> 3.12 mGal on the six-line drive, and false drift
at the stops. Truth: the same simulated drive (same sensor noise) written by a perfect logger, the
simulator's own record of the rows it dropped, and its true increments.

Drive: two repeated 5-km lines (~20 min), FIR 100 s, the stop tie forced on (the accelerometer has
no in-run drift: whatever the tie finds is its error); ~10 s per run, four runs.
"""

import numpy as np
import pytest

from ldvsurvey.io.drivelog import parse_files
from ldvsurvey.pipelines.base import run_pipeline
from ldvsurvey.pipelines.registry import get
from ldvsurvey.sim import catalog
from ldvsurvey.sim.effects import Effects, ImuTiming
from ldvsurvey.sim.scenario import bundle_files, simulate

FIR_S = 100.0
SEED = 3
#: the issue's logger: σ 0.3 ms jitter (rare tags off by up to 2 ms), a run of lost rows a minute
SLOPPY = ImuTiming(drops_per_min=1.0, drop_max_rows=5, jitter_s=3e-4)
#: every other logger/acquisition defect, no accelerometer in-run errors (no drift to find)
OTHERS = {"imu_errors": False, "turntable": False, "moving_start": False}


def _run(effects):
    sim = simulate(catalog.realistic_gravity(seed=SEED, effects=effects, n_lines=2, line_km=5.0))
    log = parse_files(bundle_files(sim))
    params = {"fir_length_s": FIR_S, "gnss_comparison": False, "drift_correction": "stops"}
    return sim, log, run_pipeline(get("gravity"), [log], params)


@pytest.fixture(scope="module")
def pair():
    """The same drive from a perfect logger and from the sloppy one (nothing else on)."""
    return _run(Effects.ideal()), _run(Effects.ideal().with_(imu_timing=SLOPPY))


@pytest.fixture(scope="module")
def every_defect():
    """Every effect but the accelerometer's in-run errors, with and without the sloppy logger."""
    return (
        _run(Effects.realistic(SEED, imu_timing=False, **OTHERS)),
        _run(Effects.realistic(SEED, imu_timing=SLOPPY, **OTHERS)),
    )


def _dropped_runs(sim):
    """(t of the row before, rows) of every run of rows the simulator dropped."""
    keep = sim.extras["imu_keep"]
    edges = np.flatnonzero(np.diff(np.r_[1, keep.astype(int), 1]))
    return [(float(sim.imu.t_s[a - 1]), int(b - a)) for a, b in zip(edges[::2], edges[1::2])]


def _no_drift(report):
    """The tie finds no drift: the last stop's (the drift over the survey; the first stop's level is
    the reference) within 2 of its 1-σ, every stop within 3, and together consistent with none (χ²
    against the tie's own covariance, p > 0.05). A max over many stops within 2 σ would fail a third
    of drift-free surveys (test_stop_tie_sigma_is_the_scatter_of_drift_free_ties)."""
    stops = report["stops"][1:]
    assert stops and all(s["drift_sigma_mgal"] and s["drift_sigma_mgal"] > 0 for s in stops), report
    z = [abs(s["drift_mgal"]) / s["drift_sigma_mgal"] for s in stops]
    return z[-1] <= 2.0 and max(z) <= 3.0 and report["no_drift_p_value"] > 0.05


def test_jitter_with_lost_rows_costs_what_the_rows_held(pair):
    (_, _, clean), (sim, log, sloppy) = pair
    s, s0 = sloppy.summary, clean.summary
    runs = _dropped_runs(sim)
    # the logger really was sloppy: a run of lost rows a minute, every one bridged as lost (not merged)
    assert len(runs) >= 15 and s["imu_gaps"]["lost_gaps"] == len(runs)
    assert s["imu_gaps"]["lost_rows"] == sum(k for _, k in runs) == log.imu.bridged_rows
    assert np.std(np.diff(log.imu.t_s)) > 1e-4  # and the tags jitter by a fraction of a ms
    # the coincidence within 10 % of the perfect logger's (it was ×4 before the fix)
    assert s["total_mgal"] == pytest.approx(s0["total_mgal"], rel=0.10), (s["total_mgal"], s0["total_mgal"])
    # per line: the bridged time is that of the simulator's dropped rows on the line, and its cost is
    # printed; a few lost rows of a smooth drive cost far less than the white floor
    dt = 0.01
    for ln, (name, a, b) in zip(s["lines"], sim.scenario.lines):
        assert ln["name"] == name
        on = sum(k for t, k in runs if a <= t <= b)
        assert ln["imu_bridged_s"] == pytest.approx(on * dt, abs=1e-6), (name, ln)
        assert 0.0 <= ln["imu_bridge_cost_mgal"] < 0.1 * s["noise_floor"]["total_mgal"], ln
    nf = s["noise_floor"]
    assert nf["imu_bridge_mgal"] > 0 and nf["combined_mgal"] >= nf["total_mgal"]
    # no drift where the accelerometer has none
    dc = s["drift_correction"]
    assert dc["method"] == "repeated stops" and _no_drift(dc), dc


def test_every_logger_defect_no_drift_found(every_defect):
    (_, _, clean), (sim, _, sloppy) = every_defect
    s, s0 = sloppy.summary, clean.summary
    assert len(_dropped_runs(sim)) >= 15 and len(sim.extras["ldv_bursts"]) >= 5
    assert s["total_mgal"] == pytest.approx(s0["total_mgal"], rel=0.10), (s["total_mgal"], s0["total_mgal"])
    assert s["total_mgal"] <= 3 * s["noise_floor"]["combined_mgal"], s["noise_floor"]
    dc = s["drift_correction"]
    assert dc["method"] == "repeated stops" and _no_drift(dc), dc
    # the stops' σ is measured on their data: the accelerometer's white noise (5 µg/√Hz) over each
    # stop's duration within a factor of 1.5 (the 1-s means of a 16-60 s stop scatter that much)
    for x in dc["stops"]:
        white = 5e-6 * 9.80665 / np.sqrt(x["duration_s"]) / 1e-5
        assert white / 1.5 < x["stop_sigma_mgal"] < 1.5 * white, (x, white)


def test_the_measured_bridge_sigma_covers_the_true_error(pair):
    """Per lost run, the σ the chain measured next to it against the true error of its bridge
    (the simulator's true increments of the dropped rows minus the bridged ones, up component):
    over the runs the normalised errors scatter like a unit normal (their RMS within 0.5-2)."""
    (_, _, _), (sim, log, _) = pair
    from ldvsurvey.pipelines.gravity.chains import lost_increment_sigmas
    from ldvsurvey.pipelines.gravity.pipeline import navigation_log
    from ldvsurvey.pipelines.navigate import run_navigation

    params = get("gravity").validate({"fir_length_s": FIR_S})
    inp, _setup, sol = run_navigation(navigation_log(log), params, lambda *a: None, aiding="ldv", smooth=True)
    sig = lost_increment_sigmas(inp, sol)
    gaps = [g for g in log.imu.bridges if g.lost]
    assert len(sig) == len(gaps) >= 15
    keep = sim.extras["imu_keep"]
    lost_rows = np.flatnonzero(~keep)
    z = []
    for g, (_, dur, sg) in zip(gaps, sig):
        true_rows = lost_rows[(sim.imu.t_s[lost_rows] > g.t_before_s - 0.005) & (sim.imu.t_s[lost_rows] < g.t_after_s)]
        assert len(true_rows) == g.rows and dur == pytest.approx(g.rows * 0.01, rel=1e-3)
        err_s = log.imu.dvel_mps[g.row : g.row + g.rows].sum(axis=0) - sim.dvel_mps[true_rows].sum(axis=0)
        up = sim.imu.c_bn[true_rows[0]][2] @ err_s  # the fixed IMU's sensor axes are the body's
        z.append(up / sg)
    rms = float(np.sqrt(np.mean(np.square(z))))
    assert 0.5 < rms < 2.0, (rms, z)


def test_stop_tie_sigma_is_the_scatter_of_drift_free_ties():
    """The tie's 1-σ and χ² against a Monte Carlo of drift-free stops (independent truth: the stop
    means drawn about their spots' Δg with known σ). Over 400 surveys of 13 stops at two spots the
    normalised drifts have unit variance and the χ² its degrees of freedom; a linear drift of 3 mGal
    over the survey (stops σ 0.1-0.4 mGal) is found (p < 1e-3)."""
    from ldvsurvey.pipelines.gravity.drift import estimate_drift

    rng = np.random.default_rng(29)
    spots = [0, 1, 1, 0, 0, 1, 1, 0, 0, 1, 1, 0, 0]
    dg = {0: 1e-4, 1: -3e-4}  # m/s²
    z2, chi2 = [], []
    for _ in range(400):
        sig = rng.uniform(1e-6, 4e-6, len(spots))
        stops = [
            (600.0 * k, 0.5 + 1e-3 * s, 0.3, dg[s] + rng.normal(0, sg), 20.0, sg)
            for k, (s, sg) in enumerate(zip(spots, sig))
        ]
        e = estimate_drift(stops)
        z2.append(np.mean((e["drift"][1:] / e["drift_sigma"][1:]) ** 2))
        chi2.append(e["chi2"])
        dof = e["dof"]
    assert dof == len(spots) - 2
    assert np.mean(z2) == pytest.approx(1.0, abs=0.1)
    assert np.mean(chi2) == pytest.approx(dof, abs=3 * np.sqrt(2 * dof / 400))
    from ldvsurvey.pipelines.gravity.drift import drift_correction

    c = 300.0 + 600.0 * np.arange(len(spots))  # the stops' centres, s
    t = np.arange(0.0, 600.0 * len(spots), 1.0)
    ramp = 3e-5 * t / t[-1]  # 3 mGal over the survey
    still = [(ck - 15.0, ck + 15.0) for ck in c]
    spot_of = np.array(spots)[np.clip(((t - 300.0) / 600.0).round().astype(int), 0, len(spots) - 1)]
    noise = rng.normal(0.0, 1e-5, len(t))  # 1 mGal per 1-Hz sample: 0.2 mGal over a 26-s stop
    chain = {
        "t_s": t,
        "dg_static": np.array([dg[s] for s in spot_of]) + ramp + noise,
        "lat": 0.5 + 1e-3 * spot_of,
        "lon": np.full(len(t), 0.3),
    }
    b, rep = drift_correction(chain, still, None, "auto")
    assert b is not None and rep["method"] == "repeated stops" and rep["no_drift_p_value"] < 1e-3, rep
    last = rep["stops"][-1]
    assert last["drift_mgal"] == pytest.approx(3.0 * (c[-1] - c[0]) / t[-1], abs=3 * last["drift_sigma_mgal"]), last


def test_bridge_cost_is_the_filtered_impulse():
    """The σ a bridge leaves in the filtered δg against the FIR itself: a velocity error A (m/s)
    over one interval is an impulse A/Δt in δg; the pipeline's filter (Lowpass.apply, with its
    normalisation) applied to it must give, at every time, |filtered| = the predicted σ for σ = A,
    and two independent bridges add in variance."""
    from ldvsurvey.nav.earth import MGAL
    from ldvsurvey.nav.gravity import Lowpass
    from ldvsurvey.pipelines.gravity.report import imu_bridge_sigma_mgal

    fs, fir, n = 10.0, 100.0, 20000
    t = np.arange(n) / fs
    a1, a2, i1, i2 = 3e-3, 2e-3, 8000, 8600
    x = np.zeros(n)
    x[i1] = a1 * fs
    y1 = Lowpass(fir, fs).apply(x)
    x[:] = 0.0
    x[i2] = a2 * fs
    y2 = Lowpass(fir, fs).apply(x)
    ch = {"fs": fs, "imu_bridges": [(t[i1], 0.03, a1), (t[i2], 0.02, a2)]}
    got = imu_bridge_sigma_mgal(ch, Lowpass(fir), t[5000:12000])
    want = np.sqrt(y1[5000:12000] ** 2 + y2[5000:12000] ** 2) / MGAL
    np.testing.assert_allclose(got, want, rtol=1e-6, atol=1e-9)
    assert got.max() > 1.0  # a 3 mm/s bridge error is ~1 mGal at its peak through a 100-s FIR
