"""Named scenarios of the simulator (the product's demo surveys and test scenarios)."""

from __future__ import annotations

import numpy as np

from ldvsurvey.sim.motion import Drive, Static, TurnInPlace
from ldvsurvey.sim.road import Ramps, Road
from ldvsurvey.sim.scenario import Scenario
from ldvsurvey.sim.sensors import LdvSpecSim
from ldvsurvey.units import RAD_PER_DEG as RAD  # noqa: E402  (rad per degree)


def drive(minutes: float = 40.0, speed_mps: float = 15.0, **kw) -> Scenario:
    """A vehicle drive with turns and grades: 5 min static, then driving along a winding road.

    Parameters
    ----------
    minutes : float
        Length of the log (min).
    speed_mps : float
        Cruising speed (m/s).
    **kw
        Further :class:`~ldvsurvey.sim.scenario.Scenario` fields (sensor grades, rates, seed, ...).

    Returns
    -------
    Scenario
        The drive (fixed IMU, 2-D LDV).
    """
    static = kw.pop("static_s", 300.0)
    length = speed_mps * (minutes * 60.0 - static) + 2000.0
    heading = Ramps(
        30 * RAD,
        [
            (s, 250.0, d * RAD)
            for s, d in zip(np.arange(1500.0, length - 1000, 3100.0), [60, -90, 45, -30, 80, -70, 50, -40] * 20)
        ],
    )
    grade = Ramps(
        0.0,
        [
            (s, 400.0, g)
            for s, g in zip(np.arange(800.0, length - 1000, 1700.0), [0.02, -0.04, 0.03, -0.01, -0.02, 0.02] * 40)
        ],
    )
    road = Road(28.4861 * RAD, 113.0623 * RAD, 120.0, length, heading, grade)
    drive_len = speed_mps * (minutes * 60.0 - static - 40.0)
    segs = [Static(static), Drive(drive_len, speed_mps, 20.0)]
    return Scenario(name="drive", road=road, segments=segs, static_s=static, **kw)


def height(minutes: float = 40.0, length_m: float = 10000.0, relief_m: float = 35.0, **kw) -> Scenario:
    """The height paper's drive: rotating IMU (4-position), 1-D LDV, out-and-back with relief.

    Sensor defaults from the paper: gyro 0.002°/h, accel 50 µg, LDV 0.05 %.

    Parameters
    ----------
    minutes : float
        Length of the log (min).
    length_m : float
        Road length, driven out and back (m).
    relief_m : float
        Height climbed (m).
    **kw
        Further :class:`~ldvsurvey.sim.scenario.Scenario` fields (sensor grades, rates, seed, ...).

    Returns
    -------
    Scenario
        The drive, its two lines set.
    """
    static = kw.pop("static_s", 300.0)
    turn_s = 40.0
    drive_s = minutes * 60.0 - static - turn_s - 60.0
    if drive_s <= 0.0:
        raise ValueError(
            f"a {minutes * 60.0:g} s height drive leaves no time to drive after its {static:g} s static "
            f"start, turn and stops: give it more than {(static + turn_s + 60.0):g} s"
        )
    speed = 2 * length_m / (drive_s * 0.97)
    g = relief_m / (0.3 * length_m)  # grade that climbs the relief over 30 % of the road
    L = length_m
    r = 0.03 * L  # ramp length
    grade = Ramps(
        0.0,
        [
            (0.08 * L, r, g),
            (0.38 * L, r, -g),
            (0.52 * L, r, -0.6 * g),
            (0.72 * L, r, 0.6 * g),
            (0.78 * L, r, 0.3 * g),
            (0.92 * L, r, -0.3 * g),
        ],
    )
    heading = Ramps(
        20 * RAD,
        [
            (0.15 * L, 0.02 * L, 35 * RAD),
            (0.45 * L, 0.025 * L, -70 * RAD),
            (0.65 * L, 0.02 * L, 50 * RAD),
            (0.85 * L, 0.015 * L, -25 * RAD),
        ],
    )
    road = Road(28.1812 * RAD, 112.9383 * RAD, 40.0, L + 1.0, heading, grade)
    segs = [
        Static(static),
        Drive(L, speed, 20.0),
        Static(30.0),
        TurnInPlace(turn_s, np.pi),
        Static(30.0),
        Drive(0.0, speed, 20.0),
    ]
    kw.setdefault(
        "ldv", LdvSpecSim(pitch_rad=0.35 * RAD, heading_rad=-0.25 * RAD, scale=1.0015, noise_mps=0.02, kind="1d")
    )
    defaults = dict(
        date="2022-05-18",
        t0_s=33300.0,
        gyro_bias_dph=0.002,
        accel_bias_ug=50.0,
        rotating=True,
        alpha_rad=4.0e-4,
        beta_rad=-6.0e-4,
        fix_schedule=[(900.0, 1000.0, 2), (1300.0, 1420.0, 0), (1420.0, 1460.0, 1)],
    )
    defaults.update(kw)
    return Scenario(name="height", road=road, segments=segs, static_s=static, **defaults)


