"""``ldv-survey run gravity DAY1 DAY2 DAY3 --set base_ties=...``: a tied, adjusted survey of three days on two
crossing roads over one known field (sim/survey.py), turn-on biases ±19.6 mGal, base ties at the ends of
both roads where the days stand still (start and end of every day), FIR 200 s, 5 µg/√Hz white accelerometer."""

import json

import numpy as np
import pytest

from ldvsurvey.cli import main
from ldvsurvey.io.writers import read_result_table, write_bundle
from ldvsurvey.nav.earth import MGAL, normal_gravity
from ldvsurvey.nav.gravity import Lowpass
from ldvsurvey.sim import survey
from ldvsurvey.sim.scenario import bundle_files, simulate

FIR_S = 200.0
RATE_HZ = 50.0  #: IMU and LDV rate of the test days (halves the CI time; the floor does not depend on it)


@pytest.fixture(scope="module")
def network_run(tmp_path_factory):
    base = tmp_path_factory.mktemp("network")
    days = [
        survey.day(0, seed=1, imu_rate_hz=RATE_HZ, ldv_rate_hz=RATE_HZ),
        survey.day(0, seed=2, date="2023-03-21", imu_rate_hz=RATE_HZ, ldv_rate_hz=RATE_HZ),
        survey.day(1, seed=6, date="2023-03-22", imu_rate_hz=RATE_HZ, ldv_rate_hz=RATE_HZ),
    ]
    sims = [simulate(d) for d in days]
    paths = [write_bundle(bundle_files(s), base / f"day{k + 1}.zip") for k, s in enumerate(sims)]
    field = survey.survey_field()
    ties = []
    # base stations at both ends of both roads, where the days stand still: absolute g = γ + the field's δg
    for lat, lon, h in survey.tie_points(road=0) + survey.tie_points(road=1):
        g = normal_gravity(np.radians(lat), h) / MGAL + field.dg_mgal(np.radians(lat), np.radians(lon))
        ties.append(f"{lat:.9f},{lon:.9f},{h:.3f},{g:.4f}")
    out = base / "out"
    argv = ["run", "gravity", *map(str, paths), "--out", str(out), "--format", "geojson"]
    argv += [
        "--set",
        f"fir_length_s={FIR_S:g}",
        "--set",
        "gnss_comparison=false",
        "--set",
        "base_ties=" + ";".join(ties),
    ]
    assert main(argv) == 0
    summary = json.loads((out / "summary.json").read_text())
    table = read_result_table((out / "gravity_adjusted.csv").read_bytes())
    return sims, summary, table, out


def truth_along(sim, t_s):
    """The simulated field's δg along the true track, through the same FIR, at times t_s (mGal)."""
    im = sim.imu
    tm = 0.5 * (im.t_s[1:] + im.t_s[:-1])
    true = sim.gravity_field.dg_mgal(0.5 * (im.lat_rad[1:] + im.lat_rad[:-1]), 0.5 * (im.lon_rad[1:] + im.lon_rad[:-1]))
    return np.interp(t_s, tm, Lowpass(FIR_S, sim.scenario.imu_rate_hz).apply(true * MGAL) / MGAL)


def test_turn_on_biases_tens_of_mgal_apart(network_run):
    sims, summary, _, _ = network_run
    b = [s.errors.accel_bias_mps2[2] / MGAL for s in sims]
    assert abs(b[0] - b[1]) > 30.0
    net = summary["network"]
    assert net["repeat_rms_before_mgal"] > 10.0 and net["crossover_rms_before_mgal"] > 10.0


def test_crossover_and_repeat_rms_at_the_floor(network_run):
    _, summary, _, _ = network_run
    net = summary["network"]
    assert net["repeat_groups"] == [["B1-L1", "B1-L2", "B2-L1", "B2-L2"], ["B3-L1", "B3-L2"]]
    assert net["n_crossings"] >= 4  # the second road weaves across the first
    floor = net["noise_floor_mgal"]
    assert 0.3 < floor < 0.5  # 5 µg/√Hz through FIR 200 s (+ the LDV)
    # the fit's own residuals sit below the floor by construction (its degrees of freedom spent on them) …
    assert net["repeat_rms_after_mgal"] <= 1.2 * floor
    assert net["crossover_rms_after_mgal"] <= 1.2 * floor
    # … the honest figure predicts each line from the others and the ties (leave one line out)
    assert net["repeat_loo_rms_mgal"] <= 1.2 * floor, net["repeat_loo_floor_ratio"]
    assert net["crossover_loo_rms_mgal"] <= 1.2 * floor, net["crossover_loo_floor_ratio"]
    assert net["repeat_loo_rms_mgal"] > net["repeat_rms_after_mgal"]
    assert all(ln["loo_rms_mgal"] is not None for ln in net["lines"])


