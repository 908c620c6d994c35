"""The unit constants against their definitions (SI, ISO 80000-3, standard gravity per CGPM 1901)."""

import math

from ldvsurvey import units as u


def test_angles():
    assert math.isclose(180.0 * u.RAD_PER_DEG, math.pi, rel_tol=1e-15)
    assert math.isclose(math.pi * u.DEG_PER_RAD, 180.0, rel_tol=1e-15)
    assert math.isclose(1296000.0 * u.RAD_PER_ARCSEC, 2 * math.pi, rel_tol=1e-15)  # 360·3600″ = full turn
    assert math.isclose(21600.0 * u.RAD_PER_ARCMIN, 2 * math.pi, rel_tol=1e-15)
    assert math.isclose(u.ARCSEC_PER_RAD, 206264.80624709636, rel_tol=1e-15)  # ρ″ = 648000/π
    assert (u.DEG_TO_RAD, u.RAD_TO_DEG) == (u.RAD_PER_DEG, u.DEG_PER_RAD)


def test_gravity_and_accelerations():
    assert u.G0_MPS2 == 9.80665
    assert math.isclose(100.0 * u.MPS2_PER_MGAL, 1e-3, rel_tol=1e-15)  # 1 Gal = 1 cm/s²
    assert math.isclose(u.MPS2_PER_MGAL * u.MGAL_PER_MPS2, 1.0, rel_tol=1e-15)
    assert math.isclose(1e6 * u.MPS2_PER_UG, 9.80665, rel_tol=1e-15)
    assert math.isclose(u.MPS2_PER_UG * u.UG_PER_MPS2, 1.0, rel_tol=1e-15)


def test_gyro_units():
    earth_rate_dph = 15.041067  # sidereal rotation, °/h
    assert math.isclose(earth_rate_dph * u.RPS_PER_DPH, 7.292115e-5, rel_tol=1e-6)
    assert math.isclose(u.RPS_PER_DPH * u.DPH_PER_RPS, 1.0, rel_tol=1e-15)
    # 1 °/√h = (π/180) rad / √(3600 s)
    assert math.isclose(u.RAD_RTS_PER_DPRH, (math.pi / 180.0) / math.sqrt(3600.0), rel_tol=1e-15)
    assert math.isclose(250.0 * u.PER_PPM, 2.5e-4, rel_tol=1e-15) and u.PPM_PER_UNIT * u.PER_PPM == 1.0
