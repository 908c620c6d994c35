"""EGM2008 synthesis against pyshtools, .gdf grids, interpolation, and the constant-DOV Schuler response."""

import numpy as np
import pytest

from ldvsurvey.errors import BundleError
from ldvsurvey.io.gdf import parse_gdf, write_gdf
from ldvsurvey.nav.dov import Deflection, Trajectory, propagate, schuler_constant_dov
from ldvsurvey.nav.dovgrid import DovGrid, area_for_track
from ldvsurvey.nav.earth import A_M, ARCSEC, E2, MGAL, OMEGA_IE, normal_gravity
from ldvsurvey.nav.egm import disturbing_coefficients, load_model, synthesize

pysh = pytest.importorskip("pyshtools")


def _pysh_point(model, lat, lon):
    coeffs = np.zeros((2, model.n_max + 1, model.n_max + 1))
    coeffs[0, :, : model.m_max + 1] = model.c
    coeffs[1, :, : model.m_max + 1] = model.s
    phi = np.radians(lat)
    rn = A_M / np.sqrt(1 - E2 * np.sin(phi) ** 2)
    x, z = rn * np.cos(phi), rn * (1 - E2) * np.sin(phi)
    r, latc = np.hypot(x, z), np.degrees(np.arctan2(z, x))
    g = pysh.gravmag.MakeGravGridPoint(coeffs, model.gm, model.a, r, latc, lon)
    g0 = pysh.gravmag.MakeGravGridPoint(np.zeros((2, 1, 1)), model.gm, model.a, r, latc, lon)
    gam = normal_gravity(phi, 0.0)
    return g[1] / gam / ARCSEC, -g[2] / gam / ARCSEC, -(g[0] - g0[0]) / MGAL


@pytest.mark.parametrize("lat,lon", [(34.316, 109.127), (-33.9, 18.4), (62.0, 7.0), (0.5, 290.0)])
def test_synthesis_matches_pyshtools_degree_360(lat, lon):
    model = disturbing_coefficients(load_model(n_max=360))
    xi, eta, dg = synthesize(model, np.array([lat]), np.array([lon]))
    ref = _pysh_point(model, lat, lon)
    np.testing.assert_allclose([xi[0, 0], eta[0, 0], dg[0, 0]], ref, atol=1e-6 * max(1, np.abs(ref).max()) + 1e-6)


def test_synthesis_full_degree_in_the_alps_where_doubles_underflow():
    model = disturbing_coefficients(load_model())
    assert model.n_max == 2190 and model.m_max == 2159
    xi, eta, dg = synthesize(model, np.array([45.5]), np.array([7.5]))
    ref = _pysh_point(model, 45.5, 7.5)
    np.testing.assert_allclose([xi[0, 0], eta[0, 0], dg[0, 0]], ref, atol=1e-4)


def test_normal_field_removed_and_magnitudes_plausible():
    m = load_model(n_max=50)
    d = disturbing_coefficients(m)
    assert abs(m.c[2, 0]) > 4e-4 and abs(d.c[2, 0]) < 1e-8  # J2 gone, only EGM − WGS84 remains
    model = disturbing_coefficients(load_model())
    lat = np.linspace(34.3, 37.2, 12)
    xi, eta, dg = synthesize(model, lat, np.array([109.127]))
    # EGM2008 on the DOV paper's track: deflections of a few to ~20″, disturbances within ±200 mGal
    assert 3 < np.abs(xi).max() < 60 and 3 < np.abs(eta).max() < 60
    assert np.abs(dg).max() < 200