def test_absolute_dg_against_truth_per_line_without_removing_a_mean(network_run):
    sims, summary, t, _ = network_run
    lines = np.asarray(t["line"]).astype(str)
    for name in sorted(set(lines)):
        k = lines == name
        log = int(t["log"][k][0])
        err = t["dg_mgal"][k] - truth_along(sims[log - 1], t["t_s"][k])
        assert np.sqrt(np.mean(err**2)) <= 0.5, (name, np.mean(err), np.std(err))
        # absolute g against γ at the TRUE position and height (the navigated height's error cancels in g)
        im = sims[log - 1].imu
        lat_true = np.interp(t["t_s"][k], im.t_s, im.lat_rad)
        h_true = np.interp(t["t_s"][k], im.t_s, im.h_m)
        g_true = truth_along(sims[log - 1], t["t_s"][k]) + normal_gravity(lat_true, h_true) / MGAL
        assert np.sqrt(np.mean((t["g_mgal"][k] - g_true) ** 2)) <= 0.5
        # the adjustment's 1-σ is the floor and the correction's; δg's adds 0.3086 mGal/m · σ_h, and so does
        # g's: g is the field where the vehicle was, reported at the navigated height h_m
        assert np.all((t["adjustment_sigma_mgal"][k] > 0.3) & (t["adjustment_sigma_mgal"][k] < 0.7))
        np.testing.assert_allclose(
            t["sigma_mgal"][k] ** 2, t["adjustment_sigma_mgal"][k] ** 2 + (0.3086 * t["h_sigma_m"][k]) ** 2, rtol=3e-3
        )
        np.testing.assert_allclose(t["g_sigma_mgal"][k], t["sigma_mgal"][k], rtol=1e-12)
        # and δg's stated 1-σ covers its error (the height term included)
        assert np.sqrt(np.mean(err**2)) <= 2.0 * np.sqrt(np.mean(t["sigma_mgal"][k] ** 2)), name


def test_height_sigma_covers_the_navigated_height_error(network_run):
    """The SINS/LDV filter's height σ is its prior (a flat metre: the LDV observes no height); the table's σ_h
    comes from the GNSS fixes on each line instead, about the line's mean (a constant height error moves the
    line's δg by a constant, which its line bias absorbs), and against the simulator's true height error
    about the line's mean it is a 1-σ: about 68 % of the samples inside it (not all: it is not a bound),
    nearly all inside 3σ."""
    sims, summary, t, _ = network_run
    z = []
    names = np.asarray(t["line"]).astype(str)
    for name in sorted(set(names)):
        k = names == name
        im = sims[int(t["log"][k][0]) - 1].imu
        err = t["h_m"][k] - np.interp(t["t_s"][k], im.t_s, im.h_m)
        z.append((err - np.mean(err)) / t["h_sigma_m"][k])
    z = np.abs(np.concatenate(z))
    print(
        f"sigma_h {np.min(t['h_sigma_m']):.3f}-{np.max(t['h_sigma_m']):.3f} m; inside 1/2/3 sigma_h: "
        f"{np.mean(z < 1):.2f} {np.mean(z < 2):.2f} {np.mean(z < 3):.2f}"
    )
    assert 0.4 <= np.mean(z < 1.0) <= 0.9, np.mean(z < 1.0)
    assert np.mean(z < 3.0) >= 0.97, np.mean(z < 3.0)
    assert np.max(t["h_sigma_m"]) < 0.3  # not the filter's flat metre
    for pl in summary["network"]["lines"]:
        assert pl["h_sigma_source"].startswith("GNSS fix 4 on the line"), pl


def test_days_on_the_same_road_come_out_level(network_run):
    _, summary, t, _ = network_run
    floor = summary["network"]["noise_floor_mgal"]
    lines = np.asarray(t["line"]).astype(str)
    raw, adj = {}, {}
    for log in (1, 2):
        k = (t["log"] == log) & np.char.startswith(lines, f"B{log}-")
        raw[log] = np.mean(t["dg_unadjusted_mgal"][k])
        adj[log] = np.mean(t["dg_mgal"][k])
    assert abs(raw[1] - raw[2]) > 30.0  # before: the turn-on biases
    assert abs(adj[1] - adj[2]) <= floor  # after: level within the floor


