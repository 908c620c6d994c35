"""Covariance inflation from time-correlated innovations (nav/innovations.py), against theory and
a Monte Carlo of the very over-confidence it corrects."""

import numpy as np
from scipy.signal import lfilter

from ldvsurvey.nav.innovations import integrated_autocorrelation, variance_inflation


def _ar1(n, phi, rng, sigma=1.0):
    w = rng.normal(0.0, sigma * np.sqrt(1 - phi**2), n)
    return lfilter([1.0], [1.0, -phi], w, zi=[phi * rng.normal(0.0, sigma)])[0]


def test_white_innovations_need_no_inflation():
    rng = np.random.default_rng(1)
    f = variance_inflation(rng.normal(0, 1, 5000))
    assert 1.0 <= f["factor"] < 1.15 and abs(f["nis_variance"] - 1) < 0.06


def test_ar1_integrated_time_matches_theory():
    rng = np.random.default_rng(2)
    for phi in (0.5, 0.9, 0.98):
        est = np.mean([integrated_autocorrelation(_ar1(20000, phi, rng)) for _ in range(5)])
        theory = (1 + phi) / (1 - phi)
        assert abs(est / theory - 1) < 0.25, (phi, est, theory)


def test_inflated_sigma_covers_the_mean_of_correlated_errors():
    """The mean of n correlated unit-variance errors scatters √τ times more than 1/√n, and
    variance_inflation, given only one realization each, restores the spread on average."""
    rng = np.random.default_rng(3)
    n, phi = 2400, 0.95
    means, factors = [], []
    for _ in range(200):
        x = _ar1(n, phi, rng, sigma=1.5)  # also 1.5× the variance the filter assumed
        means.append(x.mean())
        factors.append(variance_inflation(x)["factor"])
    naive = 1.0 / np.sqrt(n)
    actual = np.std(means)
    assert actual > 4 * naive  # white modelling is over-confident
    assert abs(np.sqrt(np.median(factors)) * naive / actual - 1) < 0.3


def test_nan_and_gated_rows_are_left_out():
    rng = np.random.default_rng(4)
    x = rng.normal(0, 1, 3000)
    x[::7] = np.nan
    x[5] = 40.0  # a rejected multipath jump
    f = variance_inflation(x, gate=6.0)
    assert f["n"] == np.count_nonzero(np.isfinite(x)) - 1 and f["factor"] < 1.15
