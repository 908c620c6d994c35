"""Gauss–Markov bias-instability states (issue 13 §2 "biases drift").

A 12-min GNSS-aided drive whose accelerometer and gyro biases wander (first-order Gauss–Markov,
σ 60 µg / 0.02 °/h, τ 10 min) on top of the turn-on bias. Modelled as constants, the filter
averages the drift away and its 1-σ claims a certainty it does not have; with the instability
(from the manifest's optional keys) it tracks the bias and its 3-σ covers the truth.
"""

import numpy as np
import pytest

from ldvsurvey.errors import ParameterError
from ldvsurvey.nav.align import coarse_align
from ldvsurvey.nav.attitude import q_from_c
from ldvsurvey.nav.filter import FilterConfig, GnssAid, ImuData, ImuNoise, NavStart, run_filter
from ldvsurvey.sim import catalog
from ldvsurvey.sim import truth as TR
from ldvsurvey.sim.effects import Effects, ImuErrorSpec
from ldvsurvey.sim.scenario import simulate
from ldvsurvey.sim.sensors import FIX_SIGMA

RAD = np.pi / 180
TAU = 600.0


@pytest.fixture(scope="module")
def drifting():
    # the bias instability alone (no scale factors or non-orthogonality): σ 0.02 °/h and 60 µg
    drift = ImuErrorSpec(
        gyro_scale_ppm=(0.0,) * 3,
        accel_scale_ppm=(0.0,) * 3,
        gyro_nonorth_urad=(0.0,) * 6,
        accel_nonorth_urad=(0.0,) * 6,
        gyro_bi_frac=0.02 / 0.01,
        accel_bi_frac=60.0 / 50.0,
        gyro_tau_s=TAU,
        accel_tau_s=TAU,
    )
    sc = catalog.drive(
        minutes=12, static_s=60, gyro_bias_dph=0.01, accel_bias_ug=50.0, effects=Effects.ideal().with_(imu_errors=drift)
    )
    sim = simulate(sc, seed=21)
    imu = sim.imu
    static = imu.t_s < sc.t0_s + 59
    c0 = coarse_align(sim.dtheta_rad[static], sim.dvel_mps[static], sc.road.lat0_rad)
    sig = np.array([FIX_SIGMA[4]] * len(sim.gnss_t_s))
    gnss = GnssAid(
        sim.gnss_t_s,
        np.radians(sim.gnss_lat_deg),
        np.radians(sim.gnss_lon_deg),
        sim.gnss_h_m,
        sig[:, 0],
        sig[:, 1],
        sc.gnss_lever_m,
    )
    pos0 = np.array([sc.road.lat0_rad, sc.road.lon0_rad, sc.road.h0_m])
    cfg = FilterConfig(att_sigma0_rad=(0.05 * RAD, 0.05 * RAD, 2 * RAD))
    out = {}
    for name, extra in (
        ("constant", {}),
        ("gm", dict(gyro_bias_instability_dph=0.02, accel_bias_instability_ug=60.0, bias_correlation_s=TAU)),
    ):
        noise = ImuNoise(0.01, 50.0, sc.gyro_arw_dprh, sc.accel_vrw_ug_rthz, **extra)
        out[name] = run_filter(
            ImuData(imu.t_s, sim.dtheta_rad, sim.dvel_mps),
            NavStart(q_from_c(c0), np.zeros(3), pos0),
            noise,
            cfg,
            zupt_intervals=[(sc.t0_s, sc.t0_s + 59)],
            gnss=gnss,
            smooth=True,
        )
    return sim, out


def test_gauss_markov_states_track_the_drift(drifting):
    sim, out = drifting
    moving = sim.imu.t_s[out["gm"].epoch_index[1:]] > sim.imu.t_s[0] + 120
    idx = out["gm"].epoch_index[1:][moving]
    stats = {}
    for name, sol in out.items():
        est = sol.epoch_bias[1:][moving, 3:5]  # horizontal accelerometers (observable in the drive)
        err = est - TR.imu_bias(sim)[1][idx, :2]
        sig = sol.epoch_sigma[1:][moving, 12:14]
        stats[name] = (np.sqrt(np.mean(err**2)), np.mean(np.abs(err) <= 3 * sig))
    assert stats["gm"][0] < 0.6 * stats["constant"][0], stats
    assert stats["gm"][1] >= 0.9, stats  # the 3-σ covers the truth
    assert stats["constant"][1] < 0.9, stats  # the constant model claims too much


def test_manifest_keys_are_validated():
    class Imu:
        gyro_bias_dph = accel_bias_ug = gyro_arw_deg_per_rth = accel_noise_ug_per_rthz = None
        accel_bias_instability_ug = 30.0

    with pytest.raises(ParameterError) as e:
        ImuNoise.from_manifest(Imu())
    assert e.value.field == "imu.bias_correlation_s"
    Imu.bias_correlation_s = "600"
    with pytest.raises(ParameterError) as e:
        ImuNoise.from_manifest(Imu())
    assert e.value.field == "imu.bias_correlation_s"
    Imu.bias_correlation_s = 600.0
    n = ImuNoise.from_manifest(Imu())
    inv, q = n.gauss_markov()
    assert inv[0] == pytest.approx(1 / 600) and q[3] == pytest.approx(2 * (30e-6 * 9.80665) ** 2 / 600)
