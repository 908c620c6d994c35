"""Local east/north metres (nav/localframe.py) against the exact ECEF offsets of nav/earth.py, and back."""

import numpy as np

from ldvsurvey.nav import earth, localframe
from ldvsurvey.nav.localframe import local_latlon, local_metres

LAT0, LON0 = np.radians(28.4861), np.radians(113.0623)


def test_the_same_ellipsoid_as_the_earth_model():
    assert (localframe.A_M, localframe.E2) == (earth.A_M, earth.E2)
    lat = np.radians(np.linspace(-89.0, 89.0, 37))
    for a, b in zip(localframe.radii(lat), earth.radii(lat)):
        assert np.array_equal(a, b)


def test_offsets_along_the_meridian_and_the_parallel_are_the_exact_ones():
    # 1 km due north and due east: the small-area formula's error is of order d³/R² (micrometres)
    d = np.array([-1000.0, -10.0, 10.0, 1000.0])
    rm, rn = earth.radii(LAT0)
    lat_n, lon_e = LAT0 + d / rm, LON0 + d / (rn * np.cos(LAT0))
    exact_n = earth.enu_offset_m(LAT0, LON0, 0.0, lat_n, np.full_like(d, LON0), 0.0)
    exact_e = earth.enu_offset_m(LAT0, LON0, 0.0, np.full_like(d, LAT0), lon_e, 0.0)
    e, n = local_metres(LAT0, LON0, lat_n, np.full_like(d, LON0))
    assert np.allclose(n, exact_n[:, 1], atol=1e-4) and np.allclose(e, 0.0, atol=1e-9)
    e, n = local_metres(LAT0, LON0, np.full_like(d, LAT0), lon_e)
    assert np.allclose(e, exact_e[:, 0], atol=1e-4) and np.allclose(n, 0.0, atol=1e-9)


def test_latlon_is_the_inverse():
    rng = np.random.default_rng(3)
    e, n = rng.uniform(-5000, 5000, (2, 50))
    lat, lon = local_latlon(LAT0, LON0, e, n)
    e2, n2 = local_metres(LAT0, LON0, lat, lon)
    assert np.allclose(e2, e, rtol=0, atol=1e-8) and np.allclose(n2, n, rtol=0, atol=1e-8)
