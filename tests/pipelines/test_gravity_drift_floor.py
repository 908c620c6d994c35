"""The drift term of the floor against the simulator's true drift on drifting drives (realistic
effects, in-run IMU errors on; three short repeated lines, two seeds).

The simulator's true Gauss-Markov z-accelerometer drift (never seen by the pipeline) is put through
the pipeline's own stop tie, FIR, lines and coincidence: its coincidence is one draw of the statistic
whose RMS expectation ``noise_floor.drift_mgal`` is, with the Monte Carlo spread
``drift_mgal_spread``; it must lie within 3 spreads. The measured coincidence must not fall below
the combined floor by more than 3 spreads (it is a floor; other in-run errors only add to it).
"""

import numpy as np
import pytest

from ldvsurvey.io.drivelog import parse_files
from ldvsurvey.nav.gravity import Lowpass
from ldvsurvey.pipelines.base import run_pipeline
from ldvsurvey.pipelines.gravity.chains import ldv_chain
from ldvsurvey.pipelines.gravity.drift import drift_correction
from ldvsurvey.pipelines.gravity.pipeline import navigation_log
from ldvsurvey.pipelines.gravity.report import evaluate
from ldvsurvey.pipelines.navigate import run_navigation
from ldvsurvey.pipelines.registry import get
from ldvsurvey.sim import catalog
from ldvsurvey.sim.scenario import bundle_files, simulate

FIR_S = 150.0


@pytest.mark.parametrize("seed", [2, 5])
def test_drift_floor_matches_the_true_drift(seed):
    sim = simulate(catalog.realistic_gravity(seed=seed, n_lines=3, line_km=4.0))
    log = parse_files(bundle_files(sim))
    assert log.manifest.imu.accel_bias_instability_ug > 0  # the simulator states its datasheet drift
    s = run_pipeline(get("gravity"), [log], {"fir_length_s": FIR_S}).summary
    nf = s["noise_floor"]
    white, drift, comb, spread = nf["total_mgal"], nf["drift_mgal"], nf["combined_mgal"], nf["drift_mgal_spread"]
    bridges = nf.get("imu_bridge_mgal") or 0.0  # lost IMU rows' term (issue 29), in quadrature
    assert drift is not None and abs(comb - np.sqrt(white**2 + drift**2 + bridges**2)) < 1e-9
    assert s["total_mgal"] >= comb - 3 * spread
    # the true drift through the same processing
    params = get("gravity").validate({})
    inp, setup, sol = run_navigation(navigation_log(log), params, lambda *a, **k: None, aiding="ldv", smooth=True)
    ch = ldv_chain(inp, sol, setup)
    bz = np.interp(ch["t_s"], sim.imu.t_s, sim.extras["imu_errors"]["accel_gm_mps2"][:, 2])
    ch.update(dg=bz.copy(), dg_static=bz.copy(), still=inp.still)
    b, rep = drift_correction(ch, ch["still"], log.manifest.imu.accel_noise_ug_per_rthz, "stops")
    assert (rep["method"] == "repeated stops") == (s["drift_correction"]["method"] == "repeated stops")
    if b is not None and s["drift_correction"]["method"] == "repeated stops":
        ch["dg"] = ch["dg"] - b
    lines = [(n, 0, a, b_) for n, a, b_ in sim.scenario.lines]
    true_drift = evaluate([ch], lines, Lowpass(FIR_S), 10.0, FIR_S / 2).coincidence.total
    assert abs(true_drift - drift) <= 3 * spread, (true_drift, drift, spread)
