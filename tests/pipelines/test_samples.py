"""The independent producer's samples (format conformance, no truth given): every pipeline they
fit processes them, and the numbers are physically meaningful, not merely finite.

Bounds from the physics of the instruments the manifests describe, not from the outputs:
- a turntable's base tilt is machined to arc-minutes (|α|, |β| ≤ 1e-3 rad), and five static minutes
  of a 0.0005°/√h gyro pin it well inside the 2e-5 rad acceptance; compensating it must remove the
  attitude oscillation with the turntable angle (at least ×10);
- an LDV is mounted by hand to within a degree or two of its nominal axis; its scale differs from
  nominal by the optics' tolerance (≤ 1 %); the body's pitch compliance is 1–3°/g (≤ 5°/g);
- LDV/INS heights agree with RTK-fixed GNSS (σ_v ≈ 3 cm) within the issue's acceptance
  (std ≤ 0.15 m, max ≤ 0.5 m) on an 8-minute log;
- the delayed-state damping's velocity agrees with GNSS within 3× the water-LDV sample σ and its
  scale is the optics' (≤ 1 %), while the conventional damping absorbs the current.
"""

import numpy as np
import pytest

from ldvsurvey.io.drivelog import load_bundle
from ldvsurvey.pipelines.base import run_pipeline
from ldvsurvey.pipelines.registry import get
from tests.helpers.samples import sample_zip

G = 9.80665
DEG = np.pi / 180


def _run(sample, pipeline, params=None):
    path = sample_zip(sample)
    res = run_pipeline(get(pipeline), [load_bundle(path)], params or {})
    for cols in res.tables.values():
        assert len(next(iter(cols.values()))) > 100
    return res.summary


def test_rotating_sample_tilt_is_small_observable_and_compensates():
    s = _run("rotating-imu-1d-ldv-8min", "tilt")
    assert s["tilt_observable"]
    assert abs(s["alpha_rad"]) <= 1e-3 and abs(s["beta_rad"]) <= 1e-3
    assert 0 < s["alpha_rad_sigma"] <= 2e-5 and 0 < s["beta_rad_sigma"] <= 2e-5
    assert s["pitch_oscillation_after_rad"] < 0.1 * s["pitch_oscillation_before_rad"]
    assert s["roll_oscillation_after_rad"] < 0.1 * s["roll_oscillation_before_rad"]


@pytest.mark.parametrize("sample", ["rotating-imu-1d-ldv-8min", "fixed-imu-2d-ldv-8min"])
def test_sample_calibration_is_a_plausible_mounting(sample):
    s = _run(sample, "calibrate")
    # nominal mounting 0°, 0°, scale 1 in both manifests
    assert abs(s["ldv_pitch_deg"]) <= 2.0 and abs(s["ldv_heading_deg"]) <= 2.0
    assert abs(s["ldv_scale"] - 1.0) <= 0.01
    assert 0 < s["ldv_pitch_deg_sigma"] < 0.05 and 0 < s["ldv_heading_deg_sigma"] < 0.05
    assert 0 < s["ldv_scale_sigma"] < 1e-3
    assert abs(s["ldv_pitch_compliance_deg_per_g"]) <= 5.0
    if "ldv_scale_up" in s:
        assert abs(s["ldv_scale_up"] - 1.0) <= 0.05


@pytest.mark.parametrize("sample", ["rotating-imu-1d-ldv-8min", "fixed-imu-2d-ldv-8min"])
def test_sample_height_agrees_with_rtk(sample):
    s = _run(sample, "height")
    assert s["n_reference_fix4"] > 100
    assert s["std_error_m_fix4"] <= 0.15 and abs(s["max_error_m_fix4"]) <= 0.5


def test_vessel_sample_damping_velocity_consistent():
    s = _run("vessel-water-ldv-8min", "damping")
    d = s["delayed_state"]
    assert d["rms_velocity_error_mps"] <= 3 * 0.05
    assert abs(s["ldv_scale_estimate"]["delayed_state"] - 1.0) <= 0.01
    assert d["rms_position_error_m"] <= s["conventional"]["rms_position_error_m"]
