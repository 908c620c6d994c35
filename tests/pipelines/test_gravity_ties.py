"""Base ties of the gravity network: the parameter, its refusals (exit 2, naming the tie), and the stops
that observe a tie (drift removed as on the lines, weight from the accelerometer noise over the stop)."""

import types
from dataclasses import replace

import numpy as np
import pytest

from ldvsurvey.cli import main
from ldvsurvey.errors import ParameterError
from ldvsurvey.nav.earth import MGAL, normal_gravity
from ldvsurvey.nav.gravity import G0, Lowpass
from ldvsurvey.pipelines.gravity.network import TIE_GRADIENT_MGAL_PER_M, observed_ties, parse_ties
from ldvsurvey.pipelines.registry import get


def test_ties_parse():
    assert parse_ties("28.5,113.0,120,979100.5; 28.6,113.1,130.5,979090;40,250,10,980000") == [
        (28.5, 113.0, 120.0, 979100.5),
        (28.6, 113.1, 130.5, 979090.0),
        (40.0, -110.0, 10.0, 980000.0),  # 250° E is 110° W, as the navigation's longitudes
    ]


@pytest.mark.parametrize(
    "text, part",
    [
        ("28.5,113.0,120", "tie 1"),
        ("28.5,113.0,120,979100;28.5,x,1,979100", "tie 2"),
        ("95,113.0,120,979100", "latitude"),
        ("28.5,113.0,120,13.2", "not an absolute gravity value"),
        ("28.5,113.0,nan,979100", "finite"),
    ],
)
def test_bad_ties_are_refused_naming_the_tie(text, part):
    with pytest.raises(ParameterError, match=part) as exc:
        get("gravity").validate({"base_ties": text})
    assert exc.value.field == "base_ties"


def test_cli_refuses_bad_ties_with_exit_2(tmp_path, capsys):
    out = tmp_path / "o"
    rc = main(["run", "gravity", str(tmp_path / "a.zip"), "--out", str(out), "--set", "base_ties=1,2,3"])
    assert rc == 2
    assert "base_ties" in capsys.readouterr().err
    assert not out.exists()  # nothing partial left behind


def _chain(t0, lat0, lon0, dg_mgal, drift_mgal_per_s=0.0):
    """A chain standing still for 100 s at t0 (a tie's place), with a drift removed by the pipeline."""
    t = np.arange(t0 - 50, t0 + 200, 0.01)
    still = [(t0, t0 + 100.0)]
    drift = drift_mgal_per_s * (t - t[0]) * MGAL
    return {
        "t_s": t,
        "lat": np.full(len(t), lat0),
        "lon": np.full(len(t), lon0),
        "dg_static": np.full(len(t), dg_mgal * MGAL) + drift,
        "drift_mps2": drift,
        "still": still,
    }


