"""Normal gravity γ(φ, h) against the WGS 84 defining document, not against the code's own constants.

Source: NIMA TR8350.2, "Department of Defense World Geodetic System 1984", 3rd ed. (2000): Table 3.4
(normal gravity at the equator γ_e = 9.7803253359 m/s², at the poles γ_p = 9.8321849379 m/s²), Table 3.1/3.3
(a = 6378137 m, 1/f = 298.257223563, b = 6356752.3142 m, m = ω²a²b/GM = 0.00344978650684), Eq. (4-1)
(Somigliana's closed formula) and Eq. (4-3) (the height correction to second order,
γ_h = γ[1 − 2/a (1 + f + m − 2f sin²φ) h + 3h²/a²]). The tests of the ties build their truth with
the code's ``normal_gravity``, so an error there would cancel in them: this pins it from outside.
"""

import numpy as np
import pytest

from ldvsurvey.nav.earth import normal_gravity

GAMMA_E = 9.7803253359  # TR8350.2 Table 3.4, m/s²
GAMMA_P = 9.8321849379  # TR8350.2 Table 3.4, m/s²
A = 6378137.0  # m
B = 6356752.3142  # m, TR8350.2 Table 3.3
F = 1.0 / 298.257223563
M = 0.00344978650684  # TR8350.2 Table 3.3


def somigliana(lat_rad):
    """TR8350.2 Eq. (4-1) in Somigliana's own form (a, b, γ_e, γ_p): γ on the ellipsoid, m/s²."""
    c2, s2 = np.cos(lat_rad) ** 2, np.sin(lat_rad) ** 2
    return (A * GAMMA_E * c2 + B * GAMMA_P * s2) / np.sqrt(A**2 * c2 + B**2 * s2)


def test_normal_gravity_at_the_equator_and_the_poles():
    assert normal_gravity(0.0, 0.0) == pytest.approx(GAMMA_E, abs=1e-10)
    assert normal_gravity(np.pi / 2, 0.0) == pytest.approx(GAMMA_P, abs=1e-9)
    assert normal_gravity(-np.pi / 2, 0.0) == pytest.approx(GAMMA_P, abs=1e-9)


def test_normal_gravity_on_the_ellipsoid_follows_somigliana():
    lat = np.radians(np.linspace(-90.0, 90.0, 37))
    # 1e-8 m/s² = 1 µGal: the document's constants are given to 10 digits
    np.testing.assert_allclose(normal_gravity(lat, 0.0), somigliana(lat), rtol=0, atol=1e-8)


def test_free_air_gradient_at_45_degrees():
    """∂γ/∂h at 45° from Eq. (4-3): −2γ/a (1 + f + m − f), about −0.3086 mGal/m; the central difference over
    ±100 m cancels the symmetric second-order term, so code and document must agree to 1e-6 relative."""
    lat = np.radians(45.0)
    expected = -2.0 * somigliana(lat) / A * (1.0 + F + M - 2.0 * F * 0.5)
    got = (normal_gravity(lat, 100.0) - normal_gravity(lat, -100.0)) / 200.0
    assert got == pytest.approx(expected, rel=1e-6)
    assert expected * 1e5 == pytest.approx(-0.3086, abs=5e-4)  # mGal/m: the figure the warnings quote
    # and the second-order term: γ(h) + γ(−h) − 2γ(0) = 6γh²/a²
    h = 1000.0
    curv = normal_gravity(lat, h) + normal_gravity(lat, -h) - 2 * normal_gravity(lat, 0.0)
    assert curv == pytest.approx(6 * somigliana(lat) * h**2 / A**2, rel=1e-6)
