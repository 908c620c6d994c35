"""The σ of a stop's mean (drift.stop_sigma): measured on few-second block means, floored at the manifest's
white accelerometer noise over √T. Truth: the scatter of many simulated stops' means (Monte Carlo)."""

import numpy as np
import pytest

from ldvsurvey.pipelines.gravity.drift import STOP_BLOCK_S, STOP_MIN_BLOCKS, stop_sigma
from ldvsurvey.units import G0_MPS2

FS_HZ = 100.0
N_UG = 20.0  # white accelerometer noise, µg/√Hz


def _white(rng, n_stops, dur_s):
    """Stops of white noise of density N_UG: per-sample σ = N √fs (m/s²)."""
    n = int(dur_s * FS_HZ)
    return np.arange(n) / FS_HZ, rng.normal(0.0, N_UG * 1e-6 * G0_MPS2 * np.sqrt(FS_HZ), (n_stops, n))


def test_the_floor_is_the_white_noise_of_the_mean_and_holds():
    """Over 2000 simulated 20-s stops the means scatter by N/√T (the truth); no stop reports less than
    that (the floor), and the reported σ's RMS stays near it (floor and scatter estimate agree)."""
    rng = np.random.default_rng(3)
    dur = 20.0
    t, x = _white(rng, 2000, dur)
    true = float(np.std(x.mean(axis=1), ddof=1))
    sig = np.array([stop_sigma(t, xi, dur, noise_ug_rthz=N_UG) for xi in x])
    floor = N_UG * 1e-6 * G0_MPS2 / np.sqrt(dur)
    assert true == pytest.approx(floor, rel=0.05)  # the floor's formula is the mean's true σ
    assert np.all(sig >= floor * (1 - 1e-12))
    raw = np.array([stop_sigma(t, xi, dur) for xi in x])  # no floor: the data's own estimate
    assert np.mean(raw < 0.7 * true) > 0.1  # from 6 blocks it is often far too small: why the floor exists
    assert np.sqrt(np.mean(sig**2)) == pytest.approx(true, rel=0.25)


def test_a_slow_disturbance_shows_in_the_few_second_blocks(monkeypatch):
    """A standing vehicle rocking (a first-order Gauss–Markov sway of 100 µg, τ 2 s) on white noise: the
    mean's true σ (the scatter over 1000 stops) is far above N/√T; 1-s block means, correlated by the sway,
    report half of it, the few-second blocks most of it."""
    from scipy.signal import lfilter

    from ldvsurvey.pipelines.gravity import drift

    rng = np.random.default_rng(5)
    dur, tau, n_stops = 30.0, 2.0, 1000
    t, x = _white(rng, n_stops, dur)
    a = np.exp(-1.0 / (FS_HZ * tau))
    w = rng.normal(0.0, 100e-6 * G0_MPS2 * np.sqrt(1 - a * a), (n_stops, len(t) + 2000))
    x = x + lfilter([1.0], [1.0, -a], w, axis=1)[:, 2000:]  # 20 s of spin-up dropped: stationary
    true = float(np.std(x.mean(axis=1), ddof=1))
    assert true > 5 * N_UG * 1e-6 * G0_MPS2 / np.sqrt(dur)

    def rms_ratio():
        sig = np.array([stop_sigma(t, xi, dur, noise_ug_rthz=N_UG) for xi in x])
        return float(np.sqrt(np.mean(sig**2)) / true)

    got = rms_ratio()
    monkeypatch.setattr(drift, "STOP_BLOCK_S", 1.0)
    one_s = rms_ratio()
    assert 0.6 < got < 1.2 and got > 1.3 * one_s, (got, one_s)


def test_a_short_stop_takes_the_floor_alone():
    dur = STOP_BLOCK_S * (STOP_MIN_BLOCKS - 1) + 0.5
    t = np.arange(int(dur * FS_HZ)) / FS_HZ
    x = np.zeros_like(t)
    assert stop_sigma(t, x, dur, noise_ug_rthz=N_UG) == pytest.approx(N_UG * 1e-6 * G0_MPS2 / np.sqrt(dur))
    assert np.isnan(stop_sigma(t, x, dur))  # neither the data nor the manifest gives a σ
    # a bridged IMU gap inside still adds σ_g/T
    s = stop_sigma(t, x, dur, bridges=[(1.0, 0.1, 2e-4)], noise_ug_rthz=N_UG)
    assert s == pytest.approx(np.hypot(N_UG * 1e-6 * G0_MPS2 / np.sqrt(dur), 2e-4 / dur))
