"""The one gravity field: Δg and DOV of the point-mass potential against harmonica (Fatiando),
the IMU sensing it at rest, and the .gdf grids written beside the bundle."""

import numpy as np
import pytest

from ldvsurvey.io.gdf import parse_gdf
from ldvsurvey.nav.earth import ARCSEC, MGAL, normal_gravity
from ldvsurvey.sim import catalog
from ldvsurvey.sim.effects import Effects, GravityFieldSpec
from ldvsurvey.sim.pointmass import G_NEWTON
from ldvsurvey.sim.scenario import grid_files, simulate

hm = pytest.importorskip("harmonica")


def _harmonica(field, lat_rad, lon_rad, h_m):
    """(ξ, η rad, Δg mGal) from harmonica's point-mass accelerations at the same masses."""
    e, n, u = field.enu(lat_rad, lon_rad, h_m)
    pts = field.masses[:, :3].T
    mass = field.masses[:, 3] / G_NEWTON
    g = {k: hm.point_gravity((e, n, u), pts, mass, field=k) for k in ("g_e", "g_n", "g_z")}
    gam = normal_gravity(lat_rad, h_m) / MGAL
    return -g["g_n"] / gam, -g["g_e"] / gam, g["g_z"]


@pytest.fixture(scope="module")
def sim():
    eff = Effects.ideal().with_(gravity_field=GravityFieldSpec(seed=7))
    sc = catalog.realistic_drive(seed=7, effects=eff, minutes=5, static_s=120)
    sc.gyro_arw_dprh = sc.accel_vrw_ug_rthz = sc.gyro_bias_dph = sc.accel_bias_ug = 0.0
    return simulate(sc)


def test_field_matches_harmonica_along_the_track(sim):
    field = sim.extras["gravity_field"]
    im = sim.imu
    sl = slice(None, None, 97)
    xi, eta, dg = field(im.lat_rad[sl], im.lon_rad[sl], im.h_m[sl])
    hxi, heta, hdg = _harmonica(field, im.lat_rad[sl], im.lon_rad[sl], im.h_m[sl])
    np.testing.assert_allclose(dg / MGAL, hdg, rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(xi, hxi, rtol=1e-9, atol=1e-15)
    np.testing.assert_allclose(eta, heta, rtol=1e-9, atol=1e-15)


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_realistic_magnitudes(seed):
    """DOV of 5–30″ at the survey, Δg gradients ≤ 3 mGal/km, Δg of tens of mGal: harmonica's numbers."""
    sc = catalog.realistic_height(seed=seed)  # only the motion is evaluated: cheap
    from ldvsurvey.sim.motion import Motion
    from ldvsurvey.sim.pointmass import build_field

    m = Motion(sc.road, sc.segments, sc.t0_s)
    tr = m.truth(np.linspace(sc.t0_s, m.t_end_s, 400))
    field = build_field(sc.effects.gravity_field, tr["lat_rad"], tr["lon_rad"], tr["h_m"])
    xi, eta, dg = _harmonica(field, tr["lat_rad"], tr["lon_rad"], tr["h_m"])
    dov = np.hypot(xi, eta) / ARCSEC
    assert 4.0 <= np.median(dov) <= 32.0
    s = np.concatenate(
        [
            [0.0],
            np.cumsum(
                np.linalg.norm(
                    np.diff(np.column_stack(field.enu(tr["lat_rad"], tr["lon_rad"], tr["h_m"])), axis=0), axis=1
                )
            ),
        ]
    )
    grad = np.abs(np.diff(dg)) / np.maximum(np.diff(s), 1e-9) * 1000.0
    assert grad[np.diff(s) > 5.0].max() <= 3.05
    assert np.ptp(dg) > 2.0 and np.max(np.abs(dg)) < 150.0


def test_imu_at_rest_senses_the_plumb_line(sim):
    """At rest the accelerometers measure −g: rotated to n with the true attitude, the mean specific
    force is [γη, γξ, γ+Δg] with harmonica's DOV and Δg at that point (sensor errors off)."""
    im = sim.imu
    dt = np.diff(im.t_s)[0]
    rest = im.t_s < sim.scenario.t0_s + 100.0
    f_b = sim.dvel_mps[rest] / dt
    f_n = np.einsum("kij,kj->ki", im.c_bn[rest], f_b).mean(axis=0)
    lat, lon, h = im.lat_rad[0], im.lon_rad[0], im.h_m[0]
    xi, eta, dg = _harmonica(sim.extras["gravity_field"], np.array([lat]), np.array([lon]), np.array([h]))
    gam = normal_gravity(lat, h)
    assert f_n[0] == pytest.approx(gam * eta[0], abs=1e-9 * gam + 1e-8)
    assert f_n[1] == pytest.approx(gam * xi[0], abs=1e-9 * gam + 1e-8)
    assert f_n[2] == pytest.approx(gam + dg[0] * MGAL, abs=1e-8)
    # and the DOV is large enough to matter (≥ 1″ tilt of the plumb line)
    assert np.hypot(xi[0], eta[0]) > ARCSEC


def test_gdf_grids_cover_the_track_and_match_harmonica(sim):
    files = grid_files(sim)
    assert set(files) == {"xi.gdf", "eta.gdf", "dg.gdf"}
    _, lat, lon, xi = parse_gdf(files["xi.gdf"], "xi.gdf")
    _, lat2, lon2, eta = parse_gdf(files["eta.gdf"], "eta.gdf")
    _, _, _, dg = parse_gdf(files["dg.gdf"], "dg.gdf")
    im = sim.imu
    la, lo = np.degrees(im.lat_rad), np.degrees(im.lon_rad)
    assert lat[0] < la.min() and lat[-1] > la.max() and lon[0] < lo.min() and lon[-1] > lo.max()
    np.testing.assert_allclose(lat, lat2)
    g_la, g_lo = np.meshgrid(np.radians(lat), np.radians(lon), indexing="ij")
    h = float(np.mean(im.h_m))
    hxi, heta, hdg = _harmonica(sim.extras["gravity_field"], g_la, g_lo, np.full(g_la.shape, h))
    # node coordinates are written to 1e-6° (≤ 0.1 m): ≤ 3e-4 mGal at ≤ 3 mGal/km, less in arcsec
    np.testing.assert_allclose(xi, hxi / ARCSEC, atol=5e-4)
    np.testing.assert_allclose(eta, heta / ARCSEC, atol=5e-4)
    np.testing.assert_allclose(dg, hdg, atol=5e-4)
    assert np.ptp(xi) > 1e-2 and np.ptp(dg) > 1e-2  # the grids are not flat
