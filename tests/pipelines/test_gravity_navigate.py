"""gravity and navigate on the product's simulator: six repeated 11-km lines, 332 m relief."""

import numpy as np
import pytest

from ldvsurvey.io.drivelog import parse_files
from ldvsurvey.nav.earth import MGAL, enu_offset_m
from ldvsurvey.nav.gravity import Lowpass
from ldvsurvey.pipelines.base import Progress, run_pipeline
from ldvsurvey.pipelines.gravity.chains import ldv_chain
from ldvsurvey.pipelines.navigate import run_navigation
from ldvsurvey.pipelines.registry import get
from ldvsurvey.sim.fields import ConstantField
from ldvsurvey.sim.motion import Static
from ldvsurvey.sim.road import Ramps, Road
from ldvsurvey.sim.scenario import Scenario, bundle_files, simulate
from tests.pipelines.helpers import truth_dg_error_mgal


@pytest.fixture(scope="module")
def gravity_result(gravity_sim):
    _, _, log = gravity_sim
    return run_pipeline(get("gravity"), [log], {"fir_length_s": 150.0})


def test_survey_geometry(gravity_sim):
    sim, _, log = gravity_sim
    assert len(log.manifest.lines) == 6
    assert np.ptp(sim.imu.h_m) > 320
    assert sim.scenario.gravity_field.max_gradient_mgal_per_km() == pytest.approx(3.0)
    assert np.any(sim.gnss_fix == 1) and np.any(sim.gnss_fix == 0)  # GNSS partly degraded


def test_internal_coincidence_and_truth(gravity_sim, gravity_result):
    sim, _, _ = gravity_sim
    s = gravity_result.summary
    assert s["fir_length_s"] <= 200
    assert s["total_mgal"] <= 0.35, s["lines"]
    # lines trimmed by half the FIR length at each end (≈1.1 km at 15 m/s)
    assert s["line_end_trim_s"] == 75.0
    assert len(s["lines"]) == 6 and s["common_length_m"] > 8_000
    assert 500 < s["resolution_m"] < 2000  # half-wavelength beside the figure: v·L/2
    # against the true, equally filtered disturbance, after one constant offset
    g = gravity_result.tables["gravity"]
    e = truth_dg_error_mgal(sim, g, "dg_mgal")
    assert len(e) > 3000  # 6 lines × 583 s after trimming, at 1 Hz
    assert np.std(e) <= 0.5
    # the offset is the (unobservable) vertical accelerometer bias, nothing else
    bias_z_mgal = sim.errors.accel_bias_mps2[2] / MGAL  # δg includes +b_z
    assert np.mean(e) == pytest.approx(bias_z_mgal, abs=1.0)


def test_sins_gnss_comparison_present_and_close(gravity_sim, gravity_result):
    """RTK fixes only, outages bridged or withheld: the SINS/GNSS chain agrees with the truth
    within a few mGal where it reports, and it withholds the long outages (GNSS partly blocked)."""
    sim, _, _ = gravity_sim
    s = gravity_result.summary
    g = s["gnss_comparison"]
    assert g["aiding"] == "gnss" and len(g["lines"]) == 6
    assert g["total_mgal"] > s["total_mgal"]
    assert sum(ln["unsupported_s"] for ln in g["lines"]) > 100.0
    t = gravity_result.tables["gravity"]
    e = truth_dg_error_mgal(sim, t, "dg_sins_gnss_mgal")
    assert len(e) > 1000
    assert np.sqrt(np.mean((e - np.mean(e)) ** 2)) <= 3.0


def test_tables_follow_the_spec(gravity_result):
    g = gravity_result.tables["gravity"]
    # the spec's columns, with the GPS week and seconds of week beside t_s (the log's date is known)
    assert list(g)[:10] == [
        "t_s", "gps_week", "gps_sow_s", "line", "distance_m", "lat_deg", "lon_deg", "h_m", "dg_raw_mgal", "dg_mgal"
    ]  # fmt: skip
    c = gravity_result.tables["coincidence"]
    assert list(c) == ["line", "distance_m", "dg_mgal", "mean_mgal", "residual_mgal"]
    np.testing.assert_allclose(np.asarray(c["dg_mgal"]) - np.asarray(c["mean_mgal"]), c["residual_mgal"])


def test_navigation_within_budget(gravity_sim):
    sim, _, log = gravity_sim
    r = run_pipeline(get("navigate"), [log], {"aiding": "ldv", "output_rate_hz": 10.0})
    tr = r.tables["trajectory"]
    im = sim.imu
    k = np.searchsorted(im.t_s, tr["t_s"])
    d = enu_offset_m(
        im.lat_rad[k], im.lon_rad[k], im.h_m[k], np.radians(tr["lat_deg"]), np.radians(tr["lon_deg"]), tr["h_m"]
    )
    assert np.hypot(d[:, 0], d[:, 1]).max() <= 10.0
    assert np.abs(d[:, 2]).max() <= 3.0
    assert r.summary["smoothed"] is True and r.summary["aiding"] == "ldv"
    assert {"e_sigma_m", "n_sigma_m", "h_sigma_m", "heading_sigma_deg"} <= set(tr)
    # the reported 1-σ is honest: errors mostly within 3σ
    assert np.mean(np.abs(d[:, 2]) <= 3 * tr["h_sigma_m"] + 0.05) > 0.95


def test_vehicle_at_rest_on_plus_10_mgal():
    road = Road(np.radians(28.0), np.radians(113.0), 150.0, 10.0, Ramps(np.radians(30.0)))
    sc = Scenario(
        name="rest",
        road=road,
        segments=[Static(1500.0)],
        static_s=1500.0,
        gravity_field=ConstantField(dg_mgal=10.0),
        gyro_bias_dph=0.003,
        accel_bias_ug=0.0,
        gyro_arw_dprh=0.0005,
        accel_vrw_ug_rthz=2.0,
        fix_schedule=[],
    )
    log = parse_files(bundle_files(simulate(sc, seed=2)))
    params = get("gravity").validate({"calibration": "nominal"})
    inp, setup, sol = run_navigation(log, params, Progress(), aiding="ldv")
    ch = ldv_chain(inp, sol, setup)
    dg = Lowpass(150.0, ch["fs"]).apply(ch["dg"]) / MGAL
    mid = dg[len(dg) // 4 : 3 * len(dg) // 4]
    assert np.nanmean(mid) == pytest.approx(10.0, abs=0.1)
