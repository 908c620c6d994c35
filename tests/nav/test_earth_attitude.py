"""Earth model and attitude conventions against independent references and identities."""

import boule
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from ldvsurvey.nav import attitude as att
from ldvsurvey.nav import earth

RAD = np.pi / 180


@pytest.mark.parametrize("lat_deg", [-89.0, -45.0, 0.0, 28.4861, 34.3, 60.0, 90.0])
@pytest.mark.parametrize("h_m", [0.0, 120.0, 2000.0, 5000.0])
def test_normal_gravity_matches_boule(lat_deg, h_m):
    # boule: closed form (Lakshmanan, Li & Götze), independent of the second-order expansion
    ref_mgal = boule.WGS84.normal_gravity((113.0, lat_deg, h_m))
    ours_mgal = earth.normal_gravity(lat_deg * RAD, h_m) / earth.MGAL
    # exact on the ellipsoid; above it the second-order expansion of methods §0 drops
    # O(f²) terms of the free-air gradient: < 1.5e-5 mGal per metre of height (measured 1.05e-5 at the equator)
    assert ours_mgal == pytest.approx(ref_mgal, abs=1e-6 + 1.5e-5 * h_m)


def test_radii_and_ecef_from_the_ellipse_geometry():
    """WGS84 radii and ECEF against the meridian ellipse in its parametric (reduced-latitude) form,
    x = a cos β, z = b sin β with tan φ = (a/b) tan β: the curvature radius of that ellipse is
    M = (a² sin²β + b² cos²β)^{3/2} / (ab) and the normal meets the axis at N = x / cos φ. Also the
    published values at the equator (b²/a, a) and the pole (a²/b). An independent route to the same
    numbers: differentiating the code's own lla_to_ecef would only repeat its formulas."""
    a = 6378137.0
    f = 1 / 298.257223563
    b = a * (1 - f)
    for lat_deg in (0.0, 28.18, 34.3, 45.0, 61.7, 89.9):
        lat = lat_deg * RAD
        beta = np.arctan((b / a) * np.tan(lat))
        m = (a**2 * np.sin(beta) ** 2 + b**2 * np.cos(beta) ** 2) ** 1.5 / (a * b)
        n = a * np.cos(beta) / np.cos(lat)
        rm, rn = earth.radii(lat)
        assert rm == pytest.approx(m, rel=1e-12) and rn == pytest.approx(n, rel=1e-12)
        h, lon = 500.0, 109.1 * RAD
        rho, z = a * np.cos(beta) + h * np.cos(lat), b * np.sin(beta) + h * np.sin(lat)
        np.testing.assert_allclose(
            earth.lla_to_ecef(lat, lon, h), [rho * np.cos(lon), rho * np.sin(lon), z], rtol=0, atol=1e-6
        )
    assert earth.radii(0.0)[0] == pytest.approx(6335439.327, abs=1e-3)
    assert earth.radii(0.0)[1] == pytest.approx(6378137.000, abs=1e-3)
    assert earth.radii(np.pi / 2)[0] == pytest.approx(6399593.626, abs=1e-3)


def test_gravity_vector_components():
    g = earth.gravity_n(0.5, 100.0, xi_rad=1e-5, eta_rad=-2e-5, dg_mps2=3e-4)
    gam = earth.normal_gravity(0.5, 100.0)
    np.testing.assert_allclose(g, [2e-5 * gam, -1e-5 * gam, -(gam + 3e-4)])


def test_spec_checks_of_c_bn():
    # heading 90° puts the forward axis on East; pitch > 0 lifts it; roll > 0 lowers the right axis
    np.testing.assert_allclose(att.c_bn_from_euler(0, 0, np.pi / 2) @ [0, 1, 0], [1, 0, 0], atol=1e-15)
    assert (att.c_bn_from_euler(0.1, 0, 0) @ [0, 1, 0])[2] > 0
    assert (att.c_bn_from_euler(0, 0.1, 0) @ [1, 0, 0])[2] < 0
    # heading is clockwise from north: 30° heading points forward between N and E
    f = att.c_bn_from_euler(0, 0, 30 * RAD) @ [0, 1, 0]
    np.testing.assert_allclose(f, [np.sin(30 * RAD), np.cos(30 * RAD), 0], atol=1e-15)