def test_ties_and_datum_reported(network_run):
    _, summary, _, _ = network_run
    net = summary["network"]
    assert net["datum"] == "ties" and net["drift_logs"] == ["B1", "B2", "B3"]
    assert len(net["ties"]) == 9  # start, far end, back at the start: for each day
    for tie in net["ties"]:
        assert abs(tie["residual_mgal"]) <= 3 * tie["sigma_mgal"] + 0.1
        assert tie["distance_m"] < 5.0
    assert 0.0 < net["datum_sigma_mgal"] < 0.4
    pars = {(p["parameter"], p.get("log", p.get("line"))): p for p in net["parameters"]}
    assert pars[("log bias", "B1")]["value_mgal"] == pytest.approx(-19.6, abs=1.0)
    assert pars[("log bias", "B2")]["value_mgal"] == pytest.approx(19.6, abs=1.0)


def test_free_air_anomaly_through_the_height_anomaly(network_run):
    """Δg − δg = γ(h) − γ(h − ζ) ≈ −0.3086 mGal/m · ζ (free-air gradient of normal gravity)."""
    _, _, t, _ = network_run
    zeta = t["height_anomaly_m"]
    assert np.all((zeta > -25) & (zeta < -8))  # EGM2008 around 28.5° N, 113° E (the simulator takes −16 m)
    np.testing.assert_allclose(t["free_air_mgal"] - t["dg_mgal"], -0.3086 * zeta, rtol=3e-3)


def test_resolution_and_external_check_per_line(network_run):
    _, summary, t, _ = network_run
    net = summary["network"]
    for ln in net["lines"]:
        assert ln["resolution_m"] == pytest.approx(1966.0 * ln["speed_mps"] / 15.0, rel=0.01)
    # one resolution in the summary: the network's; the nominal v·L/2 under its own name
    assert summary["resolution_m"] == pytest.approx(np.median([ln["resolution_m"] for ln in net["lines"]]))
    assert summary["resolution_nominal_m"] == pytest.approx(0.5 * summary["median_speed_mps"] * FIR_S)
    assert summary["resolution_m"] > 1.2 * summary["resolution_nominal_m"]  # f½ = 0.763/L: not v·L/2
    ext = net["external_check"]
    assert ext["model"].startswith("EGM2008")
    assert ext["synthesis_height_m"] == pytest.approx(np.mean(t["h_m"]), abs=1.0)  # at the tracks' height
    assert len(ext["lines"]) == 6
    for ln in ext["lines"]:
        assert ln["omission_mgal"] > 5.0 and np.isfinite(ln["std_mgal"])


def test_exports(network_run):
    _, _, t, out = network_run
    gj = json.loads((out / "gravity_adjusted.geojson").read_text())
    kinds = {f["properties"].get("kind") for f in gj["features"]}
    assert "survey_line" in kinds
    assert {"g_mgal", "dg_mgal", "free_air_mgal", "sigma_mgal"} <= set(t)
    res = read_result_table((out / "network_residuals.csv").read_bytes())
    assert set(np.asarray(res["kind"]).astype(str)) == {"repeat", "crossing", "tie"}


def test_gps_time_of_every_row_from_its_own_logs_date(network_run):
    """Three logs of three dates: each row's GPS week and seconds of week from its own log's date (the
    ``log`` column), against datetime arithmetic from the GPS epoch with GPS − UTC = 18 s (IERS, 2023)."""
    import datetime as dt

    sims, _, _, out = network_run
    days = [dt.date.fromisoformat(s.scenario.date) for s in sims]
    assert len(set(days)) == 3
    for name in ("gravity", "gravity_adjusted", "network_residuals"):
        t = read_result_table((out / f"{name}.csv").read_bytes())
        assert list(t)[list(t).index("t_s") + 1 : list(t).index("t_s") + 3] == ["gps_week", "gps_sow_s"]
        logs = np.asarray(t["log"], int)
        assert set(logs) == {1, 2, 3}
        for k in np.linspace(0, len(logs) - 1, 40).astype(int):
            utc = dt.datetime.combine(days[logs[k] - 1], dt.time()) + dt.timedelta(seconds=float(t["t_s"][k]))
            w, s = divmod((utc - dt.datetime(1980, 1, 6)).total_seconds() + 18.0, 604800.0)
            assert (t["gps_week"][k], t["gps_sow_s"][k]) == (w, pytest.approx(s, abs=1e-6)), (name, k)