def test_a_stop_near_a_tie_observes_it():
    """The tie's σ is the stop's own scatter (block means), here white accelerometer noise of 5 µg/√Hz:
    N/√T over the 96 s used (the stop means from the pipeline's own ``stop_means``, six values), with the
    horizontal-gradient term k·distance in quadrature."""
    lat, lon, h, g = 28.5, 113.0, 120.0, 979150.0
    dg_tie = g - normal_gravity(np.radians(lat), h) / MGAL
    # the stop 10 m north of the tie, its stop mean 20 mGal above the tie's δg (the accelerometer bias)
    dlat = 10.0 / 6.37e6
    ch = _chain(1000.0, np.radians(lat) + dlat, np.radians(lon), dg_tie + 20.0, drift_mgal_per_s=0.001)
    noise_mps2_per_rthz = 5.0e-6 * G0
    rng = np.random.default_rng(3)
    ch["dg_static"] = ch["dg_static"] + noise_mps2_per_rthz * np.sqrt(100.0) * rng.standard_normal(len(ch["t_s"]))
    log = types.SimpleNamespace(manifest=types.SimpleNamespace(imu=types.SimpleNamespace(accel_noise_ug_per_rthz=5.0)))
    ties, unused = observed_ties([ch], [log], [(lat, lon, h, g)], 30.0, (ch["lat"][0], ch["lon"][0]))
    assert unused == [] and len(ties) == 1
    t = ties[0]
    expected_sigma = noise_mps2_per_rthz / np.sqrt(96.0) / MGAL  # 100 s less 2 s at each edge
    assert t.sigma_mgal == pytest.approx(expected_sigma, rel=0.3)  # from ~96 one-second block means
    assert t.tie_mgal == pytest.approx(dg_tie)
    assert t.measured_mgal == pytest.approx(dg_tie + 20.0, abs=4 * expected_sigma)  # the drift removed
    assert t.distance_m == pytest.approx(10.0, rel=0.01)
    # the same stop 400 m from the station: g may differ there by the horizontal gradient, k·d in quadrature
    # (σ² grows by k²·(400² − 10²) exactly: the stop's own scatter is the same)
    far = {**ch, "lat": ch["lat"] + 390.0 / 6.37e6}
    (t_far,), _ = observed_ties([far], [log], [(lat, lon, h, g)], 1000.0, (ch["lat"][0], ch["lon"][0]))
    assert t_far.distance_m == pytest.approx(400.0, rel=0.01)
    k = TIE_GRADIENT_MGAL_PER_M
    assert t_far.sigma_mgal**2 - t.sigma_mgal**2 == pytest.approx(k**2 * (t_far.distance_m**2 - t.distance_m**2))
    assert t_far.sigma_mgal > 2 * expected_sigma  # 2 mGal at 400 m beside the stop's 0.5
    # beyond the radius: not observed, reported as unused
    ties, unused = observed_ties([ch], [log], [(lat, lon, h, g)], 5.0, (ch["lat"][0], ch["lon"][0]))
    assert ties == [] and unused[0]["tie"] == "T1"


@pytest.mark.parametrize("params", [{"base_ties": "28.5,113.0,120,979150"}, {}])
def test_line_levelling_and_the_network_exclude_each_other(params):
    """Levelling moves each log's bias into its lines and the ties would put it back: refused up front."""
    pipe = get("gravity")
    p = pipe.validate({"line_leveling": "bias", **params})
    logs = [object()] if params else [object(), object()]
    with pytest.raises(ParameterError) as e:
        pipe.func(logs, p, lambda *a, **k: None)
    assert e.value.field == "line_leveling"


def test_external_check_against_a_user_grid(tmp_path):
    """A user's δg grid holding the very field the table carries: per-line differences vanish; EGM2008's
    omission error is not claimed for a user grid; a grid not covering the survey is refused."""
    from ldvsurvey.io.gdf import write_gdf
    from ldvsurvey.pipelines.gravity.network import _external_check

    glat, glon = np.arange(28.40, 28.60, 0.005), np.arange(112.95, 113.15, 0.005)

    def field(la, lo):
        return 10.0 * np.sin(np.radians(la - 28.4) * 300) + 5.0 * np.cos(np.radians(lo - 113.0) * 200)

    path = tmp_path / "dg.gdf"
    path.write_bytes(
        write_gdf(glat, glon, field(*np.meshgrid(glat, glon, indexing="ij")), "gravity_disturbance", "mGal")
    )
    la = np.linspace(28.45, 28.55, 200)
    lo = np.linspace(113.0, 113.1, 200)
    table = {
        "lat_deg": la,
        "lon_deg": lo,
        "dg_mgal": field(la, lo),
        "line": np.array(["L1"] * 100 + ["L2"] * 100, dtype=object),
    }
    per_line = [{"name": "L1", "resolution_m": 2000.0}, {"name": "L2", "resolution_m": 2000.0}]
    out = _external_check(table, per_line, "grid", grid_paths=[str(path)])
    assert out["model"] == "dg.gdf" and "omission_note" not in out
    for ln in out["lines"]:
        assert abs(ln["mean_mgal"]) < 0.05 and ln["std_mgal"] < 0.05  # bilinear on a 0.005° grid
    assert np.allclose(table["dg_external_mgal"], table["dg_mgal"], atol=0.1)
    table["lat_deg"] = la + 1.0
    with pytest.raises(ParameterError, match="does not cover") as exc:
        _external_check(table, per_line, "grid", grid_paths=[str(path)])
    assert exc.value.field == "external_grid"