def _line_times(motion, s_a: float, s_b: float, t_from: float, t_to: float):
    """First times the vehicle passes arc lengths s_a and s_b within [t_from, t_to]."""
    t = np.arange(t_from, t_to, 0.01)
    s = motion.truth(t)["s_m"]
    ia = int(np.argmin(np.abs(s - s_a)))
    ib = int(np.argmin(np.abs(s - s_b)))
    return float(min(t[ia], t[ib])), float(max(t[ia], t[ib]))


def gravity(
    n_lines: int = 6, line_km: float = 11.0, relief_m: float = 332.0, speed_mps: float = 15.0, **kw
) -> Scenario:
    """The gravimetry paper's survey: fixed IMU (0.003°/h, 20 µg), 2-D LDV (0.1 %), repeated lines
    with large relief, GNSS partly degraded, a synthetic field with gradients up to 3 mGal/km.

    Parameters
    ----------
    n_lines : int
        Lines driven (alternately out and back).
    line_km : float
        Line length (km).
    relief_m : float
        Height climbed along the road (m).
    speed_mps : float
        Speed on the lines (m/s).
    **kw
        Further :class:`~ldvsurvey.sim.scenario.Scenario` fields (sensor grades, rates, seed, ...).

    Returns
    -------
    Scenario
        The survey, its lines set (absolute times, s).
    """
    from ldvsurvey.sim.fields import SinusoidField
    from ldvsurvey.sim.motion import Motion

    L = line_km * 1000.0
    a, b = 500.0, 500.0 + L  # line ends on the road
    road_len = b + 500.0
    g = relief_m / (0.50 * L)
    r = 0.04 * L
    grade = Ramps(
        0.0,
        [
            (0.05 * L + a, r, g),
            (0.45 * L + a, r, -0.55 * g),
            (0.7 * L + a, r, -0.45 * g),
            (0.85 * L + a, r, -0.4 * g),
            (0.93 * L + a, 0.05 * L, 0.4 * g),
        ],
    )
    heading = Ramps(
        40 * RAD, [(0.2 * L + a, 300.0, 40 * RAD), (0.5 * L + a, 400.0, -75 * RAD), (0.75 * L + a, 300.0, 50 * RAD)]
    )
    lat0, lon0 = 28.4861 * RAD, 113.0623 * RAD
    road = Road(lat0, lon0, 120.0, road_len, heading, grade)
    segs = [Static(300.0)]
    ends = (a - 300.0, b + 300.0)
    for k in range(n_lines):
        segs.append(Drive(ends[1] if k % 2 == 0 else ends[0], speed_mps, 20.0))
        segs += [Static(20.0), TurnInPlace(30.0, np.pi), Static(20.0)]
    sc_kw = dict(
        ldv=LdvSpecSim(
            pitch_rad=0.2 * RAD, heading_rad=-0.3 * RAD, scale=1.001, scale_up=1.001, noise_mps=0.01, kind="2d"
        ),
        gyro_bias_dph=0.003,
        accel_bias_ug=20.0,
        gyro_arw_dprh=0.0005,
        # navigation-grade quartz accelerometer white noise; at 5 µg/√Hz the noise floor alone
        # is ~0.45 mGal per line through a 150 s filter
        accel_vrw_ug_rthz=2.0,
    )
    # a field of 3 mGal/km at most: Σ 2π A/λ = 3e-3 mGal/m
    terms = [(10.0, 20000.0, 0.3, 0.4), (5.0, 8000.0, 1.9, 1.1), (2.0, 4000.0, 0.9, 2.0)]
    grad = sum(2 * np.pi * A / lam for A, lam, _, _ in terms) * 1000.0
    terms = [(A * 3.0 / grad, lam, th, ph) for A, lam, th, ph in terms]
    sc_kw["gravity_field"] = SinusoidField(lat0, lon0, terms, offset_mgal=5.0)
    sc_kw.update(kw)
    sc = Scenario(name="gravity", road=road, segments=segs, static_s=300.0, s0_m=ends[0], **sc_kw)
    m = Motion(road, segs, sc.t0_s, s0_m=ends[0])
    lines = []
    for p in m.pieces:
        if p[2] == "drive":
            ta, tb = _line_times(m, a, b, p[0], p[1])
            lines.append((f"L{len(lines) + 1}", ta, tb))
    sc.lines = lines
    if "fix_schedule" not in kw:  # GNSS partly blocked on some lines (forest, valley)
        dur = m.t_end_s - sc.t0_s
        sc.fix_schedule = [
            (0.22 * dur, 0.26 * dur, 1),
            (0.26 * dur, 0.29 * dur, 0),
            (0.45 * dur, 0.5 * dur, 2),
            (0.62 * dur, 0.64 * dur, 0),
            (0.64 * dur, 0.70 * dur, 1),
            (0.84 * dur, 0.86 * dur, 5),
        ]
    return sc


