"""Bad parameters exit 2 with a message saying what is missing."""

import json

import numpy as np
import pytest

from ldvsurvey.cli import main
from ldvsurvey.io.writers import imu_csv, write_bundle
from ldvsurvey.nav.sim.scenario import bundle_files, simulate


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
    fixed = dict(files, **{"manifest.json": json.dumps(m).encode(),
                           "imu.csv": imu_csv(sim.imu.t_s, sim.dtheta_rad, sim.dvel_mps)})
    path = write_bundle(fixed, tmp_path / "fixed")
    rc, err = _run(["run", "tilt", str(path), "--out", str(tmp_path / "o")], capsys)
    assert rc == 2 and "rotating IMU" in err


def test_tilt_without_any_rotation(rotating_bundle, tmp_path, capsys):
    sim, files, _ = rotating_bundle
    still = dict(files, **{"imu.csv": imu_csv(sim.imu.t_s, sim.dtheta_rad, sim.dvel_mps,
                                              np.zeros(len(sim.imu.t_s)))})
    path = write_bundle(still, tmp_path / "still")
    rc, err = _run(["run", "tilt", str(path), "--out", str(tmp_path / "o")], capsys)
    assert rc == 2 and "no rotation" in err
