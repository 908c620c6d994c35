"""The network's line weights from each log's combined floor, and the tie height check, on a simulated
survey: three days on the crossing roads of sim/survey.py, tied at both ends of both roads; the second
day's accelerometer wanders (the simulator's in-run IMU errors: a Gauss–Markov bias instability of
10 µg, τ 15 min, which its manifest states as a datasheet would), the other two are steady.

Truth is the simulator's: its field through the same FIR along the true track, its geoid-free heights;
the orthometric height of the wrong tie comes from EGM2008's height anomaly (the usual mix-up).
"""

from dataclasses import replace

import numpy as np
import pytest

from ldvsurvey.io.drivelog import parse_files
from ldvsurvey.nav.earth import MGAL, normal_gravity
from ldvsurvey.nav.gravmodel import height_anomaly_m
from ldvsurvey.pipelines.base import run_pipeline
from ldvsurvey.pipelines.gravity import pipeline as gravity
from ldvsurvey.pipelines.gravity.floor import drift_floor
from ldvsurvey.pipelines.gravity.network import survey_network
from ldvsurvey.pipelines.gravity.report import floor_of
from ldvsurvey.pipelines.gravity.tieheight import TIE_HEIGHT_WARN_M, check_tie_heights
from ldvsurvey.pipelines.registry import get
from ldvsurvey.sim import survey
from ldvsurvey.sim.effects import Effects, ImuErrorSpec
from ldvsurvey.sim.scenario import bundle_files, simulate
from tests.pipelines.test_gravity_network import FIR_S, RATE_HZ, truth_along

#: the drifting day: bias instability only (no scale or axis errors), 50 % of its 20 µg turn-on bias
DRIFT = ImuErrorSpec(
    gyro_scale_ppm=(0.0, 0.0, 0.0),
    accel_scale_ppm=(0.0, 0.0, 0.0),
    gyro_nonorth_urad=(0.0,) * 6,
    accel_nonorth_urad=(0.0,) * 6,
    gyro_bi_frac=0.0,
    accel_bi_frac=0.5,
)


#: what the network of ``weighted_run`` was given (the run's setup, chains and evaluation)
RUN_ARGS = {}


@pytest.fixture(scope="module")
def weighted_run():
    kw = dict(imu_rate_hz=RATE_HZ, ldv_rate_hz=RATE_HZ)
    days = [
        survey.day(0, seed=1, **kw),
        survey.day(0, seed=2, date="2023-03-21", effects=Effects(imu_errors=DRIFT), **kw),
        survey.day(1, seed=6, date="2023-03-22", **kw),
    ]
    sims = [simulate(d) for d in days]
    logs = [parse_files(bundle_files(s)) for s in sims]
    field = survey.survey_field()
    ties = []
    for lat, lon, h in survey.tie_points(road=0) + survey.tie_points(road=1):
        ties.append((lat, lon, h, normal_gravity(np.radians(lat), h) / MGAL + field.dg_mgal(*np.radians([lat, lon]))))
    params = {
        "fir_length_s": FIR_S,
        "gnss_comparison": False,
        "external_model": "none",
        "map_grid": False,
        "base_ties": ";".join(",".join(repr(float(v)) for v in t) for t in ties),
    }
    seen = {}
    real = gravity.network_floors

    def spy(*a, **k):  # what the network was given: to adjust the same lines with the white floor alone
        seen["args"] = a
        return real(*a, **k)

    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(gravity, "network_floors", spy)
        result = run_pipeline(get("gravity"), logs, params)
    rs, cs, res = seen["args"][:3]
    RUN_ARGS.update(rs=rs, cs=cs, res=res)
    chains = cs.main
    white = [floor_of(lg, ch, rs.lowpass)["total_mgal"] for lg, ch in zip(rs.logs, chains)]
    white_net, white_tables, _, _ = survey_network(rs.logs, chains, res, rs.params, rs.lowpass, white)
    return sims, logs, chains, ties, result, (white_net, white_tables)


def _steady_error_rms(sims, table):
    """RMS (mGal) of the adjusted δg of the steady days (B1, B3) against the simulated field."""
    err = []
    for b in (1, 3):
        k = table["log"] == b
        err.append(table["dg_mgal"][k] - truth_along(sims[b - 1], table["t_s"][k]))
    return float(np.sqrt(np.mean(np.concatenate(err) ** 2)))