class GridField:
    """A DovGrid as the simulator's gravity field (bilinear)."""

    def __init__(self, grid):
        self.grid = grid

    def __call__(self, lat_rad, lon_rad, h_m):
        return self.grid.interpolate(np.degrees(lat_rad), np.degrees(lon_rad), "linear")


def dov(km: float = 315.0, speed_mps: float = 25.0, step_arcmin: float = 1.0, degree: int = 2190, **kw) -> Scenario:
    """The DOV paper's simulation: due north from N34°18'57" E109°7'36" at 25 m/s; gyro 0.01°/h,
    ARW 0.001°/√h, accel 50 µg, 5 µg/√Hz; the true field is the built-in EGM2008 on a 1' grid.

    Parameters
    ----------
    km : float
        Distance driven (km).
    speed_mps : float
        Speed (m/s).
    step_arcmin : float
        Step of the field's grid (arcmin).
    degree : int
        Degree of the EGM2008 synthesis.
    **kw
        Further :class:`~ldvsurvey.sim.scenario.Scenario` fields; ``grid`` a ready
        :class:`~ldvsurvey.nav.dovgrid.DovGrid` (skips the synthesis).

    Returns
    -------
    Scenario
        The drive (1-D LDV at 10 Hz).
    """
    from ldvsurvey.nav.dovgrid import area_for_track, egm_grid

    lat0, lon0 = 34 + 18 / 60 + 57 / 3600, 109 + 7 / 60 + 36 / 3600
    length = km * 1000.0 + 3000.0
    road = Road(lat0 * RAD, lon0 * RAD, 500.0, length, Ramps(0.0))
    lat_end = lat0 + length / 111000.0
    area = area_for_track(np.array([lat0, lat_end]), np.array([lon0, lon0]), step_arcmin)
    grid = kw.pop("grid", None) or egm_grid(area, step_arcmin, degree)
    segs = [Static(300.0), Drive(km * 1000.0, speed_mps, 30.0)]
    defaults = dict(
        gyro_bias_dph=0.01,
        gyro_arw_dprh=0.001,
        accel_bias_ug=50.0,
        accel_vrw_ug_rthz=5.0,
        gravity_field=GridField(grid),
        date="2023-06-01",
        ldv_rate_hz=10.0,
        ldv=LdvSpecSim(noise_mps=0.02, kind="1d"),
    )
    defaults.update(kw)
    return Scenario(name="dov", road=road, segments=segs, static_s=300.0, **defaults)


def vessel(
    hours: float = 3.0, current_mps: float = 2.0, speed_mps: float = 20.0, mooring_s: float = 1000.0, **kw
) -> Scenario:
    """The damping paper's simulation: moored for ``mooring_s`` (1000 s), a left turn at 0.1°/s for
    450 s, 1 m/s² for 20 s, hours of straight run, 1 m/s² deceleration; a water-track LDV; a steady
    current (from the end of the mooring).

    Parameters
    ----------
    hours : float
        Length of the straight run (h).
    current_mps : float
        Speed of the current toward ENE (m/s).
    speed_mps : float
        Speed through the water (m/s).
    mooring_s : float
        Moored time at the start (s).
    **kw
        Further :class:`~ldvsurvey.sim.scenario.Scenario` fields (sensor grades, rates, seed, ...).

    Returns
    -------
    Scenario
        The vessel's run.
    """
    length = speed_mps * hours * 3600.0 + 2 * speed_mps * 20.0 + 2000.0
    road = Road(30.56 * RAD, 114.32 * RAD, 7.0, length, Ramps(0.0))  # water track due north
    segs = [
        Static(mooring_s),
        TurnInPlace(450.0, -45.0 * RAD),
        Drive(speed_mps * (hours * 3600.0 + 20.0), speed_mps, 20.0),
        Static(600.0),
    ]
    c = np.array([np.cos(RAD * 30.0), np.sin(RAD * 30.0), 0.0]) * current_mps  # toward ENE
    defaults = dict(
        platform="vessel",
        date="2023-06-08",
        t0_s=36000.0,
        gyro_bias_dph=0.01,
        accel_bias_ug=50.0,
        gyro_arw_dprh=0.001,
        accel_vrw_ug_rthz=10.0,
        ldv_rate_hz=20.0,
        ldv=LdvSpecSim(scale=1.002, noise_mps=0.02, kind="water", lever_arm_m=(0.0, 1.0, -2.5)),
        gnss_lever_m=(0.0, -1.0, 4.0),
        heading_offset0_rad=45.0 * RAD,
        current_n_mps=tuple(c),
        current_from_s=mooring_s,
    )
    defaults.update(kw)
    return Scenario(name="vessel", road=road, segments=segs, static_s=mooring_s, **defaults)


