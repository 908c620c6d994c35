"""The simulator against an independent one (python-ins' pyins.sim) on the same trajectory."""

import numpy as np
import pytest

from ldvsurvey.nav.earth import normal_gravity
from ldvsurvey.sim import catalog
from ldvsurvey.sim.imu import rates, simulate_imu
from ldvsurvey.sim.motion import Motion

pyins_sim = pytest.importorskip("pyins.sim")
pyins_tr = pytest.importorskip("pyins.transform")
pyins_earth = pytest.importorskip("pyins.earth")

# ENU <-> NED and RFU <-> FRD swap the first two axes and flip the third
P = np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]])
DT = 0.01


def _drive():
    """A 6-min drive's motion and its IMU times every DT s."""
    sc = catalog.drive(minutes=6, static_s=20)
    m = Motion(sc.road, sc.segments, sc.t0_s)
    n = int(round((m.t_end_s - m.t0_s) / DT))
    return sc, m, m.t0_s + np.arange(n + 1) * DT


def _pyins(m, t, c_bt):
    """pyins' increments (gyro, accel; RFU) for the body attitude and trajectory of our simulator."""
    _, _, tr, c_bn, _, _, _ = rates(m, t, c_bt)
    rph = pyins_tr.mat_to_rph(P @ c_bn @ P.T)
    lla = np.column_stack([np.degrees(tr["lat_rad"]), np.degrees(tr["lon_rad"]), tr["h_m"]])
    _, imu = pyins_sim.generate_imu(t - t[0], lla, rph, tr["v_n"] @ P.T, sensor_type="increment")
    return imu[["gyro_x", "gyro_y", "gyro_z"]].values[1:] @ P.T, imu[["accel_x", "accel_y", "accel_z"]].values[1:] @ P.T


def _gravity_difference(ours):
    """pyins' normal gravity keeps only the first-order height term: its difference to ours, as Δv (RFU) per DT."""
    lat, h = ours.lat_rad, ours.h_m
    sl2 = np.sin(lat) ** 2
    g_pyins = (
        pyins_earth.GE * (1 + pyins_earth.F * sl2) / np.sqrt(1 - pyins_earth.E2 * sl2) * (1 - 2 * h / pyins_earth.A)
    )
    return np.einsum("kji,kj->ki", ours.c_bn, np.column_stack([0 * h, 0 * h, (g_pyins - normal_gravity(lat, h)) * DT]))


def test_increments_match_pyins():
    sc, m, t = _drive()
    c_bt = sc.ldv.c_bt()
    ours = simulate_imu(m, t, c_bt)
    gyro, acc = _pyins(m, t, c_bt)
    # angular increments: the two simulators agree to 1e-10 rad per 10 ms
    assert np.abs(gyro - ours.dtheta_rad).max() < 1e-10
    # specific force, but for pyins' first-order normal gravity
    assert np.abs(acc - ours.dvel_mps - _gravity_difference(ours)).max() < 2e-9  # 0.02 µg·s per increment


def test_increments_match_pyins_with_body_attitude():
    """The body-attitude effect (stance, crab, squat, roll in curves, 1–2 Hz bounce) makes the body
    rates differ from the travel frame's; pyins, given the same body attitude, agrees."""
    from ldvsurvey.sim.body import BodyModel
    from ldvsurvey.sim.effects import DEG, BodyAttitude

    _, m, t = _drive()
    spec = BodyAttitude(
        stance_pitch_rad=0.4 * DEG,
        crab_rad=-0.3 * DEG,
        squat_rad_per_g=2.5 * DEG,
        roll_rad_per_g=2.0 * DEG,
        bounce_rad=0.05 * DEG,
        bounce_hz=(1.4, 1.9),
    )
    body = BodyModel(spec, m, 0.35 * np.pi / 180, -0.25 * np.pi / 180, np.random.default_rng(1))
    ours = simulate_imu(m, t, body)
    rigid = simulate_imu(m, t, body.c_db.T)
    # the effect is far above the comparison tolerance
    assert np.abs(ours.dtheta_rad - rigid.dtheta_rad).max() > 1e-5
    gyro, acc = _pyins(m, t, body)
    dg = np.abs(gyro - ours.dtheta_rad).max()
    da = np.abs(acc - ours.dvel_mps - _gravity_difference(ours)).max()
    print(f"max |Δθ| {dg:.2e} rad, max |Δv| {da:.2e} m/s per 10 ms")
    assert dg < 1e-9 and da < 1e-8