def test_external_check_synthesizes_egm2008_at_the_tracks_height():
    """R4: the external δg is EGM2008's at the tracks' mean height, not on the ellipsoid.

    Truth: −∂T/∂h by a central difference of T = γ·(ζ − ζ₀) from :func:`gravmodel.height_anomaly_m`
    (another sum of the model: the potential, not its radial derivative), at grid nodes (bilinear exact).
    In the Alps at 2500 m the two heights differ by tens of mGal; the difference of the normal from the
    radial direction leaves ~0.3 mGal."""
    from ldvsurvey.nav.gravmodel import ZERO_DEGREE_M, height_anomaly_m
    from ldvsurvey.pipelines.gravity.network import _external_check

    lat = np.array([46.5, 46.5 + 1 / 60, 46.5 + 2 / 60])
    lon = np.array([8.0, 8.0 + 1 / 60, 8.0 + 3 / 60])
    h = np.array([2400.0, 2500.0, 2600.0])  # mean 2500 m
    table = {"lat_deg": lat, "lon_deg": lon, "h_m": h, "dg_mgal": np.zeros(3), "line": ["L1"] * 3}
    out = _external_check(table, [{"name": "L1", "resolution_m": 2000.0}], "egm2008")
    assert out["synthesis_height_m"] == 2500.0
    assert "commission" in out["commission_note"]

    def t_pot(hh):
        return (height_anomaly_m(lat, lon, hh) - ZERO_DEGREE_M) * normal_gravity(np.radians(lat), hh)

    truth = -(t_pot(2502.0) - t_pot(2498.0)) / 4.0 / MGAL
    t0 = -(t_pot(2.0) - t_pot(-2.0)) / 4.0 / MGAL
    assert np.max(np.abs(truth - t0)) > 10.0  # the check can tell the heights apart
    np.testing.assert_allclose(table["dg_external_mgal"], truth, atol=1.0)


def test_dg_and_g_sigma_carry_the_navigated_height_error():
    """R3: δg and Δg = f − γ(h_nav) move by 0.3086 mGal/m · δh (normal gravity's free-air gradient).
    Absolute g = δg + γ(h_nav) does not move, but it is reported at h_nav: the field at the stated height
    differs from the field where it was measured by the same free-air term. Both 1-σ add 0.3086·σ_h in
    quadrature to the adjustment's (``adjustment_sigma_mgal``)."""
    from ldvsurvey.pipelines.gravity.network import _adjusted_table
    from tests.nav.test_network import FIR_S, network, survey

    lines, ties = survey(7)
    _, _, adj = network(lines, ties)
    chains, src = [], []
    for lg in range(3):
        mine = [ln for ln in lines if ln.log == lg]
        t = np.concatenate([ln.t_s for ln in mine])
        e = np.concatenate([ln.e_m for ln in mine])
        n = np.concatenate([ln.n_m for ln in mine])
        chains.append(
            {
                "lat": np.radians(45.0) + n / 6.37e6,
                "lon": np.radians(10.0) + e / 4.5e6,
                "h": np.full(len(t), 300.0),
                # the navigation's height σ grows from 0.1 m to 2.1 m over the day
                "h_sigma_epochs": (np.array([0.0, 5000.0]), np.array([0.1, 2.1])),
            }
        )
        at = 0
        for ln in mine:
            src.append((None, np.arange(at, at + len(ln.t_s))))
            at += len(ln.t_s)
    assert [ln.log for ln in lines] == sorted(ln.log for ln in lines)  # src follows lines' order
    table, per_line = _adjusted_table(lines, src, chains, adj, Lowpass(FIR_S))
    sig_adj = np.concatenate(
        [np.sqrt(ln.sigma_mgal**2 + adj.correction_sigma(ln.log, i, ln.t_s) ** 2) for i, ln in enumerate(lines)]
    )
    sig_h = np.interp(table["t_s"], [0.0, 5000.0], [0.1, 2.1])
    np.testing.assert_allclose(table["adjustment_sigma_mgal"], sig_adj, rtol=1e-9)
    np.testing.assert_allclose(table["h_sigma_m"], sig_h, rtol=1e-9)
    for col in ("sigma_mgal", "g_sigma_mgal"):
        np.testing.assert_allclose(table[col], np.sqrt(sig_adj**2 + (0.3086 * sig_h) ** 2), rtol=2e-3)
    assert np.max(np.sqrt(table["g_sigma_mgal"] ** 2 - sig_adj**2)) > 0.3  # 0.3086 mGal/m · ~1.1 m on the last line
    assert all(pl["g_sigma_mgal"] > pl["adjustment_sigma_mgal"] for pl in per_line)


