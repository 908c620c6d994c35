"""IMU effects from the generated increments: scale factors and non-orthogonality recovered from a
known rotation and from gravity, Gauss–Markov correlation time from the autocorrelation, dropped
rows and time-tag jitter from the written imu.csv."""

import io

import numpy as np
import pytest

from ldvsurvey.nav.earth import OMEGA_IE
from ldvsurvey.sim.effects import Effects, ImuErrorSpec, ImuTiming
from ldvsurvey.sim.motion import Static, TurnInPlace
from ldvsurvey.sim.road import Ramps, Road
from ldvsurvey.sim.scenario import Scenario, bundle_files, simulate

boule = pytest.importorskip("boule")

LAT, LON, H = 0.52, 2.0, 100.0
SPEC = ImuErrorSpec(
    gyro_scale_ppm=(150.0, -80.0, 220.0),
    accel_scale_ppm=(-120.0, 60.0, 250.0),
    gyro_nonorth_urad=(30.0, -45.0, 12.0, 38.0, -20.0, 25.0),
    accel_nonorth_urad=(-33.0, 41.0, 15.0, -27.0, 22.0, -18.0),
)


def _scenario(segments, effects, **kw):
    road = Road(LAT, LON, H, 100.0, Ramps(0.3))
    base = dict(gyro_bias_dph=0.0, accel_bias_ug=0.0, gyro_arw_dprh=0.0, accel_vrw_ug_rthz=0.0)
    base.update(kw)
    return Scenario(
        name="bench", road=road, segments=segments, static_s=segments[0].duration_s, effects=effects, **base
    )


def _gamma():
    return boule.WGS84.normal_gravity((np.degrees(LON), np.degrees(LAT), H), si_units=True)


def test_scale_and_nonorthogonality_from_a_turn_and_gravity():
    """A level π turn in place and gravity at rest are the known inputs; the effect must show up as
    the specified ppm and µrad (no other IMU errors)."""
    sim = simulate(
        _scenario([Static(10.0), TurnInPlace(30.0, np.pi), Static(10.0)], Effects.ideal().with_(imu_errors=SPEC))
    )
    t = sim.imu.t_s
    dt = t[1] - t[0]
    turn = (t > sim.scenario.t0_s + 10.0) & (t <= sim.scenario.t0_s + 40.0 + 1e-9)
    # the true body rates of a level turn in place: heading ψ(t) clockwise, Earth rate in ENU [0, Ω cos L, Ω sin L]
    tf = np.arange(sim.scenario.t0_s + 10.0, sim.scenario.t0_s + 40.0 + 1e-9, 1e-3)
    from ldvsurvey.nav.attitude import euler_from_c_bn
    from ldvsurvey.sim.imu import rates

    c = rates(sim.motion, tf, np.eye(3))[3]
    psi = np.unwrap(euler_from_c_bn(c)[2])
    assert psi[-1] - psi[0] == pytest.approx(np.pi, abs=1e-12)
    wx = -OMEGA_IE * np.cos(LAT) * np.sin(psi)
    wy = OMEGA_IE * np.cos(LAT) * np.cos(psi)
    ideal = np.array([np.trapezoid(wx, tf), np.trapezoid(wy, tf), -np.pi + OMEGA_IE * np.sin(LAT) * 30.0])
    meas = sim.dtheta_rad[turn].sum(axis=0)
    scale_z = meas[2] / ideal[2] - 1.0
    assert scale_z * 1e6 == pytest.approx(SPEC.gyro_scale_ppm[2], abs=0.5)
    n_xz = (meas[0] - ideal[0] * (1 + SPEC.gyro_scale_ppm[0] * 1e-6)) / ideal[2]
    n_yz = (meas[1] - ideal[1] * (1 + SPEC.gyro_scale_ppm[1] * 1e-6)) / ideal[2]
    assert n_xz * 1e6 == pytest.approx(SPEC.gyro_nonorth_urad[1], abs=0.5)
    assert n_yz * 1e6 == pytest.approx(SPEC.gyro_nonorth_urad[3], abs=0.5)
    # accelerometers at rest on level ground see [0, 0, γ] (γ from boule, WGS-84)
    rest = t <= sim.scenario.t0_s + 10.0
    f = sim.dvel_mps[rest].sum(axis=0) / (rest.sum() * dt)
    g = _gamma()
    assert (f[2] / g - 1.0) * 1e6 == pytest.approx(SPEC.accel_scale_ppm[2], abs=0.5)
    assert f[0] / g * 1e6 == pytest.approx(SPEC.accel_nonorth_urad[1], abs=0.5)
    assert f[1] / g * 1e6 == pytest.approx(SPEC.accel_nonorth_urad[3], abs=0.5)


