"""The still detection's running filters against scipy.ndimage, the library they stand in for.

``nav/running.py`` computes the still detection's 1-s running means, the running median's test
against the still speed and the "moving for a second" test itself, so that a navigation does not
import scipy.ndimage. Truth here is scipy.ndimage's own answer on random signals of every length and
window (odd and even, longer than the signal, values exactly at the limit): the same numbers bit
for bit, the same booleans.
"""

import numpy as np
import pytest
from scipy.ndimage import median_filter, minimum_filter1d, uniform_filter1d

from ldvsurvey.nav.running import all_ahead, running_mean, running_median_within


def _cases(seed, count=150):
    rng = np.random.default_rng(seed)
    for _ in range(count):
        n = int(rng.integers(1, 500))
        w = int(rng.integers(1, 130))
        yield rng, n, w


def test_running_mean_is_scipy_s_uniform_filter1d_bit_for_bit():
    for rng, n, w in _cases(1):
        x = rng.normal(size=(n, 3)) * 10 ** rng.uniform(-4, 4) + rng.normal(size=3)
        assert np.array_equal(running_mean(x, w), uniform_filter1d(x, w, axis=0, mode="nearest")), (n, w)
        assert np.array_equal(running_mean(x[:, 1], w), uniform_filter1d(x[:, 1], w, mode="nearest")), (n, w)


@pytest.mark.parametrize("limit", [0.03, 0.5])
def test_running_median_test_is_scipy_s_median_filter_compared(limit):
    for rng, n, w in _cases(2):
        # speeds in mm/s steps: many samples exactly at ±limit, so both comparisons are tested at the edge
        v = np.round(rng.normal(size=n) * rng.choice([0.02, 0.05, 1.0]), 3)
        v[rng.random(n) < 0.05] = limit * rng.choice([-1.0, 1.0])
        want = np.abs(median_filter(v, size=w, mode="nearest")) < limit
        assert np.array_equal(running_median_within(v, w, limit), want), (n, w)


def test_a_nan_keeps_scipy_s_answer():
    rng = np.random.default_rng(3)
    v = rng.normal(size=300) * 0.05
    v[[0, 17, 150]] = np.nan
    want = np.abs(median_filter(v, size=25, mode="nearest")) < 0.03
    assert np.array_equal(running_median_within(v, 25, 0.03), want)


def test_all_ahead_is_scipy_s_shifted_minimum_filter():
    for rng, n, w in _cases(4):
        flags = rng.random(n) < rng.uniform(0.2, 1.0)
        want = minimum_filter1d(flags.astype(np.uint8), w, mode="constant", cval=0, origin=-(w // 2)) > 0
        assert np.array_equal(all_ahead(flags, w), want), (n, w)