def test_a_tie_may_carry_its_own_sigma():
    """A fifth value is the 1-σ of the station's g (mGal); four values stay valid (the g taken as exact)."""
    from ldvsurvey.pipelines.gravity.network import DEFAULT_TIE_SIGMA_MGAL, tie_sigmas_mgal

    text = "28.5,113.0,120,979100.5,0.01; 28.6,113.1,130.5,979090"
    assert parse_ties(text) == [(28.5, 113.0, 120.0, 979100.5), (28.6, 113.1, 130.5, 979090.0)]
    assert tie_sigmas_mgal(text) == [0.01, DEFAULT_TIE_SIGMA_MGAL]
    assert get("gravity").validate({"base_ties": text}).base_ties == text


@pytest.mark.parametrize("sigma", ["0", "-0.1", "150", "nan", "x"])
def test_a_bad_tie_sigma_is_refused_naming_the_tie(sigma):
    with pytest.raises(ParameterError, match="tie 2") as exc:
        get("gravity").validate({"base_ties": f"28.5,113.0,120,979100;28.6,113.1,130,979090,{sigma}"})
    assert exc.value.field == "base_ties"
    if sigma in ("0", "-0.1", "150"):
        assert "SIGMA_MGAL" in exc.value.message and "at most 100" in exc.value.message


def test_six_values_are_refused():
    with pytest.raises(ParameterError, match="SIGMA_MGAL"):
        parse_ties("28.5,113.0,120,979100,0.1,7")


def _weighted_network(ties, sigmas):
    """The simulated three-log network (tests/nav/test_network.py) on ``ties`` weighted by the stations' σ."""
    from ldvsurvey.pipelines.gravity.network import tie_rows, weigh_ties
    from tests.nav.test_network import network, survey

    w = weigh_ties(ties, sigmas)
    lines, _ = survey(3, ties=False)
    _, _, adj = network(lines, w)
    return {(r["tie"], r["log"]): r for r in tie_rows(w, adj)}, adj, lines


def _level_error(adj, lines, lg):
    """The log's level over its lines less the simulated one (bias and drift), and its stated 1-σ (mGal)."""
    from tests.nav.test_network import BIASES, DRIFTS, T_REF

    t = np.concatenate([ln.t_s for ln in lines if ln.log == lg])
    a = np.mean(adj._row(lg, None, t), axis=0)
    true = BIASES[lg] + DRIFTS[lg] * (np.mean(t) - T_REF[lg]) / 3600.0
    return float(a @ adj.x - true), float(np.sqrt(a @ adj.cov @ a))


