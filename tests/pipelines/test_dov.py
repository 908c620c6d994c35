"""dov on the DOV paper's simulation: 315 km due north at 25 m/s with EGM2008 as the true field."""

import numpy as np
import pytest

from ldvsurvey.errors import ParameterError
from ldvsurvey.io.drivelog import parse_files
from ldvsurvey.io.gdf import write_gdf
from ldvsurvey.io.writers import imu_csv
from ldvsurvey.nav.sim import catalog
from ldvsurvey.nav.sim.scenario import bundle_files, simulate
from ldvsurvey.pipelines.base import run_pipeline
from ldvsurvey.pipelines.registry import get


@pytest.fixture(scope="module")
def dov_run(tmp_path_factory):
    sc = catalog.dov()
    sim = simulate(sc, seed=3, with_nodov=True)
    d = tmp_path_factory.mktemp("dov")
    nodov = d / "imu_nodov.csv"
    nodov.write_bytes(imu_csv(sim.imu.t_s, *sim.imu_nodov))
    log = parse_files(bundle_files(sim))
    res = run_pipeline(get("dov"), [log], {"imu_nodov": str(nodov), "compensation_updates_s": "0.03,3"})
    return sc, sim, log, res, d


@pytest.mark.slow
def test_paper_setup_and_magnitudes(dov_run):
    sc, sim, _, res, _ = dov_run
    s = res.summary
    north_km = (sim.imu.lat_rad[-1] - sim.imu.lat_rad[0]) * 6.37e6 / 1000
    assert 310 < north_km < 320 and np.ptp(np.degrees(sim.imu.lon_rad)) < 1e-6
    th = s["methods"]["theoretical"]
    # the paper (EIGEN-6C4): 851.85 m north, 514.43 m east; EGM2008 is not the same model
    assert 300 < abs(th["max_north_m"]) < 2500 and 200 < abs(th["max_east_m"]) < 2000
    lo, hi = s["xi_range_arcsec"]
    assert -40 < lo < 0 < hi < 40


@pytest.mark.slow
def test_rk4_within_5_percent_of_theoretical(dov_run):
    s = dov_run[3].summary["methods"]
    assert abs(s["rk4"]["north_deviation_pct"]) <= 5 and abs(s["rk4"]["east_deviation_pct"]) <= 5
    assert "north_deviation_pct" in s["direct"]
    tab = dov_run[3].tables["dov"]
    # the whole curves, not only the maxima, follow the two-mechanization error
    scale = np.abs(tab["dn_theoretical_m"]).max()
    assert np.abs(tab["dn_rk4_m"] - tab["dn_theoretical_m"]).max() < 0.05 * scale


@pytest.mark.slow
def test_compensation_residual_decreases(dov_run):
    comp = dov_run[3].summary["compensation"]
    table = {(c["grid_step_arcmin"], c["update_s"]): c["max_residual_m"] for c in comp}
    steps = sorted({k[0] for k in table})
    updates = sorted({k[1] for k in table})
    for u in updates:
        vals = [table[(st, u)] for st in steps]
        assert all(a < b for a, b in zip(vals, vals[1:])), (u, vals)
    for st in steps:
        vals = [table[(st, u)] for u in updates]
        assert all(a < b for a, b in zip(vals, vals[1:])), (st, vals)
    th = dov_run[3].summary["methods"]["theoretical"]
    assert table[(1.0, 0.03)] < 0.01 * abs(th["max_north_m"])  # compensation removes the DOV error


@pytest.mark.slow
def test_gdf_grids_and_coverage(dov_run):
    sc, sim, log, res, d = dov_run
    g = sc.gravity_field.grid
    (d / "xi.gdf").write_bytes(write_gdf(g.lat_deg, g.lon_deg, g.xi_arcsec, "deflection_xi", "arcsec"))
    (d / "eta.gdf").write_bytes(write_gdf(g.lat_deg, g.lon_deg, g.eta_arcsec, "deflection_eta", "arcsec"))
    r2 = run_pipeline(get("dov"), [log], {"dov_grid": f"{d / 'xi.gdf'},{d / 'eta.gdf'}", "compensation": "false"})
    a, b = res.summary["max_north_error_m"], r2.summary["max_north_error_m"]
    assert b["rk4"] == pytest.approx(a["rk4"], rel=0.02)
    assert "theoretical" in r2.summary["methods"] and r2.warnings  # compensated vs uncompensated, said so
    # a grid that stops short of the track
    k = g.lat_deg < 35.5
    (d / "xi2.gdf").write_bytes(write_gdf(g.lat_deg[k], g.lon_deg, g.xi_arcsec[k], "deflection_xi", "arcsec"))
    (d / "eta2.gdf").write_bytes(write_gdf(g.lat_deg[k], g.lon_deg, g.eta_arcsec[k], "deflection_eta", "arcsec"))
    with pytest.raises(ParameterError, match="does not cover the track"):
        run_pipeline(get("dov"), [log], {"dov_grid": f"{d / 'xi2.gdf'},{d / 'eta2.gdf'}", "compensation": "false"})
