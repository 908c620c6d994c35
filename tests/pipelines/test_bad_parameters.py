"""Bad parameters exit 2 with a message saying what is missing."""

import json

import numpy as np
import pytest

from ldvsurvey.cli import main
from ldvsurvey.io.writers import imu_csv, write_bundle
from ldvsurvey.sim.scenario import bundle_files, simulate


@pytest.fixture(scope="module")
def rotating_bundle(short_height_sim, tmp_path_factory):
    sim = simulate(short_height_sim, seed=3)
    files = bundle_files(sim)
    return sim, files, write_bundle(files, tmp_path_factory.mktemp("rot") / "b")


def _run(args, capsys):
    rc = main(args)
    return rc, capsys.readouterr().err


def test_calibration_window_outside_the_log(rotating_bundle, tmp_path, capsys):
    _, _, path = rotating_bundle
    rc, err = _run(["run", "calibrate", str(path), "--out", str(tmp_path), "--set", "calibration_window=1,2"], capsys)
    assert rc == 2 and "calibration_window" in err and "not inside the log" in err


def test_unknown_and_malformed_parameters(rotating_bundle, tmp_path, capsys):
    _, _, path = rotating_bundle
    rc, err = _run(["run", "height", str(path), "--out", str(tmp_path), "--set", "fir=3"], capsys)
    assert rc == 2 and "unknown parameter" in err
    rc, err = _run(["run", "height", str(path), "--out", str(tmp_path), "--set", "ldv_scale=abc"], capsys)
    assert rc == 2 and "ldv_scale" in err
    rc, err = _run(["run", "nosuch", str(path), "--out", str(tmp_path)], capsys)
    assert rc == 2 and "unknown pipeline" in err


def test_no_gnss_for_calibration(rotating_bundle, tmp_path, capsys):
    _, files, _ = rotating_bundle
    nognss = {k: v for k, v in files.items() if k != "gnss.nmea"}
    path = write_bundle(nognss, tmp_path / "nognss")
    rc, err = _run(["run", "calibrate", str(path), "--out", str(tmp_path / "o")], capsys)
    assert rc == 2 and "GNSS" in err and "gnss.nmea" in err


def test_tilt_on_a_fixed_imu(rotating_bundle, tmp_path, capsys):
    sim, files, _ = rotating_bundle
    m = json.loads(files["manifest.json"])
    m["imu"]["rotating"] = False
    fixed = dict(
        files,
        **{"manifest.json": json.dumps(m).encode(), "imu.csv": imu_csv(sim.imu.t_s, sim.dtheta_rad, sim.dvel_mps)},
    )
    path = write_bundle(fixed, tmp_path / "fixed")
    rc, err = _run(["run", "tilt", str(path), "--out", str(tmp_path / "o")], capsys)
    assert rc == 2 and "rotating IMU" in err


def test_tilt_without_any_rotation(rotating_bundle, tmp_path, capsys):
    sim, files, _ = rotating_bundle
    still = dict(files, **{"imu.csv": imu_csv(sim.imu.t_s, sim.dtheta_rad, sim.dvel_mps, np.zeros(len(sim.imu.t_s)))})
    path = write_bundle(still, tmp_path / "still")
    rc, err = _run(["run", "tilt", str(path), "--out", str(tmp_path / "o")], capsys)
    assert rc == 2 and "no rotation" in err


@pytest.fixture(scope="module")
def small_bundles(tmp_path_factory):
    """Small random-content bundles (no physics: the door is checked before any sample is used)."""
    import copy

    from tests.bundles import MANIFEST, make_bundle

    root = tmp_path_factory.mktemp("small")
    one_line = copy.deepcopy(MANIFEST)
    one_line["lines"] = [{"name": "L1", "t_start": 30001.0, "t_end": 30009.0}]
    return {
        "fixed": write_bundle(make_bundle(seed=11, n_imu=1000), root / "fixed"),
        "nognss": write_bundle(make_bundle(seed=12, n_imu=1000, gnss=False), root / "nognss"),
        "lined": write_bundle(make_bundle(seed=13, n_imu=1000, manifest=one_line), root / "lined"),
    }


@pytest.mark.parametrize(
    "pipeline,key,value",
    [
        ("gravity", "fir_length_s", "-5"),
        ("gravity", "fir_length_s", "0"),
        ("tilt", "output_rate_hz", "0"),
        ("dov", "degree", "-1"),
        ("dov", "degree", "100000"),
        ("height", "ldv_scale", "-3"),
        ("height", "ldv_scale", "nan"),
        ("dov", "interpolation", "cubic"),
        ("navigate", "smooth", "maybe"),
        ("damping", "period_s", "-1"),
        ("gravity", "lines", "9-3"),
        ("calibrate", "calibration_window", "5"),
    ],
)
def test_cli_out_of_range_exits_2_naming_the_key(small_bundles, tmp_path, capsys, pipeline, key, value):
    rc, err = _run(
        ["run", pipeline, str(small_bundles["fixed"]), "--out", str(tmp_path), "--set", f"{key}={value}"], capsys
    )
    assert rc == 2 and f"'{key}'" in err, err
    assert not any(tmp_path.iterdir())  # nothing written


@pytest.mark.parametrize(
    "bundle,pipeline,sets,why",
    [
        ("fixed", "tilt", [], "rotating IMU"),
        ("fixed", "damping", [], "vessels"),
        ("fixed", "height", ["output_rate_hz=500"], "above the IMU rate"),
        ("nognss", "dov", [], "gnss.nmea"),
        ("nognss", "navigate", ["aiding=gnss"], "gnss.nmea"),
        ("lined", "gravity", [], "fewer than two survey lines"),
    ],
)
def test_cli_inapplicable_pipeline_exits_2_saying_why(small_bundles, tmp_path, capsys, bundle, pipeline, sets, why):
    args = ["run", pipeline, str(small_bundles[bundle]), "--out", str(tmp_path)]
    for s in sets:
        args += ["--set", s]
    rc, err = _run(args, capsys)
    assert rc == 2 and why in err, err
    assert not any(tmp_path.iterdir())