def test_an_imprecise_tie_is_pulled_by_the_network_a_precise_one_holds():
    """Station T1 is 3 mGal off (a poor relative tie), T2 right. Weighted alike, T1 pulls the level of the
    logs standing on it, far beyond the level's stated σ; given its σ (3 mGal, T2 0.01 mGal), its residual
    takes the 3 mGal and the level follows T2 (back at the simulated one within its stated 3σ, which now
    holds the drift known from one precise tie and the repeats only)."""
    from tests.nav.test_network import survey

    _, ties = survey(3)
    bad = [replace(t, tie_mgal=t.tie_mgal + 3.0) if t.name == "T1" else t for t in ties]
    equal_rows, equal, lines = _weighted_network(bad, [0.0, 0.0])
    rows, adj, _ = _weighted_network(bad, [3.0, 0.01])
    for lg in (0, 1):
        err_equal, sig_equal = _level_error(equal, lines, lg)
        err, sig = _level_error(adj, lines, lg)
        assert abs(err_equal) > max(0.8, 3 * sig_equal), (err_equal, sig_equal)  # pulled, and claiming precision
        # T1's error is one unknown of both logs, held only by its 3 mGal: the logs' drift comes from the
        # repeats and that weak prior, so the level is looser than with T1 exact, and stated so
        assert abs(err) < min(3 * sig, abs(err_equal)), (lg, err, sig, err_equal)
        r1, r2 = rows[("T1", f"B{lg + 1}")], rows[("T2", f"B{lg + 1}")]
        # y − δg: the station's g 3 mGal high, within the level's own 3σ at that stop
        assert r1["residual_mgal"] == pytest.approx(-3.0, abs=3 * adj.correction_sigma(lg, None, r1["t_s"])[0])
        assert abs(r1["residual_mgal"]) > 2 * abs(equal_rows[("T1", f"B{lg + 1}")]["residual_mgal"])
        assert abs(r2["residual_mgal"]) < 3 * r2["sigma_mgal"]
        for r, s_g in ((r1, 3.0), (r2, 0.01)):
            assert r["tie_sigma_mgal"] == s_g
            assert r["sigma_mgal"] == pytest.approx(np.hypot(r["stop_sigma_mgal"], s_g), rel=1e-12)


def test_the_datum_sigma_of_a_tied_log_is_that_of_its_stations():
    """One log, no drift: its lines hold no level (they only compare with each other), so its level comes
    from its stations: station S, visited n_S times, gives it with variance Σ_stops σ_stop²/n_S² + σ_g,S²
    (the stop means average down, the station's own g error is one, shared by its visits); the stations
    independently: var = 1/Σ_S 1/(…) (times max(1, σ0²))."""
    from ldvsurvey.nav import network as net
    from ldvsurvey.pipelines.gravity.network import datum_sigma_mgal, weigh_ties
    from tests.nav.test_network import LOWPASS, survey

    lines, ties = survey(3)
    lines = [ln for ln in lines if ln.log == 0]
    ties = [t for t in ties if t.log == 0]
    ties += [
        replace(ties[0], t_s=ties[0].t_s + 200.0 * k, measured_mgal=ties[0].measured_mgal + 0.1 * k) for k in (1, 2)
    ]
    ties = weigh_ties(ties, [0.5, 0.02])  # T1 (σ_g 0.5 mGal) visited three times, T2 (0.02 mGal) once
    groups = net.repeat_groups(lines)
    clusters = [
        c for gi, g in enumerate(groups) for c in net.repeat_clusters(lines, g, gi, 10.0, LOWPASS.correlation_time_s)
    ]
    adj = net.adjust(lines, clusters, ties, 1, drift="none")
    var_station = {}
    for nm in {t.name for t in ties}:
        mine = [t for t in ties if t.name == nm]
        w = sum(1.0 / t.stop_sigma_mgal**2 for t in mine)  # the stops' weighted mean …
        var_station[nm] = 1.0 / w + mine[0].g_sigma_mgal ** 2  # … and the station's error, once
    assert len(ties) > len(var_station)  # a station visited more than once: the case the old weights got wrong
    var = max(1.0, adj.sigma0**2) / sum(1.0 / v for v in var_station.values())
    assert np.sqrt(adj.cov[adj.index["bias:0"], adj.index["bias:0"]]) == pytest.approx(np.sqrt(var), rel=1e-9)
    assert datum_sigma_mgal(adj, lines) == pytest.approx(np.sqrt(var), rel=0.02)  # the lines' mean bias is zero


