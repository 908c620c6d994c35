"""Gravity disturbance, FIR and internal coincidence: analytic identities and the paper's tables."""

import numpy as np
import pytest
from scipy.signal import filtfilt

from ldvsurvey.nav.coincidence import (along_track, common_points, crossovers, internal_coincidence,
                                       total_from_lines)
from ldvsurvey.nav.earth import MGAL, OMEGA_IE, normal_gravity, radii
from ldvsurvey.nav.gravity import disturbance_mps2, fir_taps, zero_phase_lowpass


def test_paper_tables_2_and_3_add_up():
    assert round(total_from_lines([0.73, 0.47, 0.66, 1.05, 0.53, 0.59]), 2) == 0.70  # SINS/LDV, Tab. 2
    assert round(total_from_lines([1.03, 1.30, 1.75, 1.02, 2.46, 1.05]), 2) == 1.53  # SINS/GNSS, Tab. 3


def test_total_is_the_mean_of_the_per_line_squares():
    rng = np.random.default_rng(0)
    g = rng.normal(0, 1, (6, 500)) + np.linspace(0, 30, 500)
    c = internal_coincidence(g)
    assert c.total == pytest.approx(total_from_lines(c.per_line_rms), rel=1e-12)
    # galileoQC's checkRepeatLines: std about the mean with ddof 0 = ours · sqrt((n−1)/n)
    n = g.shape[0]
    galileo = np.sqrt(np.mean((g - g.mean(axis=0)) ** 2, axis=1))
    np.testing.assert_allclose(c.per_line_rms, galileo * np.sqrt(n / (n - 1)))


def test_identical_lines_and_known_offsets():
    base = np.sin(np.linspace(0, 6, 300)) * 10
    assert internal_coincidence(np.tile(base, (4, 1))).total == 0.0
    offs = np.array([0.3, -0.1, 0.5, -0.7])
    c = internal_coincidence(base + offs[:, None])
    dev = offs - offs.mean()
    np.testing.assert_allclose(c.per_line_rms, np.abs(dev) * np.sqrt(4 / 3))
    assert c.total == pytest.approx(np.std(offs, ddof=1))
    np.testing.assert_allclose(c.per_line_max, dev)
    np.testing.assert_allclose(c.per_line_min, dev)


def test_common_points_reverse_and_trim():
    s = np.linspace(0, 1000, 101)
    fwd = (s, 2 * s)
    back = (s[::-1] + 5.0, 2 * (s[::-1] + 5.0))  # driven the other way, starts 5 m further
    grid, vals = common_points([fwd, back], 10.0)
    assert grid[0] == 5.0 and grid[-1] <= 1000.0
    np.testing.assert_allclose(vals[0], vals[1])


def test_along_track_projection():
    e = np.linspace(0, 1000, 11)
    n = np.zeros(11)
    s, lat = along_track(e, n, np.array([250.0, 730.0]), np.array([3.0, -4.0]))
    np.testing.assert_allclose(s, [250.0, 730.0])
    np.testing.assert_allclose(lat, [3.0, 4.0])


def test_crossover_accuracy():
    x = np.linspace(-500, 500, 21)
    tracks = [(x, 0 * x, np.full(21, 1.0)), (0 * x + 10, x, np.full(21, 1.6))]
    found, eps = crossovers(tracks)
    assert len(found) == 1 and found[0][4] == pytest.approx(-0.6)
    assert eps == pytest.approx(np.sqrt(0.36 / 2))


def test_zero_phase_fir_equals_filtfilt_inside():
    rng = np.random.default_rng(1)
    fs, L = 10.0, 30.0
    x = rng.normal(0, 1, 5000).cumsum()
    h = fir_taps(L, fs)
    ref = filtfilt(h, [1.0], x)
    ours = zero_phase_lowpass(x, L, fs)
    k = slice(len(h) * 2, -len(h) * 2)
    np.testing.assert_allclose(ours[k], ref[k], rtol=1e-9, atol=1e-9)
    # gaps are bridged and the result stays where the data support it
    x2 = x.copy()
    x2[2000:2010] = np.nan
    y2 = zero_phase_lowpass(x2, L, fs)
    assert np.all(np.isfinite(y2[2000:2010]))
    assert np.abs(y2[1500:2500] - ours[1500:2500]).max() < 0.05 * np.std(x)


def test_disturbance_at_rest_is_minus_gravity_residual():
    lat, h = np.radians(30.0), 200.0
    gam = normal_gravity(lat, h)
    # at rest the accelerometer reads γ + Δg upwards
    assert disturbance_mps2(gam + 10 * MGAL, 0.0, 0.0, 0.0, lat, h) / MGAL == pytest.approx(10.0, abs=1e-9)


def test_eotvos_sign_eastward_motion():
    """Moving east, the centripetal terms lower the specific force needed: δg adds (v_E/(R_N+h)+2Ω cos L) v_E."""
    lat, h, ve = np.radians(45.0), 0.0, 20.0
    rm, rn = radii(lat)
    eot = (ve / (rn + h) + 2 * OMEGA_IE * np.cos(lat)) * ve
    gam = normal_gravity(lat, h)
    assert disturbance_mps2(gam - eot, 0.0, ve, 0.0, lat, h) == pytest.approx(0.0, abs=1e-12)
