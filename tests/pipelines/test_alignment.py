"""Alignment by what the sensors can observe, on a standstill found in the data (issue 34).

Simulated drives with known truth: a consumer-MEMS IMU (gyro turn-on bias 500 °/h, accelerometer
scale +1.4 %, 4-Hz RTK fixes, no LDV) with an engine idling through a 35-s stop at the start, no
``initial.static_s``; the same stop followed by a 0.3 m/s creep; a navigation-grade IMU at a
2-min standstill; a log that starts on the move. The truth is the simulator's: the timeline of its
pieces (where the vehicle stands), its body attitude, its drawn sensor biases.
"""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest

from ldvsurvey.io.drivelog import parse_files
from ldvsurvey.nav.attitude import euler_from_c_bn
from ldvsurvey.pipelines.base import run_pipeline
from ldvsurvey.pipelines.registry import get
from ldvsurvey.pipelines.stages.aids import initial_attitude, nav_inputs
from ldvsurvey.pipelines.stages.start import body_force_and_rate, detect_static_start, gnss_still_speed
from ldvsurvey.sim import catalog
from ldvsurvey.sim.effects import Effects, EngineVibration, ImuErrorSpec
from ldvsurvey.sim.motion import Drive, Static
from ldvsurvey.sim.scenario import bundle_files, simulate

DEG = np.pi / 180
STOP_S = 35.0


def _mems_drive(creep: bool = False, seed: int = 3, minutes: float = 4.0):
    """A consumer-MEMS car drive: 35 s idling, (a 0.3 m/s creep over 12 m,) then 12 m/s."""
    sc = catalog.drive(
        minutes=minutes,
        static_s=STOP_S,
        speed_mps=12.0,
        with_ldv=False,
        gyro_bias_dph=500.0,
        accel_bias_ug=3000.0,
        gyro_arw_dprh=0.5,
        accel_vrw_ug_rthz=100.0,
        gnss_rate_hz=4.0,
    )
    eff = Effects(
        engine_vibration=EngineVibration(),
        imu_errors=ImuErrorSpec(accel_scale_ppm=(14000.0,) * 3, gyro_scale_ppm=(3000.0, -2000.0, 4000.0)),
        seed=seed,
    )
    segs = [Static(STOP_S)] + ([Drive(12.0, 0.3, 2.0)] if creep else [])
    segs.append(Drive(12.0 * (minutes * 60.0 - STOP_S - 80.0), 12.0, 10.0))
    return simulate(dataclasses.replace(sc, effects=eff, segments=segs), seed=seed)


def _without_static_s(sim) -> dict:
    files = bundle_files(sim)
    m = json.loads(files["manifest.json"])
    del m["initial"]["static_s"]
    files["manifest.json"] = json.dumps(m).encode()
    return files


def _pieces(sim):
    t0 = sim.scenario.t0_s
    return [(a - t0, b - t0, kind) for a, b, kind, _ in sim.motion.pieces]


def _heading_error(c_bn, sim, j: int = 0) -> float:
    _, _, h = euler_from_c_bn(c_bn)
    _, _, ht = euler_from_c_bn(sim.imu.c_bn[j])
    return float((h - ht + np.pi) % (2 * np.pi) - np.pi)


@pytest.fixture(scope="module")
def mems():
    sim = _mems_drive()
    return sim, parse_files(_without_static_s(sim))


