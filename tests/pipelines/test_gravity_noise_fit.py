"""The no-LDV gravity floor's noise figures estimated from the data (issue 25): the GNSS height noise
fitted to a SINS/GNSS chain's raw δg, the accelerometer density from the static start; each against
the synthetic noise it was made of."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from ldvsurvey.nav.gravity import G0, Lowpass, noise_floor_mgal
from ldvsurvey.pipelines.gravity.report import fit_height_noise, height_wander_floor_mgal, static_accel_noise_ug_rthz

FIR_S = 150.0
LOWPASS = Lowpass(FIR_S)


def _chain(n_s, white_m, q_m2_per_s, accel_ug_rthz, seed, nan_at=()):
    """A 1 Hz chain whose raw δg is the second difference of white + random-walk heights plus white
    accelerometer noise (what the SINS/GNSS chain holds above the FIR's pass band)."""
    rng = np.random.default_rng(seed)
    h = white_m * rng.normal(size=n_s) + np.cumsum(np.sqrt(q_m2_per_s) * rng.normal(size=n_s))
    dg = h[2:] - 2 * h[1:-1] + h[:-2] + accel_ug_rthz * 1e-6 * G0 * rng.normal(size=n_s - 2)
    for k in nan_at:
        dg[k : k + 30] = np.nan
    return {"dg": dg, "fs": 1.0, "kind": "gnss"}


@pytest.mark.parametrize("seed", [1, 2])
def test_height_noise_fit_recovers_white_and_wander(seed):
    """White 15 mm and a wander of q = 4.5e-6 m²/s (σ 26 mm over 300 s) over 6 h, with gaps in the
    chain (the stretches between them are used): σ_w within 5 %, q within 20 % (the fit's own scatter
    is about 8 % on 6 h: 30 % on 24 min, measured over 30 simulated realizations)."""
    white, q = 0.015, 2 * 0.026**2 / 300.0
    fit = fit_height_noise(_chain(6 * 3600, white, q, 2.0, seed, nan_at=(5000, 12000)), LOWPASS, 2.0)
    assert fit is not None
    w_fit, q_fit, n_seg = fit
    assert n_seg > 100
    assert w_fit == pytest.approx(white, rel=0.05) and q_fit == pytest.approx(q, rel=0.2)


def test_height_noise_fit_without_wander_finds_none():
    """White heights only: the fitted wander is a small fraction of an RTK receiver's, and its floor
    term below the white part's."""
    w_fit, q_fit, _ = fit_height_noise(_chain(6 * 3600, 0.02, 0.0, 2.0, 3), LOWPASS, 2.0)
    assert w_fit == pytest.approx(0.02, rel=0.05)
    white_floor = noise_floor_mgal(LOWPASS, height_noise_m=w_fit, gnss_rate_hz=1.0)["gnss_height_mgal"]
    assert q_fit < 0.1 * 2 * 0.026**2 / 300.0
    assert height_wander_floor_mgal(LOWPASS, q_fit) < white_floor


def test_too_short_a_chain_gives_no_fit():
    assert fit_height_noise(_chain(300, 0.015, 1e-6, 2.0, 4), LOWPASS) is None


def test_wander_floor_is_the_long_gauss_markov_limit():
    """The random-walk term equals noise_floor_mgal's Gauss-Markov term for τ ≫ the FIR (q = 2σ²/τ)."""
    tau = 1e5
    sig = np.sqrt(4.5e-6 * tau / 2)
    gm = noise_floor_mgal(LOWPASS, height_correlated_m=sig, height_correlation_s=tau)["gnss_height_correlated_mgal"]
    assert height_wander_floor_mgal(LOWPASS, 4.5e-6) == pytest.approx(gm, rel=0.01)


def test_static_start_gives_the_accelerometer_density():
    """Δv of a tilted IMU at rest with white noise of 5 µg/√Hz at 100 Hz, a bias and a slow drift:
    the density back within 5 %; None without a static start of 30 s."""
    rng = np.random.default_rng(7)
    fs, n = 100.0, 120 * 100
    t = 1000.0 + np.arange(n) / fs
    up = np.array([0.05, -0.03, 1.0]) / np.linalg.norm([0.05, -0.03, 1.0])
    f_up = G0 + 20e-6 * G0 + 1e-7 * (t - t[0]) + 5e-6 * G0 * np.sqrt(fs) * rng.normal(size=n)
    dvel = (f_up[:, None] * up + 5e-6 * G0 * np.sqrt(fs) * rng.normal(size=(n, 3)) * [1, 1, 0]) / fs
    log = SimpleNamespace(imu=SimpleNamespace(t_s=t, dvel_mps=dvel))
    got, (a, b) = static_accel_noise_ug_rthz(log, [(t[0], t[-1])])
    assert got == pytest.approx(5.0, rel=0.05) and (a, b) == (t[0], t[-1])
    assert static_accel_noise_ug_rthz(log, [(t[0], t[0] + 20.0)]) is None
    assert static_accel_noise_ug_rthz(log, [(t[0] + 50.0, t[-1])]) is None  # not at the start
    assert static_accel_noise_ug_rthz(log, []) is None