def _z(tables, names):
    res = tables["network_residuals"]
    k = np.array([ln.split("-")[0] in names for ln in res["line"]]) & (np.array(res["kind"]) != "tie")
    return np.asarray(res["standardized"])[k]


def test_the_drifting_log_weighs_by_its_combined_floor(weighted_run):
    _, logs, _, _, result, _ = weighted_run
    assert logs[1].manifest.imu.accel_bias_instability_ug == pytest.approx(10.0)
    rows = {r["log"]: r for r in result.summary["network"]["log_floors"]}
    print({k: (r["white_mgal"], r["drift_mgal"], r["drift_mgal_spread"], r["combined_mgal"]) for k, r in rows.items()})
    assert rows["B1"]["drift_mgal"] is None and rows["B3"]["drift_mgal"] is None  # steady: no drift stated
    assert rows["B1"]["combined_mgal"] == rows["B1"]["white_mgal"]
    d = rows["B2"]
    assert d["drift_mgal"] > d["white_mgal"]  # the wander dominates the drifting day's floor
    assert d["combined_mgal"] == pytest.approx(np.hypot(d["white_mgal"], d["drift_mgal"]))
    per_line = {ln["name"]: ln["noise_floor_mgal"] for ln in result.summary["network"]["lines"]}
    assert per_line["B2-L1"] == pytest.approx(d["combined_mgal"]) and per_line["B1-L1"] == rows["B1"]["white_mgal"]


def test_residuals_consistent_with_the_weights(weighted_run):
    """χ² per degree of freedom near 1 and the drifting day's normalized residuals of unit scale with
    the combined floor; with the white floor alone its residuals are several σ. The drifting day is ONE
    realisation of its drift: its coincidence scatters about the Monte Carlo's RMS by the Monte Carlo's own
    spread (~50 % here), so its residuals' RMS is held to within two of those spreads."""
    _, _, _, _, result, (white_net, white_tables) = weighted_run
    net = result.summary["network"]
    z_drift, z_white = _z(result.tables, {"B2"}), _z(white_tables, {"B2"})
    print(
        f"sigma0 {net['sigma0']:.3f} (white only {white_net['sigma0']:.3f}); B2 z RMS "
        f"{np.sqrt(np.mean(z_drift**2)):.2f} (white only {np.sqrt(np.mean(z_white**2)):.2f}); steady z RMS "
        f"{np.sqrt(np.mean(_z(result.tables, {'B1', 'B3'}) ** 2)):.2f} (white only "
        f"{np.sqrt(np.mean(_z(white_tables, {'B1', 'B3'}) ** 2)):.2f})"
    )
    assert 0.5 < net["sigma0"] < 1.5, net["sigma0"]
    d = next(r for r in net["log_floors"] if r["log"] == "B2")
    lo = np.hypot(d["white_mgal"], max(d["drift_mgal"] - 2 * d["drift_mgal_spread"], 0.0)) / d["combined_mgal"]
    hi = np.hypot(d["white_mgal"], d["drift_mgal"] + 2 * d["drift_mgal_spread"]) / d["combined_mgal"]
    assert lo < np.sqrt(np.mean(z_drift**2)) < hi, (lo, hi)
    assert np.sqrt(np.mean(_z(result.tables, {"B1", "B3"}) ** 2)) < 1.5
    assert np.sqrt(np.mean(z_white**2)) > 1.5 * np.sqrt(np.mean(z_drift**2))  # the check can tell


def test_the_steady_days_are_not_pulled(weighted_run):
    sims, _, _, _, result, (_, white_tables) = weighted_run
    combined = _steady_error_rms(sims, result.tables["gravity_adjusted"])
    white = _steady_error_rms(sims, white_tables["gravity_adjusted"])
    floor = result.summary["network"]["log_floors"][0]["white_mgal"]
    print(f"steady days against truth: {combined:.3f} mGal (white-only weights {white:.3f}), floor {floor:.3f}")
    assert combined <= white + 0.02
    assert combined < 2.5 * floor


def test_true_tie_heights_raise_no_warning(weighted_run):
    _, _, _, _, result, _ = weighted_run
    ties = result.summary["network"]["ties"]
    assert ties and all(t["height_warning"] is None for t in ties)
    assert max(abs(t["h_difference_m"]) for t in ties) < TIE_HEIGHT_WARN_M
    assert not any("height" in w and "base tie" in w for w in result.warnings)


