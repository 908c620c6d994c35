"""Turntable-axis tilt from a rotating IMU's own attitude (nav/turntable.py) against attitudes built
with scipy's rotations from a known tilt, level and indexing scheme."""

import numpy as np
from scipy.spatial.transform import Rotation

from ldvsurvey.nav.turntable import diversity, estimate_tilt, find_stops

ALPHA_RAD, BETA_RAD = 2.0e-3, -1.5e-3
RATE_HZ = 10.0


def _passive(axis: str, angle_rad):
    """Frame-rotation (passive) matrices about one axis, (K, 3, 3)."""
    return np.transpose(Rotation.from_euler(axis, np.reshape(angle_rad, (-1, 1))).as_matrix(), (0, 2, 1))


def _attitudes(eta_rad, level_xyz_rad, noise_rad=0.0, seed=0):
    """C_s^n of a sensor on a turntable tilted by (ALPHA_RAD, BETA_RAD) on a body of attitude
    C_b^n = Rotation.from_euler("xyz", level) (K, 3, 3), with white attitude noise (rad)."""
    c_bs = _passive("y", BETA_RAD) @ _passive("x", ALPHA_RAD) @ _passive("z", eta_rad)  # R_y(β) R_x(α) R_z(η)
    c_bn = Rotation.from_euler("xyz", level_xyz_rad).as_matrix()
    c_sn = c_bn @ np.transpose(c_bs, (0, 2, 1))
    if noise_rad:
        rng = np.random.default_rng(seed)
        c_sn = c_sn @ Rotation.from_rotvec(rng.normal(0.0, noise_rad, (len(eta_rad), 3))).as_matrix()
    return c_sn


def _drive(stop_deg, dwell_s, levels, noise_rad=0.0, drift_rad=0.0):
    """Still intervals of 4-position stops (instant moves) at two levels of the body, 60 s of driving
    between them (turntable at rest). Returns t_s, c_sn, eta_rad, still intervals."""
    ts, cs, es, still = [], [], [], []
    t0 = 1000.0
    for k, level in enumerate(levels):
        n = int(dwell_s * RATE_HZ) * len(stop_deg)
        t = t0 + np.arange(n) / RATE_HZ
        eta = np.repeat(np.radians(stop_deg), int(dwell_s * RATE_HZ))
        lev = np.asarray(level, float) + np.outer(np.linspace(0.0, 1.0, n), [drift_rad, -drift_rad, 0.0])
        ts.append(t)
        cs.append(_attitudes(eta, lev, noise_rad, seed=k))
        es.append(eta)
        still.append((float(t[0]), float(t[-1])))
        t0 = t[-1] + 60.0
    return np.concatenate(ts), np.concatenate(cs), np.concatenate(es), still


LEVELS = [(0.01, -0.02, 0.3), (-0.015, 0.005, 2.1)]


def test_exact_attitudes_give_the_tilt_and_the_pairs_of_opposite_stops():
    t, c_sn, eta, still = _drive([0.0, 180.0, 270.0, 90.0], 25.0, LEVELS)
    est = estimate_tilt(t, c_sn, eta, still, trim_s=0.5, stops=find_stops(t, eta))
    assert est.observable and est.n_intervals == 2
    np.testing.assert_allclose([est.alpha_rad, est.beta_rad], [ALPHA_RAD, BETA_RAD], atol=1e-9)
    assert est.rms_residual_rad < 1e-9
    assert abs(est.diversity - diversity(np.radians([0.0, 180.0, 270.0, 90.0]))) < 0.05
    # 0°→180° and 270°→90° in each interval; 180°→270° is a quarter turn
    assert len(est.pairs) == 4
    assert all(still[0][0] <= a < b <= still[0][1] or still[1][0] <= a < b <= still[1][1] for a, b in est.pairs)


def test_noisy_drifting_level_within_its_stated_sigma_and_the_bias_floor():
    noise = 2e-5
    t, c_sn, eta, still = _drive([0.0, 180.0, 90.0, 270.0], 40.0, LEVELS, noise_rad=noise, drift_rad=5e-5)
    est = estimate_tilt(t, c_sn, eta, still, trim_s=0.5)
    err = np.array([est.alpha_rad - ALPHA_RAD, est.beta_rad - BETA_RAD])
    sig = np.array([est.alpha_sigma_rad, est.beta_sigma_rad])
    assert np.all(np.abs(err) < 4 * sig), (err, sig)
    # white noise of 20 µrad on 3200 samples: about noise / √3200 ≈ 0.4 µrad, neither zero nor the noise
    assert np.all((sig > noise / 500) & (sig < noise / 10)), sig
    floored = estimate_tilt(t, c_sn, eta, still, trim_s=0.5, bias_sigma_rad=1e-4)
    assert floored.alpha_sigma_rad == floored.beta_sigma_rad == 1e-4
    assert floored.alpha_rad == est.alpha_rad


def test_a_turntable_that_does_not_turn_while_still_falls_back_to_zero():
    t, c_sn, eta, still = _drive([90.0], 100.0, LEVELS)
    est = estimate_tilt(t, c_sn, eta, still)
    assert not est.observable
    assert (est.alpha_rad, est.beta_rad, est.alpha_sigma_rad) == (0.0, 0.0, None)
    assert "not observable" in est.warnings[0]