def test_idling_stop_found_and_heading_from_the_course(mems):
    """No ``initial.static_s``: the idling stop is found from the 4-Hz RTK speed and the IMU's steady
    1-s means (on main: "no static period", the GNSS speed differenced epoch to epoch reads motion);
    the gyros cannot gyrocompass (500 °/h against 13 °/h of horizontal Earth rate), so the heading is
    the GNSS course at move-off carried back by the gyros, within 3 σ of the truth; the initial gyro
    biases are the simulator's within 3 σ."""
    sim, log = mems
    (a, b, kind), *_ = _pieces(sim)
    assert kind == "static" and b == pytest.approx(STOP_S)
    inp = nav_inputs(log)
    al = inp.alignment
    t0 = sim.scenario.t0_s
    s0, s1 = (x - t0 for x in al.standstill_s)
    print(
        f"standstill found [{s0:.2f}, {s1:.2f}] s against the simulated [{a:.2f}, {b:.2f}] s,",
        f"by {al.standstill_found_by}",
    )
    # the stage ends a standstill 2 s before the first motion it sees (a smooth start at 10 m/s per 10 s)
    assert s0 == pytest.approx(0.0, abs=0.05) and b - 4.0 <= s1 <= b
    assert "GNSS" in al.standstill_found_by
    assert al.method == "gnss_course"
    assert al.gyrocompass_sigma_rad > 30 * DEG
    err = _heading_error(al.c_bn, sim)
    print(f"heading error {err / DEG:+.3f}° against σ {al.heading_sigma_rad / DEG:.3f}°")
    assert abs(err) <= 3.0 * al.heading_sigma_rad
    assert al.heading_sigma_rad < 2.0 * DEG  # a usable heading, not a shrug
    n = int(np.searchsorted(sim.imu.t_s, al.standstill_s[1]))
    truth = sim.errors.gyro_bias_rps + sim.extras["imu_errors"]["gyro_gm_rps"][:n].mean(axis=0)
    e_b = al.gyro_bias_rps - truth
    dph = 180 / np.pi * 3600
    print(f"initial gyro bias error {e_b * dph} °/h against σ {al.gyro_bias_sigma_rps * dph} °/h")
    assert np.all(np.abs(e_b) <= 3.0 * al.gyro_bias_sigma_rps)


def test_navigate_summary_states_the_weak_alignment(mems):
    """``navigate`` runs without a hand-given static period and says how it aligned: method, heading
    σ, the standstill, the initial gyro biases with σ, the filter's bias σ, and a warning that the
    gyros cannot find north; the forward filter's heading then follows the truth within its σ."""
    sim, log = mems
    r = run_pipeline(get("navigate"), [log], {"smooth": False})
    s = r.summary
    assert s["alignment_method"] == "gnss_course"
    assert 0.0 < s["alignment_heading_sigma_deg"] < 2.0
    assert len(s["standstill_s"]) == 2 and s["standstill_found_by"]
    assert len(s["initial_gyro_bias_dph"]) == 3 and len(s["initial_gyro_bias_sigma_dph"]) == 3
    assert all(v > 0 for v in s["gyro_bias_sigma_end_of_alignment_dph"] + s["gyro_bias_sigma_end_dph"])
    assert any("cannot find north" in w and "GNSS course" in w for w in s["warnings"])
    tab = r.tables["trajectory"]
    k = np.clip(np.searchsorted(sim.imu.t_s, tab["t_s"]), 0, len(sim.imu.t_s) - 1)
    _, _, ht = euler_from_c_bn(sim.imu.c_bn[k])
    dh = (tab["heading_deg"] * DEG - ht + np.pi) % (2 * np.pi) - np.pi
    late = tab["t_s"] > sim.scenario.t0_s + 60.0
    rms = float(np.sqrt(np.mean(dh[late] ** 2)))
    print(f"forward filter heading error after 60 s: RMS {rms / DEG:.3f}°, largest {np.max(np.abs(dh)) / DEG:.3f}°")
    # heading held through the idling stop (no drift read into it from the vibration) and after
    assert np.all(np.abs(dh) <= 3.0 * tab["heading_sigma_deg"] * DEG + 0.05 * DEG)
    assert rms < 1.0 * DEG