def test_height_sigma_without_fixes_on_the_line_is_the_filters():
    """σ_h falls back to the navigation filter's where the GNSS cannot say: a SINS/GNSS chain (its filter is
    GNSS-aided), a log without GNSS, a line with too few fixes of the chosen quality."""
    from ldvsurvey.pipelines.gravity.network import MIN_HEIGHT_FIXES, line_height_sigma

    t = np.arange(0.0, 100.0, 0.5)
    ch = {"kind": "ldv", "t_s": t, "h": np.full(len(t), 50.0), "h_sigma_epochs": (np.array([0.0, 100.0]), np.ones(2))}
    gnss = types.SimpleNamespace(t_s=t[::2], h_m=np.full(100, 51.6), fix=np.full(100, 5))
    noise = {"4": types.SimpleNamespace(white_m=0.01, correlated_m=0.02)}
    log = types.SimpleNamespace(
        gnss=gnss,
        manifest=types.SimpleNamespace(gnss=types.SimpleNamespace(lever_arm_m=[0.0, 0.0, 1.6], height_noise=noise)),
    )
    sig, src = line_height_sigma(ch, log, t[10:50], fixes=(4,))  # only float fixes: none of quality 4
    assert np.all(sig == 1.0) and f"fewer than {MIN_HEIGHT_FIXES}" in src
    assert line_height_sigma({**ch, "kind": "gnss"}, log, t, (5,))[1] == "navigation filter"
    assert line_height_sigma(ch, types.SimpleNamespace(gnss=None), t, (5,))[1] == "navigation filter"
    # with fixes: the navigated height a constant 0.3 m off the GNSS one at the IMU, the receiver stating
    # 0.05 m (0.03 white): the line's bias absorbs the constant, σ_h is the receiver's white floor
    gnss.h_m = np.full(100, 51.9)
    log.manifest.gnss.height_noise = {"5": types.SimpleNamespace(white_m=0.03, correlated_m=0.04)}
    sig, src = line_height_sigma(ch, log, t[10:50], fixes=(5,))
    assert sig == pytest.approx(0.03, rel=1e-9) and src.startswith("GNSS fix 5")
    # a wander of RMS 0.3 m about the offset (a whole period on the line's 20 fixes) and one multipath jump
    # of 3 m, which the screen drops as the SINS/GNSS chain does: σ² = 0.3² − 0.05²
    tg = gnss.t_s
    gnss.h_m = 51.9 + 0.3 * np.sqrt(2.0) * np.sin(2 * np.pi * (tg - 5.0) / 20.0)
    gnss.h_m[np.searchsorted(tg, 12.0)] += 3.0
    sig, src = line_height_sigma(ch, log, t[10:50], fixes=(5,), window_s=5.0)
    assert sig == pytest.approx(np.sqrt(0.3**2 * 20 / 19 - 0.05**2), rel=0.05) and "1 screened out" in src


def _graded_stop(grade=0.06, imu_above_mark_m=0.8, lever_up_m=1.2, orthometric_log_zeta=None):
    """A straight road east at 28.2° N falling at ``grade``, driven to x = 0 and stopped there; fixes at 10 Hz
    (RTK fixed) at the antenna ``lever_up_m`` above the IMU, the IMU ``imu_above_mark_m`` above the road.
    Returns (chain, log, lat0 deg, lon0 deg, road height m as a function of x m east)."""
    from ldvsurvey.nav.earth import radii

    lat0, lon0 = 28.2, 112.9
    rm, rn = radii(np.radians(lat0))
    road = lambda x: 99.2 - grade * np.asarray(x, float)  # noqa: E731
    t = np.arange(0.0, 160.0, 0.1)
    x = np.minimum(-500.0 + 5.0 * t, 0.0)  # 5 m/s for 100 s, then 60 s standing at x = 0
    h_imu = road(x) + imu_above_mark_m
    lat = np.full(len(t), np.radians(lat0))
    lon = np.radians(lon0) + x / (rn * np.cos(lat))
    chain = {"t_s": t, "lat": lat, "lon": lon, "h": h_imu, "still": [(100.0, 160.0)], "h_sigma_epochs": None}
    h_gnss = h_imu + lever_up_m - (0.0 if orthometric_log_zeta is None else orthometric_log_zeta)
    gnss = types.SimpleNamespace(
        t_s=t, lat_deg=np.degrees(lat), lon_deg=np.degrees(lon), h_m=h_gnss, fix=np.full(len(t), 4)
    )
    log = types.SimpleNamespace(
        gnss=gnss, manifest=types.SimpleNamespace(gnss=types.SimpleNamespace(lever_arm_m=[0.0, 0.0, lever_up_m]))
    )
    return chain, log, lat0, lon0, road, rn