def test_an_orthometric_tie_height_is_reported(weighted_run):
    """T1 given above the geoid (h − ζ, EGM2008's height anomaly there, about −20 m near Changsha)."""
    _, logs, chains, ties, result, _ = weighted_run
    lat, lon, h, g = ties[0]
    zeta = float(height_anomaly_m(lat, lon, h)[0])
    assert abs(zeta) > 2 * TIE_HEIGHT_WARN_M  # the check can see it here
    given = [(lat, lon, h - zeta, g)] + list(ties[1:])
    rows = [dict(r) for r in result.summary["network"]["ties"]]
    warnings = check_tie_heights(rows, given, chains, logs)
    flagged = [r for r in rows if r["height_warning"]]
    assert flagged and {r["tie"] for r in flagged} == {"T1"} and len(warnings) == len(flagged)
    for r in flagged:
        assert r["h_difference_m"] == pytest.approx(-zeta, abs=1.5)
        assert f"{h - zeta:.1f} m" in r["height_warning"] and f"{r['h_reference_m']:.1f} m" in r["height_warning"]
        assert r["h_reference_source"] == "GNSS" and r["h_reference_m"] == pytest.approx(r["h_gnss_m"], abs=0.5)
        assert "T1" in r["height_warning"] and "the tie's height looks orthometric" in r["height_warning"]


def test_without_gnss_the_navigated_height_is_the_reference(weighted_run):
    """A log without fixes at the stop: the tie's height is compared with the navigated one (the
    simulator's true height there is the independent check of that reference)."""
    import types

    sims, logs, chains, ties, result, _ = weighted_run
    lat, lon, h, g = ties[0]
    no_gnss = [types.SimpleNamespace(gnss=None, manifest=lg.manifest) for lg in logs]
    rows = [dict(r) for r in result.summary["network"]["ties"]]
    warnings = check_tie_heights(rows, [(lat, lon, h - 20.0, g)] + list(ties[1:]), chains, no_gnss)
    for r in rows:
        assert r["h_gnss_m"] is None
        ci = int(r["log"][1:]) - 1
        true_h = float(np.interp(r["t_s"], sims[ci].imu.t_s, sims[ci].imu.h_m))
        assert r["h_nav_m"] == pytest.approx(true_h, abs=1.0)
        assert (r["height_warning"] is not None) == (r["tie"] == "T1")
    assert warnings and all("navigated height" in w and "T1" in w for w in warnings)


def test_a_drifting_log_whose_manifest_states_no_drift_keeps_a_drift_term(weighted_run):
    """The drifting day with the bias instability struck from its manifest: its stop tie still measured the
    drift, so the floor takes the drift's law from the tie (saying so) instead of dropping the term. Against
    the floor from the simulator's own law (the true manifest) it is of the same size (the tie sees the
    slow part: a lower bound of σ, τ at the stops' spacing)."""
    rs, cs, res = RUN_ARGS["rs"], RUN_ARGS["cs"], RUN_ARGS["res"]
    assert cs.drift_reports[1].get("method") == "repeated stops"  # the tie found the drift and was applied
    log = rs.logs[1]
    blind = replace(
        log,
        manifest=log.manifest.model_copy(
            update={"imu": log.manifest.imu.model_copy(update={"accel_bias_instability_ug": None})}
        ),
    )
    kw = {"tie_applied": True, "leveling": "bias", "bundle": 1}
    true_law = drift_floor(log, cs.main[1], res, rs.lowpass, rs.params.spacing_m, **kw)
    tied_law = drift_floor(blind, cs.main[1], res, rs.lowpass, rs.params.spacing_m, **kw)
    print(
        f"drift floor: manifest's law {true_law['drift_mgal']:.2f} mGal, the tie's {tied_law['drift_mgal']:.2f} "
        f"(σ {tied_law['accel_bias_instability_ug']:.2f} µg, τ {tied_law['bias_correlation_s']:.0f} s)"
    )
    assert "stop tie's measured drift" in tied_law["drift_source"] and "bundle 2" in tied_law["drift_warning"]
    assert 0.3 * true_law["drift_mgal"] < tied_law["drift_mgal"] < 3.0 * true_law["drift_mgal"]
    assert tied_law["drift_mgal"] > floor_of(log, cs.main[1], rs.lowpass)["total_mgal"]  # as the true one, it dominates
    # a log whose manifest states no drift and whose tie measured none keeps the white floor, silently
    steady = drift_floor(blind, {**cs.main[1], "drift_mps2": None}, res, rs.lowpass, rs.params.spacing_m, **kw)
    assert steady["drift_mgal"] is None and "drift_warning" not in steady
