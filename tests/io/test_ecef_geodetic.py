"""ECEF -> WGS-84 geodetic (``io.importers.common.ecef_to_lla``, used by the ubx NAV-SOL and rtklib x/y/z-ecef
readers) against the closed-form geodetic -> ECEF written here. Neither pymap3d nor pyproj is installed, so the
truth is this analytic round trip, to a few units in the last place of the coordinates (float64 resolves ECEF
coordinates near the surface to 0.93 nm: 1e-9 m is below it)."""

from __future__ import annotations

import numpy as np
import pytest

from ldvsurvey.io.importers.common import ecef_to_lla

A_M, F = 6378137.0, 1 / 298.257223563  # WGS-84 (NIMA TR8350.2)
E2 = F * (2 - F)


def lla_to_ecef(lat_rad, lon_rad, h_m):
    """Geodetic to ECEF, m: N = a / √(1 - e² sin² φ); x, y = (N + h) cos φ (cos λ, sin λ); z = (N(1-e²) + h) sin φ."""
    n = A_M / np.sqrt(1 - E2 * np.sin(lat_rad) ** 2)
    cl = np.cos(lat_rad)
    return np.stack(
        [(n + h_m) * cl * np.cos(lon_rad), (n + h_m) * cl * np.sin(lon_rad), (n * (1 - E2) + h_m) * np.sin(lat_rad)], -1
    )


EDGES_DEG = [-90.0, -89.999, -60.0, -1e-9, 0.0, 1e-9, 45.0, 80.0, 85.0, 89.9, 89.99999, 90.0]


@pytest.mark.parametrize("h_m", [-1000.0, 0.0, 120.0, 9000.0, 1e5, 2.02e7])
def test_round_trip_at_every_latitude(h_m):
    rng = np.random.default_rng(7)
    lat = np.r_[np.radians(EDGES_DEG), np.arcsin(rng.uniform(-1, 1, 500))]
    lon = np.r_[np.radians(np.linspace(-179.9, 180.0, len(EDGES_DEG))), rng.uniform(-np.pi, np.pi, 500)]
    xyz = lla_to_ecef(lat, lon, np.full(lat.shape, h_m))
    got = np.array([ecef_to_lla(*p) for p in xyz.tolist()])
    tol_m = 5 * np.spacing(A_M + abs(h_m))  # a few ulps of the coordinates: 4.7e-9 m at the surface
    r_m = A_M + h_m  # metres per radian, to within 0.7 % (enough for a tolerance)
    assert np.abs(got[:, 2] - h_m).max() <= tol_m
    assert (np.abs(np.radians(got[:, 0]) - lat) * r_m).max() <= tol_m
    off_axis = np.abs(lat) < np.radians(89.99)  # the longitude of a point on the axis is arbitrary
    dlon = (np.radians(got[off_axis, 1]) - lon[off_axis] + np.pi) % (2 * np.pi) - np.pi
    assert (np.abs(dlon) * r_m * np.cos(lat[off_axis])).max() <= tol_m


def test_on_the_axis_the_height_is_above_the_pole():
    b_m = A_M * (1 - F)
    for z, lat in ((b_m + 10.0, 90.0), (-(b_m + 10.0), -90.0)):
        got = ecef_to_lla(0.0, 0.0, z)
        assert got[0] == lat and got[2] == pytest.approx(10.0, abs=1e-8)
