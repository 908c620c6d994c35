"""The combined floor (white noise + the manifest's accelerometer drift after the same processing)
against the coincidence measured on simulated drives whose accelerometer drifts (realistic effects,
in-run IMU errors on), three short repeated lines, two seeds.

Bounds from the physics: the coincidence of a drive is one draw of a statistic whose expectation
the floor is; the Monte Carlo gives its spread (``drift_mgal_spread``). The measurement must lie
within 3 spreads below the combined floor and, above it, within the drift-free excess the chain
shows (≤ 1.3× the white floor on these drives, docs/accuracy.md) plus 3 spreads.
"""

import numpy as np
import pytest

from ldvsurvey.io.drivelog import parse_files
from ldvsurvey.nav.sim import catalog
from ldvsurvey.nav.sim.scenario import bundle_files, simulate
from ldvsurvey.pipelines.base import run_pipeline
from ldvsurvey.pipelines.registry import get


@pytest.mark.parametrize("seed", [2, 5])
def test_coincidence_within_the_combined_floor(seed):
    sim = simulate(catalog.realistic_gravity(seed=seed, n_lines=3, line_km=4.0))
    log = parse_files(bundle_files(sim))
    assert log.manifest.imu.accel_bias_instability_ug > 0  # the simulator states what it simulates
    s = run_pipeline(get("gravity"), [log], {"fir_length_s": 150.0}).summary
    nf = s["noise_floor"]
    white, drift, comb, spread = nf["total_mgal"], nf["drift_mgal"], nf["combined_mgal"], nf["drift_mgal_spread"]
    assert drift is not None and abs(comb - np.hypot(white, drift)) < 1e-9
    lo = comb - 3 * spread
    hi = np.hypot(1.3 * white, drift) + 3 * spread
    assert lo <= s["total_mgal"] <= hi, (s["total_mgal"], white, drift, spread)