def test_c_bn_is_zxy_sequence_and_round_trips():
    rng = np.random.default_rng(0)
    p, r, h = rng.uniform(-1.4, 1.4, 200), rng.uniform(-3, 3, 200), rng.uniform(0, 2 * np.pi, 200)
    c = att.c_bn_from_euler(p, r, h)
    # independent: intrinsic z (yaw = −heading), x (pitch), y (roll)
    ref = Rotation.from_euler("ZXY", np.column_stack([-h, p, r])).as_matrix()
    np.testing.assert_allclose(c, ref, atol=1e-14)
    p2, r2, h2 = att.euler_from_c_bn(c)
    np.testing.assert_allclose(p2, p, atol=1e-12)
    np.testing.assert_allclose(r2, r, atol=1e-12)
    np.testing.assert_allclose(h2, h, atol=1e-12)
    q = att.q_from_c(c)
    np.testing.assert_allclose(att.c_from_q(q), c, atol=1e-14)
    sq = Rotation.from_matrix(c).as_quat()  # scipy: [x, y, z, w]
    np.testing.assert_allclose(np.abs(np.sum(q * np.column_stack([sq[:, 3], sq[:, :3]]), axis=1)), 1.0, atol=1e-12)


def test_c_bs_is_the_spec_matrix_and_small_angle_form():
    eta, a, b = 0.7, 3e-3, -2e-3
    # spec: R_y(β) R_x(α) R_z(η), passive elementary rotations
    rx = Rotation.from_euler("x", -a).as_matrix()
    ry = Rotation.from_euler("y", -b).as_matrix()
    rz = Rotation.from_euler("z", -eta).as_matrix()
    np.testing.assert_allclose(att.c_bs(eta, a, b), ry @ rx @ rz, atol=1e-15)
    # small-angle form (paper eq. 13)
    ce, se = np.cos(eta), np.sin(eta)
    eq13 = np.array([[ce, se, -b], [-se, ce, a], [b * ce + a * se, b * se - a * ce, 1]])
    np.testing.assert_allclose(att.c_bs(eta, a, b), eq13, atol=1e-5)


def test_tilt_identity_delta_c():
    """ΔC = C_s^n(η) + C_s^n(η+π) = C_b^n [[0,0,0],[0,0,0],[−2β, 2α, 2]] (small angles)."""
    c_bn = att.c_bn_from_euler(0.01, -0.02, 1.0)
    a, b = 4e-4, -6e-4
    dc = c_bn @ att.c_bs(0.3, a, b).T + c_bn @ att.c_bs(0.3 + np.pi, a, b).T
    m = np.zeros((3, 3))
    m[2] = [-2 * b, 2 * a, 2]
    np.testing.assert_allclose(dc, c_bn @ m, atol=1e-6)


def test_rotvec_and_attitude_error():
    rng = np.random.default_rng(1)
    v = rng.normal(0, 0.5, (50, 3))
    np.testing.assert_allclose(att.c_to_rotvec(att.rotvec_to_c(v)), v, atol=1e-12)
    np.testing.assert_allclose(att.rotvec_to_c(v), Rotation.from_rotvec(v).as_matrix(), atol=1e-14)
    c = att.c_bn_from_euler(0.1, 0.2, 0.3)
    phi = np.array([1e-5, -2e-5, 3e-5])
    c_est = (np.eye(3) - att.skew(phi)) @ c
    np.testing.assert_allclose(att.attitude_error_rad(c_est, c), phi, atol=1e-12)


def _q_to_c_reference(q):
    """The quaternion-to-matrix formula as both compiled copies wrote it before they became one,
    in plain Python floats (IEEE double, no contraction: what the compiled code must reproduce)."""
    w, x, y, z = (float(a) for a in q)
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
        ]
    )


def test_q_to_c_and_its_in_place_form_are_one_formula():
    from ldvsurvey.nav import damping, kfloop

    # the filter loops compile this very function (no copy of the formula of their own)
    assert kfloop.q_to_c_into is att.q_to_c_into and damping.q_to_c_into is att.q_to_c_into
    rng = np.random.default_rng(7)
    qs = rng.normal(size=(200, 4))
    qs /= np.linalg.norm(qs, axis=1, keepdims=True)
    c = np.full((3, 3), np.nan)
    for q in qs:
        ref = _q_to_c_reference(q)
        np.testing.assert_array_equal(att.q_to_c(q), ref)  # bit for bit
        att.q_to_c_into(q, c)
        np.testing.assert_array_equal(c, ref)
    # and the formula is the rotation of q (scipy wants scalar-last quaternions)
    np.testing.assert_allclose(
        [att.q_to_c(q) for q in qs], Rotation.from_quat(qs[:, [1, 2, 3, 0]]).as_matrix(), rtol=0, atol=1e-15
    )