def test_bias_instability_is_gauss_markov():
    """At rest (no noise, no scale errors), the increments minus their mean are the Gauss–Markov bias: the 1-s lag
    autocorrelation gives τ and the variance gives σ = 30 % of the manifest's bias."""
    spec = ImuErrorSpec(
        gyro_scale_ppm=(0, 0, 0),
        accel_scale_ppm=(0, 0, 0),
        gyro_nonorth_urad=(0,) * 6,
        accel_nonorth_urad=(0,) * 6,
        gyro_tau_s=20.0,
        accel_tau_s=10.0,
    )
    sim = simulate(
        _scenario([Static(1500.0)], Effects.ideal().with_(imu_errors=spec), gyro_bias_dph=0.01, accel_bias_ug=50.0),
        seed=3,
    )
    dt = sim.imu.t_s[1] - sim.imu.t_s[0]
    k = int(round(1.0 / dt))
    for incr, tau, sigma in [
        (sim.dtheta_rad, 20.0, 0.3 * 0.01 * np.pi / 180 / 3600),
        (sim.dvel_mps, 10.0, 0.3 * 50e-6 * 9.80665),
    ]:
        x = incr / dt  # rates; each is the bias at its sample time (dt ≪ τ)
        x = x - x.mean(axis=0)
        r1 = np.sum(x[k:] * x[:-k]) / np.sum(x * x)  # autocorrelation at 1 s lag: e^(−1/τ)
        assert -1.0 / np.log(r1) == pytest.approx(tau, rel=0.25)
        assert np.sqrt(np.mean(x * x)) == pytest.approx(sigma, rel=0.25)


def test_dropped_rows_and_jitter_in_the_written_log():
    timing = ImuTiming(drops_per_min=6.0, drop_max_rows=5, jitter_s=5e-5, big_jitter_share=1e-3)
    sim = simulate(_scenario([Static(300.0)], Effects.ideal().with_(imu_timing=timing)), seed=2)
    data = np.loadtxt(io.BytesIO(bundle_files(sim)["imu.csv"]), delimiter=",", comments="#", skiprows=2)
    t, dv_z = data[:, 0], data[:, 6]
    dt = 0.01
    assert np.all(np.diff(t) > 0)  # jitter never reorders rows
    n_grid = np.round((t - sim.scenario.t0_s) / dt)
    jitter = t - (sim.scenario.t0_s + n_grid * dt)
    assert np.abs(jitter).max() <= 0.4 * dt + 1e-9
    core = np.abs(jitter) < 5e-4
    assert np.std(jitter[core]) == pytest.approx(5e-5, rel=0.1)
    assert (~core).mean() == pytest.approx(1e-3 * 0.75, abs=6e-4)  # share 1e-3, ¾ of U(−2, 2) ms beyond 0.5 ms
    gaps = np.diff(n_grid)
    events = gaps > 1
    expected = 6.0 * 5.0  # per minute × minutes
    assert abs(events.sum() - expected) < 4 * np.sqrt(expected)
    assert gaps.max() <= 6 + 5  # at most two overlapping events of ≤ 5 rows
    # a row after a gap holds only its own 10-ms interval of gravity, not the lost ones
    after = np.flatnonzero(events) + 1
    np.testing.assert_allclose(dv_z[after], _gamma() * dt, rtol=1e-6)
