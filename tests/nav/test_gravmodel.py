"""EGM2008's height anomaly (nav/gravmodel.py) against the model's own gravity disturbance: the vertical
derivative of T = (ζ − ζ₀)·γ is −δg (the two come from separate sums of the synthesis)."""

import numpy as np
import pytest

from ldvsurvey.nav import gravmodel as gm
from ldvsurvey.nav.earth import MGAL, normal_gravity


def test_vertical_derivative_of_the_potential_is_the_disturbance():
    from ldvsurvey.nav.egm import synthesize

    lat, lon, h, d = 28.49, 113.06, 120.0, 50.0

    def potential(hh):
        return (gm.height_anomaly_m([lat], [lon], hh)[0] - gm.ZERO_DEGREE_M) * normal_gravity(np.radians(lat), hh)

    dg_fd = -(potential(h + d) - potential(h - d)) / (2 * d) / MGAL
    _, _, dg = synthesize(gm._model(2190), np.array([lat]), np.array([lon]), h)
    assert abs(dg_fd) > 5.0  # a real signal there, not two zeros
    assert dg_fd == pytest.approx(dg[0, 0], abs=0.05)  # spherical −∂T/∂r against −∂T/∂h


def test_grid_interpolation_matches_the_points():
    la = np.array([28.47, 28.49, 28.51])
    lo = np.array([113.04, 113.06, 113.08])
    np.testing.assert_allclose(gm.height_anomaly_grid(la, lo, 120.0), gm.height_anomaly_m(la, lo, 120.0), atol=0.02)


def test_free_air_anomaly_refers_to_the_telluroid():
    """Δg − δg = γ(h) − γ(h − ζ): a negative ζ puts the telluroid above the ellipsoidal point, where normal
    gravity is smaller, so Δg > δg by 0.3086 mGal per metre."""
    lat = np.radians(28.5)
    out = gm.free_air_anomaly_mgal(np.array([10.0]), lat, np.array([120.0]), np.array([-16.0]))
    assert out[0] - 10.0 == pytest.approx(0.3086 * 16.0, rel=3e-3)
