"""The effects switchboard: names, realistic draws in their documented ranges, overrides, ideal = off."""

import numpy as np
import pytest

from ldvsurvey.sim import catalog
from ldvsurvey.sim.effects import DEG, Effects, GnssEffects, effect_names
from ldvsurvey.sim.scenario import simulate


def test_names_and_switches():
    names = effect_names()
    assert set(names) == {
        "ldv_dropouts",
        "body_attitude",
        "gravity_field",
        "imu_errors",
        "imu_timing",
        "turntable",
        "gnss",
        "engine_vibration",
        "moving_start",
    }
    assert Effects.ideal().on() == []
    assert set(Effects.realistic(3).on()) == set(names) - {"moving_start", "engine_vibration"}
    assert Effects.only("engine_vibration", 3).on() == ["engine_vibration"]
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
    for a, b in [
        (ideal.dtheta_rad, off.dtheta_rad),
        (ideal.dvel_mps, off.dvel_mps),
        (ideal.ldv_v_fwd, off.ldv_v_fwd),
        (ideal.ldv_quality, off.ldv_quality),
        (ideal.gnss_lat_deg, off.gnss_lat_deg),
    ]:
        np.testing.assert_array_equal(a, b)


def test_demo_names_registered():
    assert {"realistic-height", "realistic-gravity", "realistic-drive", "realistic-vessel"} <= set(catalog.SCENARIOS)
    sc = catalog.by_name("realistic-height", seed=2, gnss=False)
    assert sc.effects.gnss is None and sc.effects.seed == 2 and sc.rotating and sc.ldv.kind == "1d"
    sc = catalog.by_name("realistic-gravity", seed=2)
    assert sc.ldv.kind == "2d" and sc.accel_vrw_ug_rthz == 5.0 and len(sc.lines) == 6
    assert catalog.realistic_vessel().effects.body_attitude is None


def test_demo_writes_bundle_truth_and_grids(tmp_path):
    """``ldv-survey demo DIR --scenario realistic-drive``: a loadable bundle, truth with the effects'
    columns, and ξ/η/Δg grids that the product's .gdf reader accepts."""
    import json

    from ldvsurvey.cli import main
    from ldvsurvey.io.drivelog import load_bundle
    from ldvsurvey.io.gdf import parse_gdf

    out = tmp_path / "d"
    assert main(["demo", str(out), "--scenario", "realistic-drive", "--seed", "3", "--duration-s", "480"]) == 0
    load_bundle(out)
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["gnss"]["lever_arm_m"] == [0.3, 0.8, 1.6]
    for name in ("xi.gdf", "eta.gdf", "dg.gdf"):
        parse_gdf((out / "grids" / name).read_bytes(), name)
    meta = json.loads((out / "truth" / "truth.json").read_text())
    assert set(meta["effects"]) == set(effect_names()) and meta["ldv_effective"]["n_samples"] > 0
    cols = np.genfromtxt(out / "truth" / "truth.csv", delimiter=",", names=True, skip_header=1)
    for c in (
        "dg_mgal",
        "xi_arcsec",
        "eta_arcsec",
        "ldv_travel_pitch_deg",
        "head_travel_pitch_deg",
        "body_pitch_deg",
        "gyro_gm_x_dph",
        "accel_gm_z_ug",
    ):
        assert c in cols.dtype.names
    moving = np.hypot(cols["v_e_mps"], cols["v_n_mps"]) > 2.0
    # in the head's own axes the travel direction is the body's attitude over its path, reversed
    np.testing.assert_allclose(cols["head_travel_pitch_deg"][moving], -cols["body_pitch_deg"][moving], atol=0.01)
    np.testing.assert_allclose(cols["head_travel_heading_deg"][moving], cols["body_yaw_deg"][moving], atol=0.01)
    with pytest.raises(Exception, match="fixed length"):
        from ldvsurvey.demo import write_demo

        write_demo(tmp_path / "g", scenario="realistic-gravity", duration_s=600.0)