def test_gdf_round_trip_and_interpolation():
    lat = np.arange(34.0, 34.5001, 1 / 60)
    lon = np.arange(109.0, 109.4001, 1 / 60)
    gl, go = np.meshgrid(lat, lon, indexing="ij")
    xi = 3 * gl - 2 * go  # bilinear functions are reproduced exactly by bilinear interpolation
    eta = 0.5 * gl * go
    hdr, la, lo, v = parse_gdf(write_gdf(lat, lon, xi, "deflection_xi", "arcsec"), "xi.gdf")
    np.testing.assert_allclose(la, lat)
    np.testing.assert_allclose(lo, lon)
    np.testing.assert_allclose(v, xi, atol=1e-7)
    assert hdr["functional"] == "deflection_xi"
    g = DovGrid(lat, lon, xi, eta)
    pts_lat, pts_lon = np.array([34.1234, 34.4321]), np.array([109.0555, 109.3333])
    x, e, _ = g.interpolate(pts_lat, pts_lon, "linear")
    np.testing.assert_allclose(x / ARCSEC, 3 * pts_lat - 2 * pts_lon, atol=1e-9)
    x3, _, _ = g.interpolate(pts_lat, pts_lon, "cubic")
    np.testing.assert_allclose(x3 / ARCSEC, 3 * pts_lat - 2 * pts_lon, atol=1e-6)
    assert g.missing_cover(pts_lat, pts_lon) is None
    assert "covers" in g.missing_cover(np.array([35.0]), np.array([109.1]))
    s, n, w, e_ = area_for_track(pts_lat, pts_lon, 1.0)
    assert s < pts_lat.min() and n > pts_lat.max() and w < pts_lon.min() and e_ > pts_lon.max()


def _gdf(**drop):
    lat = np.arange(34.0, 34.1001, 1 / 60)
    lon = np.arange(109.0, 109.1001, 1 / 60)
    return write_gdf(lat, lon, np.zeros((len(lat), len(lon))), "deflection_eta", "arcsec")


@pytest.mark.parametrize(
    "defect,expect",
    [
        ("missing_keyword", "latitude_parallels"),
        ("wrong_count", "grid points but the header promises"),
        ("no_end", "end_of_head"),
        ("text_value", "not numeric"),
    ],
)
def test_malformed_gdf(defect, expect):
    data = _gdf().decode()
    if defect == "missing_keyword":
        data = "\n".join(ln for ln in data.splitlines() if not ln.startswith("latitude_parallels"))
    elif defect == "wrong_count":
        data = "\n".join(data.splitlines()[:-3])
    elif defect == "no_end":
        data = data.replace("end_of_head", "end_of_header_x").replace("end_of_header_x", "xx")
    elif defect == "text_value":
        lines = data.splitlines()
        lines[-1] = lines[-1].rsplit(" ", 1)[0] + " abc"
        data = "\n".join(lines)
    with pytest.raises(BundleError, match=expect) as ei:
        parse_gdf(data.encode(), "eta.gdf")
    assert ei.value.file == "eta.gdf"


def test_constant_dov_schuler_response():
    """A constant ξ on an INS aligned to the true vertical: δN = R ξ (1 − cos ω_s t)."""
    lat0 = np.radians(34.3)
    t = np.arange(0.0, 2 * 5070.0, 1.0)
    n = len(t)
    lat = np.full(n, lat0)
    gam = normal_gravity(lat, 0.0)
    f_n = np.column_stack([np.zeros(n), np.zeros(n), gam])
    w_in = np.column_stack([np.zeros(n), OMEGA_IE * np.cos(lat), OMEGA_IE * np.sin(lat)])
    eps = 10 * ARCSEC
    for coriolis in (False, True):
        to, dn, de, _ = propagate(
            Trajectory(t, lat, np.zeros(n), np.zeros(n), f_n, w_in, gam),
            Deflection(np.full(n, eps), np.zeros(n)),
            0.09,
            True,
            np.zeros(3),
            coriolis,
        )
        ref = schuler_constant_dov(to, eps, lat0)
        # the analytic response ignores Earth rotation: tight over the first half period, and the
        # Earth-rate (Foucault) coupling stays within 5 % of the peak over two periods
        half = to <= 5070.0 / 2
        assert np.abs(dn - ref)[half].max() < 0.01 * ref.max()
        assert np.abs(dn - ref).max() < 0.05 * ref.max()
        if not coriolis:  # without Foucault coupling a north deflection moves the INS north only
            assert np.abs(de).max() < 1e-3 * ref.max()
        else:  # the Foucault rotation Ω sin L · t turns part of it east (≈ 24° after two periods)
            assert 0.1 * ref.max() < np.abs(de).max() < 0.4 * ref.max()
    assert ref.max() == pytest.approx(2 * 6.37e6 * eps, rel=0.01)  # 62 m peak per arcsecond
