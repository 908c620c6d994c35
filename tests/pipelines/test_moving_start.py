"""A log that begins on the move (no static period): coarse alignment from the GNSS course and the
LDV speed, then the filter. Truth: the simulator's attitude, velocity and position.

The log is a simulated drive cut 50 s after the vehicle moved off (15 m/s, past its speed ramp);
the manifest gives neither ``initial.static_s`` nor a start position.
"""

import numpy as np
import pytest

from ldvsurvey.errors import ParameterError
from ldvsurvey.io.drivelog import parse_files
from ldvsurvey.nav.attitude import euler_from_c_bn
from ldvsurvey.nav.earth import enu_offset_m
from ldvsurvey.pipelines.base import run_pipeline
from ldvsurvey.pipelines.registry import get
from ldvsurvey.pipelines.stages.aids import nav_inputs
from ldvsurvey.sim import catalog
from ldvsurvey.sim.scenario import bundle_files, simulate
from tests.pipelines.helpers import files_from

DEG = np.pi / 180


@pytest.fixture(scope="module")
def moving():
    sim = simulate(catalog.drive(minutes=6.0, static_s=60.0), seed=8)
    f, j = files_from(sim, sim.scenario.t0_s + 110.0)
    return sim, f, j


def _wrap(a):
    return (a + np.pi) % (2 * np.pi) - np.pi


def test_coarse_alignment_on_the_move(moving):
    sim, f, j = moving
    inp = nav_inputs(parse_files(f))
    p, r, h = euler_from_c_bn(inp.c_bn0)
    pt, rt, ht = euler_from_c_bn(sim.imu.c_bn[j])
    # level: the neglected Coriolis term 2 ω_ie v ≈ 2e-3 m/s² is 0.013° of tilt
    assert abs(p - pt) < 0.03 * DEG and abs(r - rt) < 0.03 * DEG
    # heading: course over 1 s from RTK fixes (1 cm white noise at 15 m/s ≈ 0.05°) and the road's turn in 1 s
    assert abs(_wrap(h - ht)) < 0.2 * DEG
    assert np.linalg.norm(inp.v0_n - sim.imu.v_n[j]) < 0.05
    d = enu_offset_m(sim.imu.lat_rad[j], sim.imu.lon_rad[j], sim.imu.h_m[j], *inp.pos0)
    assert np.hypot(d[0], d[1]) < 0.1 and abs(d[2]) < 0.15  # RTK σ 2/3 cm, lever arm applied


def test_navigation_after_a_moving_start(moving):
    sim, f, _ = moving
    res = run_pipeline(get("navigate"), [parse_files(f)], {"aiding": "ldv+gnss", "calibration": "nominal"})
    assert any("coarse alignment on the move" in w for w in res.summary["warnings"])
    tab = res.tables["trajectory"]
    k = np.searchsorted(sim.imu.t_s, tab["t_s"])
    pt, rt, ht = euler_from_c_bn(sim.imu.c_bn[k])
    late = tab["t_s"] > tab["t_s"][0] + 60.0
    assert np.abs(np.radians(tab["pitch_deg"]) - pt)[late].max() < 0.005 * DEG
    assert np.abs(np.radians(tab["roll_deg"]) - rt)[late].max() < 0.005 * DEG
    assert np.abs(_wrap(np.radians(tab["heading_deg"]) - ht))[late].max() < 0.02 * DEG
    d = enu_offset_m(
        sim.imu.lat_rad[k],
        sim.imu.lon_rad[k],
        sim.imu.h_m[k],
        np.radians(tab["lat_deg"]),
        np.radians(tab["lon_deg"]),
        tab["h_m"],
    )
    assert np.abs(d).max() < 0.15


def test_moving_start_without_gnss_names_what_is_missing(moving):
    _, f, _ = moving
    f = {k: v for k, v in f.items() if k != "gnss.nmea"}
    with pytest.raises(ParameterError) as ei:
        nav_inputs(parse_files(f))
    assert ei.value.file == "gnss.nmea" and "no static period" in ei.value.message


def test_realistic_moving_start_of_the_rotating_height_drive():
    """The simulator's own moving-start effect (``initial.static_s`` = 0, rotating IMU, LDV mounted
    0.35° nose-up, nominal 0): the coarse alignment is coarser, the filter still converges."""
    from ldvsurvey.sim.effects import Effects

    sc = catalog.realistic_height(
        seed=4, effects=Effects.only("moving_start", 4), minutes=14.0, length_m=3500.0, relief_m=15.0
    )
    sim = simulate(sc, seed=7)
    res = run_pipeline(get("navigate"), [parse_files(bundle_files(sim))], {"aiding": "ldv+gnss"})
    tab = res.tables["trajectory"]
    k = np.clip(np.searchsorted(sim.imu.t_s, tab["t_s"]), 0, len(sim.imu.t_s) - 1)
    pt, rt, ht = euler_from_c_bn(sim.imu.c_bn[k])
    late = tab["t_s"] > tab["t_s"][0] + 120.0
    assert np.abs(np.radians(tab["pitch_deg"]) - pt)[late].max() < 0.01 * DEG
    assert np.abs(np.radians(tab["roll_deg"]) - rt)[late].max() < 0.01 * DEG
    assert np.abs(_wrap(np.radians(tab["heading_deg"]) - ht))[late].max() < 0.02 * DEG
    assert res.summary["rms_horizontal_error_m"] < 0.1