SCENARIOS = {"drive": drive, "height": height, "gravity": gravity, "dov": dov, "vessel": vessel}


def by_name(name: str, **kw) -> Scenario:
    """Scenario by name; unknown names raise KeyError listing the known ones."""
    try:
        return SCENARIOS[name](**kw)
    except KeyError:
        raise KeyError(f"unknown scenario '{name}' (known: {', '.join(sorted(SCENARIOS))})") from None


# --- the realistic family: the same drives with the effects real drives have -------------------------


def _split_effects(seed: int, effects, kw: dict):
    """Effect overrides (keys named like effects) out of ``kw``; returns (Effects, remaining kw)."""
    from ldvsurvey.sim.effects import Effects, effect_names

    over = {k: kw.pop(k) for k in list(kw) if k in effect_names()}
    if effects is None:
        eff = Effects.realistic(seed, **over)
    else:
        eff = effects.with_(**over) if over else effects
    return eff, kw


def _realistic(sc: Scenario, eff, seed: int) -> Scenario:
    """Attach the effects: a moving start drops the initial static period and starts the log at
    cruising speed; the GNSS effect
    moves the antenna to its real lever arm."""
    from ldvsurvey.sim.motion import Static as _Static

    sc.effects = eff
    sc.seed = seed
    sc.name = "realistic-" + sc.name
    if eff.moving_start is not None and sc.segments and isinstance(sc.segments[0], _Static):
        sc.segments = sc.segments[1:]
        sc.static_s = 0.0
        ramp = getattr(sc.segments[0], "ramp_s", 0.0)
        sc.lead_s = ramp + 10.0  # the log starts 10 s after the vehicle reached its speed
    if eff.gnss is not None:
        sc.gnss_lever_m = tuple(eff.gnss.lever_arm_m)
    return sc


def realistic_height(seed: int = 1, effects=None, minutes: float = 40.0, **kw) -> Scenario:
    """The height drive (40 min, rotating IMU, 1-D LDV, 2 × 10 km out and back, 35 m relief)
    with every real-drive effect (see ``effects.py``); ``kw`` may switch effects by name
    (``gnss=False``, ``turntable=TurntableSpec(scheme="2pos")``) or set scenario fields."""
    eff, kw = _split_effects(seed, effects, kw)
    return _realistic(height(minutes=minutes, **kw), eff, seed)


def realistic_gravity(seed: int = 1, effects=None, n_lines: int = 6, **kw) -> Scenario:
    """The gravimetry survey (six repeated 11-km lines, fixed IMU, 2-D LDV, accelerometer white
    noise 5 µg/√Hz) with every real-drive effect; the point-mass field replaces the sinusoids."""
    eff, kw = _split_effects(seed, effects, kw)
    kw.setdefault("accel_vrw_ug_rthz", 5.0)
    sc = gravity(n_lines=n_lines, **kw)
    if eff.gravity_field is not None:
        sc.gravity_field = None  # built from the effect's one potential at simulation time
    return _realistic(sc, eff, seed)


def realistic_drive(seed: int = 1, effects=None, minutes: float = 40.0, **kw) -> Scenario:
    """The navigation drive (winding road with grades, fixed IMU, 2-D LDV) with every effect."""
    eff, kw = _split_effects(seed, effects, kw)
    kw.setdefault("fix_schedule", [])
    return _realistic(drive(minutes=minutes, **kw), eff, seed)


def realistic_vessel(seed: int = 1, effects=None, hours: float = 3.0, **kw) -> Scenario:
    """The damping vessel with the effects that apply afloat: IMU errors and timing, one gravity
    field, GNSS effects (its own lever arm kept), LDV dropouts; no vehicle body attitude."""
    explicit = "body_attitude" in kw
    eff, kw = _split_effects(seed, effects, kw)
    if effects is None and not explicit:
        eff = eff.with_(body_attitude=False)
    sc = _realistic(vessel(hours=hours, **kw), eff, seed)
    sc.gnss_lever_m = tuple(kw.get("gnss_lever_m", (0.0, -1.0, 4.0)))
    return sc


REALISTIC = {
    "realistic-height": realistic_height,
    "realistic-gravity": realistic_gravity,
    "realistic-drive": realistic_drive,
    "realistic-vessel": realistic_vessel,
}
SCENARIOS.update(REALISTIC)