def test_idling_engine_is_not_motion_for_the_imu(mems):
    """Without any speed (no GNSS judgement, no LDV), the IMU's own test keeps the whole idling stop:
    the engine shakes the sensor by metres per second squared and degrees per second per sample,
    but the 1-s means stay put."""
    sim, log = mems
    t = log.imu.t_s
    f_b, w_z = body_force_and_rate(t, log.imu.dtheta_rad, log.imu.dvel_mps, None)
    rate = np.std(log.imu.dtheta_rad[t < t[0] + 30.0] / 0.01, axis=0) / DEG
    print(f"gyro σ per sample at rest {rate} °/s")
    assert np.max(rate) > 0.5  # the vibration is there
    end = detect_static_start(t, f_b, w_z, np.zeros(len(t)), np.zeros(len(t), bool))
    k = int(np.searchsorted(sim.imu.t_s, end))
    v_end = float(np.linalg.norm(sim.imu.v_n[k]))
    print(f"IMU alone: standstill ends at {end - sim.scenario.t0_s:.2f} s (true speed there {v_end:.4f} m/s)")
    # the whole stop kept; an IMU alone sees a smooth move-off late: the vehicle has barely moved by then
    assert end - sim.scenario.t0_s >= STOP_S - 4.0 and v_end < 0.02


def test_a_creeping_vehicle_is_not_standing():
    """A 0.3 m/s creep after the idling stop is motion: the standstill ends before it and the GNSS
    speed is above its still limit all through it."""
    sim = _mems_drive(creep=True, minutes=4.0)
    log = parse_files(_without_static_s(sim))
    (_, b, _), (c0, c1, kind), *_ = _pieces(sim)
    assert kind == "drive" and c1 - c0 > 30.0
    t = log.imu.t_s
    ok, v, lim = gnss_still_speed(log, t)
    rel = t - sim.scenario.t0_s
    creep = (rel > c0 + 5.0) & (rel < c1 - 5.0)  # the ramps (2 s) and the 2-s speed span off
    assert ok[creep].all() and np.all(v[creep] > lim[creep])
    assert np.all(v[(rel > 3.0) & (rel < b - 3.0)] < lim[(rel > 3.0) & (rel < b - 3.0)])
    inp = nav_inputs(log)
    s1 = inp.alignment.standstill_s[1] - sim.scenario.t0_s
    print(f"standstill ends at {s1:.2f} s, the creep starts at {c0:.2f} s")
    assert b - 4.0 <= s1 <= b
    err = _heading_error(inp.alignment.c_bn, sim)
    assert abs(err) <= 3.0 * inp.alignment.heading_sigma_rad


def test_navigation_grade_gyrocompasses():
    """A navigation-grade IMU (0.003 °/h) at a 2-min standstill: gyrocompassing is chosen, its heading
    within 3 σ of the truth and σ well under a degree; no warning about the alignment."""
    sim = simulate(catalog.drive(minutes=4.0, static_s=120.0, with_ldv=False), seed=4)
    inp = nav_inputs(parse_files(_without_static_s(sim)))
    al = inp.alignment
    assert al.method == "gyrocompass" and al.c_bn is None
    err = _heading_error(initial_attitude(inp, None), sim)
    print(f"gyrocompass heading error {err / DEG * 60:+.3f}′ against σ {al.heading_sigma_rad / DEG * 60:.3f}′")
    assert al.heading_sigma_rad < 0.1 * DEG
    assert abs(err) <= 3.0 * al.heading_sigma_rad
    assert not any("north" in w or "heading" in w for w in inp.warnings)


def test_a_log_that_starts_on_the_move_keeps_its_alignment():
    """Cut 50 s after moving off (no standstill): the alignment on the move as before, said so."""
    from ldvsurvey.io.writers import imu_csv, nmea_text
    from ldvsurvey.sim.scenario import GEOID_SEPARATION_M

    sim = simulate(catalog.drive(minutes=4.0, static_s=60.0, with_ldv=False), seed=8)
    t_cut = sim.scenario.t0_s + 110.0
    ki, kg = sim.imu.t_s > t_cut, sim.gnss_t_s > t_cut
    m = json.loads(bundle_files(sim)["manifest.json"])
    m["initial"] = {}
    f = {
        "manifest.json": json.dumps(m).encode(),
        "imu.csv": imu_csv(sim.imu.t_s[ki], sim.dtheta_rad[ki], sim.dvel_mps[ki]),
        "gnss.nmea": nmea_text(
            sim.gnss_t_s[kg],
            sim.gnss_lat_deg[kg],
            sim.gnss_lon_deg[kg],
            sim.gnss_h_m[kg],
            sim.gnss_fix[kg],
            sep_m=GEOID_SEPARATION_M,
            talker="GN",
        ),
    }
    inp = nav_inputs(parse_files(f))
    al = inp.alignment
    assert al.method == "moving_start" and al.standstill_s is None
    assert abs(_heading_error(inp.c_bn0, sim, int(np.flatnonzero(ki)[0]))) < 0.3 * DEG
    assert al.summary()["alignment_heading_sigma_deg"] == pytest.approx(3.0)


