"""The noise floor's term for GNSS heights that wander (first-order Gauss-Markov), against simulated
wander through the same second difference and zero-phase FIR."""

import numpy as np
import pytest

from ldvsurvey.nav.gravity import MGAL, Lowpass, noise_floor_mgal


@pytest.mark.parametrize("length_s,tau_s", [(150.0, 300.0), (100.0, 60.0)])
def test_gauss_markov_height_floor_matches_monte_carlo(length_s, tau_s):
    sigma_m = 0.026
    floor = noise_floor_mgal(Lowpass(length_s), height_correlated_m=sigma_m, height_correlation_s=tau_s)
    rng = np.random.default_rng(11)
    n = 400_000  # 1-Hz heights
    phi = np.exp(-1.0 / tau_s)
    drive = rng.normal(0.0, sigma_m * np.sqrt(1.0 - phi**2), n)
    h = np.empty(n)
    h[0] = rng.normal(0.0, sigma_m)
    for k in range(1, n):  # exact discrete Gauss-Markov at 1 s steps
        h[k] = phi * h[k - 1] + drive[k]
    k = slice(int(3 * length_s), -int(3 * length_s))
    got = np.std(Lowpass(length_s, 1.0).apply(np.diff(h, 2))[k]) / MGAL
    assert got == pytest.approx(floor["gnss_height_correlated_mgal"], rel=0.15)
    assert floor["total_mgal"] == pytest.approx(floor["gnss_height_correlated_mgal"])
