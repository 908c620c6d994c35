"""Body attitude over the travel direction: stance, squat, roll in curves, bounce, and what the
LDV and IMU see of them, checked against the effect's specification from the generated data."""

import numpy as np
import pytest

from ldvsurvey.nav.attitude import c_bn_from_euler, euler_from_c_bn
from ldvsurvey.nav.errmodel import c_db
from ldvsurvey.sim import catalog
from ldvsurvey.sim import truth as TR
from ldvsurvey.sim.effects import DEG, BodyAttitude, Effects
from ldvsurvey.sim.scenario import effective_travel_direction, mean_travel_direction, simulate
from ldvsurvey.sim.sensors import ldv_measure

G0 = 9.80665
SPEC = BodyAttitude(
    stance_pitch_rad=0.3 * DEG,
    crab_rad=-0.25 * DEG,
    squat_rad_per_g=2.0 * DEG,
    roll_rad_per_g=2.5 * DEG,
    bounce_rad=0.04 * DEG,
    bounce_hz=(1.3, 1.8),
)


@pytest.fixture(scope="module")
def sim():
    eff = Effects.ideal().with_(body_attitude=SPEC)
    sc = catalog.realistic_drive(seed=5, effects=eff, minutes=4, static_s=20)
    sc.gyro_arw_dprh = 0.0
    return simulate(sc)


def test_travel_direction_is_the_velocity_in_body_axes(sim):
    """The truth's effective LDV direction equals C_n^b v_n / |v| from the true attitude and velocity."""
    im = sim.imu
    moving = np.linalg.norm(im.v_n, axis=1) > 2.0
    pitch, roll, heading = euler_from_c_bn(im.c_bn[moving])
    c_bn = c_bn_from_euler(pitch, roll, heading)
    u = np.einsum("kji,kj->ki", c_bn, im.v_n[moving])
    u /= np.linalg.norm(u, axis=1)[:, None]
    p, h = effective_travel_direction(sim, im.t_s[moving])
    np.testing.assert_allclose(p, np.arcsin(u[:, 2]), atol=1e-9)
    np.testing.assert_allclose(h, np.arctan2(-u[:, 0], u[:, 1]), atol=1e-9)
    # on average it is the mounting moved by stance and crab (small angles), not the mounting:
    # nose-up stance puts the travel below the body's forward axis; the crab is a clockwise heading
    # of the body, while the mounting angle φ counts counter-clockwise (x = −sin φ)
    m = mean_travel_direction(sim)
    ldv = sim.scenario.ldv
    assert abs(m["pitch_rad"] - (ldv.pitch_rad - SPEC.stance_pitch_rad)) < 0.02 * DEG
    assert abs(m["heading_rad"] - (ldv.heading_rad + SPEC.crab_rad)) < 0.02 * DEG


def _fit(x, y):
    a = np.column_stack([np.ones_like(x), x])
    return np.linalg.lstsq(a, y, rcond=None)[0]


def test_squat_and_roll_per_g(sim):
    """Regressions of the body's pitch and roll over its path (from the true attitude and velocity)
    on the accelerations (finite differences of the true velocity) give the specified 2°/g, 2.5°/g."""
    im = sim.imu
    t = im.t_s
    v = im.v_n
    speed = np.linalg.norm(v, axis=1)
    a_fwd = np.gradient(speed, t)
    psi_v = np.unwrap(np.arctan2(v[:, 0], v[:, 1]))
    a_lat = speed * np.gradient(psi_v, t)  # centripetal, + to the right
    mov = speed > 3.0
    mov[:200] = mov[-200:] = False
    # pitch of the body over its path: body forward axis vs velocity direction
    fwd = im.c_bn[:, :, 1]
    right = im.c_bn[:, :, 0]
    up_v = v / speed[:, None].clip(1e-9)
    body_pitch = np.arcsin(fwd[:, 2]) - np.arcsin(up_v[:, 2].clip(-1, 1))
    body_roll = np.arcsin(-right[:, 2])  # roll of the body on a road without bank (+ = right side down)
    c0, c1 = _fit(a_fwd[mov], body_pitch[mov])
    assert c1 == pytest.approx(SPEC.squat_rad_per_g / G0, rel=0.03)
    d0, d1 = _fit(a_lat[mov], body_roll[mov])
    assert d1 == pytest.approx(-SPEC.roll_rad_per_g / G0, rel=0.03)
    assert np.ptp(a_fwd[mov]) > 1.0 and np.ptp(a_lat[mov]) > 0.5  # the drive excites both


def test_ldv_sees_the_stance(sim):
    """A 2-D LDV fixed in the body reads v_up/v_fwd = −tan(body pitch over the path): −stance on average."""
    t = sim.ldv_t_s
    tr = sim.motion.truth(t)
    ok = (sim.ldv_quality >= 100) & (tr["speed_mps"] > 10.0)
    ratio = sim.ldv_v_up[ok] / sim.ldv_v_fwd[ok]
    assert np.mean(ratio) == pytest.approx(-np.tan(SPEC.stance_pitch_rad), abs=3e-5)
    # an LDV riding the travel direction (the ideal simulator) would read zero
    assert abs(np.mean(ratio)) > 4e-3


def test_gyro_sees_the_bounce(sim):
    """The pitch-axis gyro (body right axis, mounting rotates it slightly) carries the 1.3-Hz bounce
    with rate amplitude 2π f A v/v_ref at constant speed."""
    im = sim.imu
    dt = np.diff(im.t_s)[0]
    tr = sim.motion.truth(im.t_s)
    const = np.abs(np.gradient(tr["speed_mps"], im.t_s)) < 1e-6
    const &= tr["speed_mps"] > 10.0
    idx = np.flatnonzero(const)[:6000]
    w_b = sim.dtheta_rad[idx] / dt @ c_db(sim.scenario.ldv.pitch_rad, sim.scenario.ldv.heading_rad)  # into head axes
    tt = im.t_s[idx] - dt / 2
    f = SPEC.bounce_hz[0]
    a = np.column_stack([np.sin(2 * np.pi * f * tt), np.cos(2 * np.pi * f * tt), np.ones_like(tt), tt - tt.mean()])
    coef = np.linalg.lstsq(a, w_b[:, 0], rcond=None)[0]
    amp = np.hypot(coef[0], coef[1])
    v = float(np.mean(tr["speed_mps"][idx]))
    assert amp == pytest.approx(2 * np.pi * f * SPEC.bounce_rad * v / SPEC.bounce_ref_mps, rel=0.02)


def test_effective_scale_is_what_the_ldv_measures(sim):
    """K·cos δ from the truth's travel direction equals the speed-weighted ratio of a noiseless LDV at
    the IMU centre (no lever arm) to the true speed: two routes through the simulator agree."""
    from dataclasses import replace

    a, b = sim.scenario.t0_s + 30.0, sim.motion.t_end_s - 10.0
    k_eff = TR.effective_scale(sim, a, b)
    t = np.arange(a, b, 0.1)
    quiet = replace(sim.scenario.ldv, noise_mps=0.0, lever_arm_m=(0.0, 0.0, 0.0))
    v_fwd, _ = ldv_measure(sim.motion, t, quiet, np.random.default_rng(0), body=sim.body)
    speed = sim.motion.truth(t)["speed_mps"]
    assert k_eff == pytest.approx(np.sum(v_fwd) / np.sum(speed), rel=1e-9)
    # the body attitude tilts the head off the travel direction: below K, by about δ²/2 (δ ~ 0.4°)
    assert sim.scenario.ldv.scale * (1 - 1e-4) < k_eff < sim.scenario.ldv.scale * (1 - 1e-6)
