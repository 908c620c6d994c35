"""calibrate, tilt and height on the product's simulator with the height paper's setup."""

import json

import numpy as np
import pytest

from ldvsurvey.cli import main
from ldvsurvey.io.drivelog import parse_files
from ldvsurvey.io.writers import write_bundle
from ldvsurvey.pipelines.base import run_pipeline
from ldvsurvey.pipelines.registry import get
from ldvsurvey.sim.scenario import bundle_files, simulate
from tests.pipelines.helpers import truth_height

ARCSEC = np.pi / 180 / 3600


@pytest.fixture(scope="module")
def results(height_sim):
    sim, files, log = height_sim
    # the simulated world of these scenarios has no deflection of the vertical
    return {
        name: run_pipeline(get(name), [log], {} if name == "tilt" else {"dov": "none"})
        for name in ("tilt", "calibrate", "height")
    }


def test_tilt_angles_and_oscillation(height_sim, results):
    sim, _, _ = height_sim
    s = results["tilt"].summary
    assert abs(s["alpha_rad"] - sim.scenario.alpha_rad) < 2e-5
    assert abs(s["beta_rad"] - sim.scenario.beta_rad) < 2e-5
    assert s["pitch_oscillation_after_rad"] <= 0.2 * s["pitch_oscillation_before_rad"]
    assert s["roll_oscillation_after_rad"] <= 0.2 * s["roll_oscillation_before_rad"]
    # the oscillation before compensation is the tilt itself: peak-to-peak ≈ 2·sqrt(α² + β²)
    amp = np.hypot(sim.scenario.alpha_rad, sim.scenario.beta_rad)
    assert 1.0 * amp < s["pitch_oscillation_before_rad"] < 2.5 * amp
    att = results["tilt"].tables["attitude"]
    truth_p = np.degrees(np.interp(att["t_s"], sim.imu.t_s, np.arcsin(sim.imu.c_bn[:, 2, 1])))
    assert np.abs(att["pitch_deg"] - truth_p).max() < np.abs(att["pitch_raw_deg"] - truth_p).max() / 5


def test_calibration_recovers_mounting_and_scale(height_sim, results):
    sim, _, _ = height_sim
    s = results["calibrate"].summary
    ldv = sim.scenario.ldv
    assert abs(np.radians(s["ldv_pitch_deg"]) - ldv.pitch_rad) < 10 * ARCSEC
    assert abs(np.radians(s["ldv_heading_deg"]) - ldv.heading_rad) < 10 * ARCSEC
    assert abs(s["ldv_scale"] - ldv.scale) < 1e-4
    for k in ("ldv_pitch_deg_sigma", "ldv_heading_deg_sigma", "ldv_scale_sigma"):
        assert 0 < s[k] < 1
    a, b = s["segment_t_s"]
    assert b - a > 600  # the longest good stretch, not a sliver
    track = results["calibrate"].tables["calibration_track"]
    k = (sim.imu.t_s >= a) & (sim.imu.t_s <= b)
    lat_t = np.interp(track["t_s"], sim.imu.t_s[k], np.degrees(sim.imu.lat_rad[k]))
    assert np.abs(track["lat_deg"] - lat_t).max() * 111e3 < 5.0  # calibrated dead reckoning stays on track


def test_height_accuracy_and_tilt_effect(height_sim, results):
    sim, _, _ = height_sim
    r = results["height"]
    h = r.tables["height"]
    err = h["h_m"] - truth_height(sim, h["t_s"])
    err_raw = h["h_uncompensated_m"] - truth_height(sim, h["t_s"])
    assert np.std(err) <= 0.3 and np.abs(err).max() <= 1.0
    assert np.std(err_raw) > 3 * np.std(err)  # visibly worse without tilt compensation
    s = r.summary
    # against GNSS (fix 4/2, whose simulated σ_v is 0.03/0.9 m) the figures include the reference noise
    assert s["n_reference"] > 2000 and s["std_error_m"] <= 0.3
    fix4 = h["fix_quality"] == 4
    e4 = (h["h_m"] - h["h_gnss_m"])[fix4 & np.isfinite(h["h_gnss_m"])]
    assert np.abs(e4).max() <= 1.0
    assert len(h["t_s"]) >= 0.99 * len(sim.ldv_t_s)  # 100 Hz output


def test_fd_hz_gives_the_same_height(short_height_sim, tmp_path):
    sc = short_height_sim
    sims = [simulate(sc, seed=5)]
    sc_fd = type(sc)(**{**sc.__dict__, "ldv_fd": True})
    sims.append(simulate(sc_fd, seed=5))
    params = {"ldv_pitch_deg": 0.35, "ldv_heading_deg": -0.25, "ldv_scale": 1.0015, "dov": "none"}
    outs = []
    for sim in sims:
        files = bundle_files(sim)
        log = parse_files(files)
        outs.append(run_pipeline(get("height"), [log], params).tables["height"]["h_m"])
    assert "fd_hz" in bundle_files(sims[1])["ldv.csv"].decode().splitlines()[1]
    assert np.abs(outs[0] - outs[1]).max() <= 1e-3


def test_cli_run_writes_spec_files(short_height_sim, tmp_path, capsys):
    sim = simulate(short_height_sim, seed=2)
    path = write_bundle(bundle_files(sim), tmp_path / "b")
    assert main(["run", "tilt", str(path), "--out", str(tmp_path / "o")]) == 0
    s = json.loads((tmp_path / "o" / "summary.json").read_text())
    for k in (
        "pipeline",
        "format_version",
        "inputs",
        "parameters",
        "software_version",
        "started_at",
        "elapsed_s",
        "warnings",
        "alpha_rad",
        "beta_rad",
        "alpha_rad_sigma",
    ):
        assert k in s
    assert s["parameters"]["output_rate_hz"] == 10.0
    hdr = (tmp_path / "o" / "attitude.csv").read_text().splitlines()[0]
    # the spec's columns, GPS week and seconds of week beside t_s (the log's date is known)
    assert hdr == "t_s,gps_week,gps_sow_s,turntable_deg,pitch_raw_deg,roll_raw_deg,pitch_deg,roll_deg,heading_deg"
