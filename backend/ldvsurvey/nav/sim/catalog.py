"""Named scenarios of the simulator (the product's demo surveys and test scenarios)."""

from __future__ import annotations

import numpy as np

from ldvsurvey.nav.sim.motion import Drive, Static, TurnInPlace
from ldvsurvey.nav.sim.road import Ramps, Road
from ldvsurvey.nav.sim.scenario import Scenario
from ldvsurvey.nav.sim.sensors import LdvSpecSim

RAD = np.pi / 180.0


def drive(minutes: float = 40.0, speed_mps: float = 15.0, **kw) -> Scenario:
    """A vehicle drive with turns and grades: 5 min static, then driving along a winding road."""
    static = kw.pop("static_s", 300.0)
    length = speed_mps * (minutes * 60.0 - static) + 2000.0
    heading = Ramps(30 * RAD, [(s, 250.0, d * RAD) for s, d in
                               zip(np.arange(1500.0, length - 1000, 3100.0), [60, -90, 45, -30, 80, -70, 50, -40] * 20)])
    grade = Ramps(0.0, [(s, 400.0, g) for s, g in
                        zip(np.arange(800.0, length - 1000, 1700.0), [0.02, -0.04, 0.03, -0.01, -0.02, 0.02] * 40)])
    road = Road(28.4861 * RAD, 113.0623 * RAD, 120.0, length, heading, grade)
    drive_len = speed_mps * (minutes * 60.0 - static - 40.0)
    segs = [Static(static), Drive(drive_len, speed_mps, 20.0)]
    return Scenario(name="drive", road=road, segments=segs, static_s=static, **kw)


def height(minutes: float = 40.0, length_m: float = 10000.0, relief_m: float = 35.0, **kw) -> Scenario:
    """The height paper's drive: rotating IMU (4-position), 1-D LDV, out-and-back with relief.

    Sensor defaults from the paper: gyro 0.002°/h, accel 50 µg, LDV 0.05 %.
    """
    static = kw.pop("static_s", 300.0)
    turn_s = 40.0
    speed = 2 * length_m / ((minutes * 60.0 - static - turn_s - 60.0) * 0.97)
    g = relief_m / (0.3 * length_m)  # grade that climbs the relief over 30 % of the road
    L = length_m
    r = 0.03 * L  # ramp length
    grade = Ramps(0.0, [(0.08 * L, r, g), (0.38 * L, r, -g), (0.52 * L, r, -0.6 * g),
                        (0.72 * L, r, 0.6 * g), (0.78 * L, r, 0.3 * g), (0.92 * L, r, -0.3 * g)])
    heading = Ramps(20 * RAD, [(0.15 * L, 0.02 * L, 35 * RAD), (0.45 * L, 0.025 * L, -70 * RAD),
                               (0.65 * L, 0.02 * L, 50 * RAD), (0.85 * L, 0.015 * L, -25 * RAD)])
    road = Road(28.1812 * RAD, 112.9383 * RAD, 40.0, L + 1.0, heading, grade)
    segs = [Static(static), Drive(L, speed, 20.0), Static(30.0), TurnInPlace(turn_s, np.pi),
            Static(30.0), Drive(0.0, speed, 20.0)]
    kw.setdefault("ldv", LdvSpecSim(pitch_rad=0.35 * RAD, heading_rad=-0.25 * RAD, scale=1.0015,
                                    noise_mps=0.02, kind="1d"))
    defaults = dict(date="2022-05-18", t0_s=33300.0, gyro_bias_dph=0.002, accel_bias_ug=50.0,
                    rotating=True, alpha_rad=4.0e-4, beta_rad=-6.0e-4,
                    fix_schedule=[(900.0, 1000.0, 2), (1300.0, 1420.0, 0), (1420.0, 1460.0, 1)])
    defaults.update(kw)
    return Scenario(name="height", road=road, segments=segs, static_s=static, **defaults)


SCENARIOS = {"drive": drive, "height": height}


def by_name(name: str, **kw) -> Scenario:
    """Scenario by name; unknown names raise KeyError listing the known ones."""
    try:
        return SCENARIOS[name](**kw)
    except KeyError:
        raise KeyError(f"unknown scenario '{name}' (known: {', '.join(sorted(SCENARIOS))})") from None
