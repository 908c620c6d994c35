"""The effects switchboard: names, realistic draws in their documented ranges, overrides, ideal = off."""

import numpy as np
import pytest

from ldvsurvey.nav.sim import catalog
from ldvsurvey.nav.sim.effects import DEG, Effects, GnssEffects, effect_names
from ldvsurvey.nav.sim.scenario import simulate


def test_names_and_switches():
    names = effect_names()
    assert set(names) == {"ldv_dropouts", "body_attitude", "gravity_field", "imu_errors", "imu_timing",
                          "turntable", "gnss", "moving_start"}
    assert Effects.ideal().on() == []
    assert set(Effects.realistic(3).on()) == set(names) - {"moving_start"}
    assert Effects.only("gnss", 3).on() == ["gnss"]
    assert Effects.realistic(3, gnss=False, moving_start=True).on().count("gnss") == 0
    assert "moving_start" in Effects.realistic(3, moving_start=True).on()
    mine = GnssEffects(lever_arm_m=(1.0, 2.0, 3.0))
    assert Effects.realistic(3, gnss=mine).gnss is mine
    with pytest.raises(KeyError, match="unknown effect"):
        Effects.realistic(3, wind=True)


@pytest.mark.parametrize("seed", [1, 2, 3, 4, 5])
def test_realistic_draws_within_documented_ranges(seed):
    e = Effects.realistic(seed)
    b = e.body_attitude
    assert 0.15 * DEG <= abs(b.stance_pitch_rad) <= 0.45 * DEG and 0.1 * DEG <= abs(b.crab_rad) <= 0.4 * DEG
    assert 1 * DEG <= b.squat_rad_per_g <= 3 * DEG and 1 * DEG <= b.roll_rad_per_g <= 3 * DEG
    assert all(1.0 <= f <= 2.0 for f in b.bounce_hz)
    s = e.imu_errors
    assert all(10 <= abs(x) <= 300 for x in s.gyro_scale_ppm + s.accel_scale_ppm)
    assert all(abs(x) <= 50 for x in s.gyro_nonorth_urad + s.accel_nonorth_urad)
    assert 600 <= s.gyro_tau_s <= 3600 and 600 <= s.accel_tau_s <= 3600


def test_all_effects_off_is_the_ideal_drive():
    """A realistic scenario with every switch off gives exactly the ideal scenario's sensor data."""
    kw = dict(minutes=3, static_s=20)
    ideal = simulate(catalog.drive(**kw), seed=4)
    off = simulate(catalog.realistic_drive(seed=4, effects=Effects.ideal(), **kw))
    for a, b in [(ideal.dtheta_rad, off.dtheta_rad), (ideal.dvel_mps, off.dvel_mps),
                 (ideal.ldv_v_fwd, off.ldv_v_fwd), (ideal.ldv_quality, off.ldv_quality),
                 (ideal.gnss_lat_deg, off.gnss_lat_deg)]:
        np.testing.assert_array_equal(a, b)


def test_demo_names_registered():
    assert {"realistic-height", "realistic-gravity", "realistic-drive", "realistic-vessel"} <= set(catalog.SCENARIOS)
    sc = catalog.by_name("realistic-height", seed=2, gnss=False)
    assert sc.effects.gnss is None and sc.effects.seed == 2 and sc.rotating and sc.ldv.kind == "1d"
    sc = catalog.by_name("realistic-gravity", seed=2)
    assert sc.ldv.kind == "2d" and sc.accel_vrw_ug_rthz == 5.0 and len(sc.lines) == 6
    assert catalog.realistic_vessel().effects.body_attitude is None