def test_a_manifest_heading_overrides_and_a_bad_one_is_refused(mems):
    """``initial.heading_deg`` (with ``initial.heading_sigma_deg``) is the start heading as given,
    whatever the gyros or the course say; a heading that is no number is refused naming the field."""
    from ldvsurvey.errors import ParameterError

    sim, _ = mems
    files = _without_static_s(sim)
    m = json.loads(files["manifest.json"])
    m["initial"].update(heading_deg=33.0, heading_sigma_deg=0.5)
    files["manifest.json"] = json.dumps(m).encode()
    al = nav_inputs(parse_files(files)).alignment
    assert al.method == "manifest" and al.heading_sigma_rad == pytest.approx(0.5 * DEG)
    assert euler_from_c_bn(al.c_bn)[2] == pytest.approx(33.0 * DEG, abs=1e-12)
    m["initial"]["heading_deg"] = "north"
    files["manifest.json"] = json.dumps(m).encode()
    with pytest.raises(ParameterError) as exc:
        nav_inputs(parse_files(files))
    assert exc.value.field == "initial.heading_deg"


def test_no_north_and_no_course_is_said(mems):
    """The MEMS log without its GNSS (start position from the manifest, no LDV): the IMU alone finds
    the idling stop, the gyros cannot find north and there is no course: the alignment says the
    heading is not observable (σ beyond 10°), and the warning says what to give."""
    sim, _ = mems
    files = _without_static_s(sim)
    del files["gnss.nmea"]
    inp = nav_inputs(parse_files(files))
    al = inp.alignment
    assert al.method == "gyrocompass" and not al.observable
    assert al.heading_sigma_rad > 10 * DEG
    assert "IMU" in al.standstill_found_by and "no speed" in al.standstill_found_by
    assert STOP_S - 4.0 <= al.standstill_s[1] - sim.scenario.t0_s <= STOP_S + 0.5
    assert any("heading not observable" in w and "initial.heading_deg" in w for w in inp.warnings)
    # the horizontal Earth rate stays in the bias estimate's σ: the truth is inside it
    n = int(np.searchsorted(sim.imu.t_s, al.standstill_s[1]))
    truth = sim.errors.gyro_bias_rps + sim.extras["imu_errors"]["gyro_gm_rps"][:n].mean(axis=0)
    assert np.all(np.abs(al.gyro_bias_rps - truth) <= 3.0 * al.gyro_bias_sigma_rps)


def test_a_horizontal_bias_the_manifest_does_not_state_stops_gyrocompassing():
    """A navigation-grade log whose x gyro reads 300 °/h more (a bias of its own, its vertical gyro
    quiet) and whose manifest states no gyro bias: the standstill's horizontal rate, 20 times the
    Earth's, shows the gyros cannot find north, so the heading comes from the course."""
    from ldvsurvey.io.writers import imu_csv

    sim = simulate(catalog.drive(minutes=4.0, static_s=60.0, with_ldv=False), seed=6)
    files = _without_static_s(sim)
    m = json.loads(files["manifest.json"])
    del m["imu"]["gyro_bias_dph"]
    files["manifest.json"] = json.dumps(m).encode()
    dth = sim.dtheta_rad.copy()
    dth[:, 0] += 300.0 * DEG / 3600.0 * 0.01
    files["imu.csv"] = imu_csv(sim.imu.t_s, dth, sim.dvel_mps)
    al = nav_inputs(parse_files(files)).alignment
    assert al.gyrocompass_sigma_rad > 30 * DEG and al.method == "gnss_course"
    assert abs(_heading_error(al.c_bn, sim)) <= 3.0 * al.heading_sigma_rad