def test_a_tie_50_m_down_a_6_percent_grade_is_no_false_warning():
    """The mark 50 m beyond the stop down a 6 % grade, the IMU 0.8 m above the road: the tie is 3.8 m
    below the stop's height (the old check, stop height against tie, warned), the geometry explains it."""
    from ldvsurvey.nav.gravmodel import height_anomaly_m
    from ldvsurvey.pipelines.gravity.tieheight import TIE_HEIGHT_WARN_M, check_tie_heights

    chain, log, lat0, lon0, road, rn = _graded_stop()
    lon_tie = lon0 + np.degrees(50.0 / (rn * np.cos(np.radians(lat0))))
    h_mark = float(road(50.0))
    rows = [{"tie": "T1", "log": "B1", "t_s": 130.0}]
    assert check_tie_heights(rows, [(lat0, lon_tie, h_mark, 979000.0)], [chain], [log]) == []
    r = rows[0]
    assert r["height_warning"] is None
    assert abs(h_mark - r["h_gnss_m"]) > TIE_HEIGHT_WARN_M  # what the stop-height check compared, and flagged
    assert r["h_gnss_m"] == pytest.approx(road(0.0) + 0.8, abs=1e-9)  # the lever arm's up part taken off
    assert r["reference_distance_m"] == pytest.approx(50.0, abs=0.5)
    assert r["reference_grade"] == pytest.approx(0.06, rel=1e-6)
    assert r["h_reference_sigma_m"] == pytest.approx(0.05)  # RTK fixed: aids.GNSS_SIGMA's vertical
    # the same mark given as an orthometric height (H = h − ζ) is still flagged, and named as the tie's
    zeta = float(height_anomaly_m(lat0, lon_tie, h_mark)[0])
    rows = [{"tie": "T1", "log": "B1", "t_s": 130.0}]
    warnings = check_tie_heights(rows, [(lat0, lon_tie, h_mark - zeta, 979000.0)], [chain], [log])
    assert len(warnings) == 1 and "T1" in warnings[0]
    assert "tie's height looks orthometric" in warnings[0] and f"ζ = {zeta:+.1f} m" in warnings[0]
    assert "σ 0.05 m" in warnings[0] and "2.40 m" in warnings[0]  # the reference's σ, twice the lever's up
    assert f"{0.3086 * abs(h_mark - zeta - road(0.0) - 0.8):.1f} mGal" in warnings[0]


def test_orthometric_log_heights_are_named_as_the_log_side():
    """The tie right; the log's GGA without a geoid separation (heights above the geoid, h − ζ): the tie
    warning says the log's heights look orthometric, and the gravity summary warns of δg's offset."""
    from ldvsurvey.nav.gravmodel import height_anomaly_m
    from ldvsurvey.pipelines.gravity.tieheight import check_tie_heights, separation_warnings

    zeta = float(height_anomaly_m(28.2, 112.9, 100.0)[0])
    chain, log, lat0, lon0, road, _ = _graded_stop(orthometric_log_zeta=zeta)
    rows = [{"tie": "T1", "log": "B1", "t_s": 130.0}]
    warnings = check_tie_heights(rows, [(lat0, lon0, float(road(0.0)), 979000.0)], [chain], [log])
    assert len(warnings) == 1 and "the log's heights look orthometric" in warnings[0]
    assert rows[0]["h_difference_m"] == pytest.approx(zeta - 0.8, abs=1e-6)
    # the separation: all NaN (an empty GGA field) warns with the size of the error; stated, none
    log.gnss.sep_m = np.full(len(log.gnss.t_s), np.nan)
    (w,) = separation_warnings([log])
    assert "bundle 1" in w and "orthometric" in w and "ellipsoidal heights" in w
    assert f"{-0.3086 * zeta:+.1f} mGal" in w
    log.gnss.sep_m = np.full(len(log.gnss.t_s), zeta)
    assert separation_warnings([log]) == []
