"""A gravity survey of several days on crossing roads over one known field (the network's test scenario).

A straight road and a second one weaving across it (a crossing every 800 m of road, at 50°); a day
drives one road out and back between static stops
at its two ends (where base ties are set), with its own turn-on accelerometer bias (its own seed).
The field (:class:`~ldvsurvey.sim.fields.SinusoidField`) is the same for every day, so a repeated
line, a crossing and a base tie all see the same truth.
"""

from __future__ import annotations

import numpy as np

from ldvsurvey.nav.earth import radii
from ldvsurvey.sim.fields import SinusoidField
from ldvsurvey.sim.motion import Drive, Motion, Static, TurnInPlace
from ldvsurvey.sim.road import Ramps, Road
from ldvsurvey.sim.scenario import Scenario
from ldvsurvey.sim.sensors import LdvSpecSim
from ldvsurvey.units import RAD_PER_DEG as RAD

#: origin of the survey (the gravity scenario's area)
LAT0_DEG, LON0_DEG, H0_M = 28.4861, 113.0623, 120.0
#: the two roads' general headings (deg, clockwise from north)
HEADINGS_DEG = (40.0, 40.0)
#: the second road weaves across the first: ± this angle (deg) about the common heading …
WEAVE_DEG = 50.0
#: … turning every this many metres of road, over this many metres
WEAVE_SEGMENT_M, WEAVE_TURN_M = 800.0, 200.0
#: run-in beyond each line end on the road (m): acceleration and braking stay off the lines
RUN_IN_M = 300.0
#: default line length of each road, km
LINE_KM = (7.0, 8.0)


def survey_field(lat0_rad: float = LAT0_DEG * RAD, lon0_rad: float = LON0_DEG * RAD) -> SinusoidField:
    """The survey's Δg: three plane waves (4-20 km) of up to 2 mGal/km and a 5-mGal offset."""
    terms = [(8.0, 20000.0, 0.3, 0.4), (4.0, 9000.0, 1.9, 1.1), (1.5, 4500.0, 0.9, 2.0)]
    return SinusoidField(lat0_rad, lon0_rad, terms, offset_mgal=5.0)


def road_of(k: int, line_km: float | None = None) -> Road:
    """Road ``k``: 0 straight and flat through the origin, 1 weaving across it (± WEAVE_DEG, a crossing every
    WEAVE_SEGMENT_M of road); both centred on the origin.

    Parameters
    ----------
    k : int
        Which road (0 or 1).
    line_km : float, optional
        Line length (km; default ``LINE_KM[k]``); the road adds a run-in of RUN_IN_M (m) at each end.

    Returns
    -------
    Road
        The road, flat, at H0_M (m).
    """
    line_km = LINE_KM[k] if line_km is None else line_km
    length = line_km * 1000.0 + 2 * RUN_IN_M
    psi = HEADINGS_DEG[k] * RAD
    if k == 0:
        heading, along = Ramps(psi, []), 0.5 * length
    else:
        a = WEAVE_DEG * RAD
        # on the first road's line at the start, heading off by +a; turns of ∓2a every segment: the road
        # crosses the first one in the middle of every segment
        steps = [
            (
                0.5 * WEAVE_SEGMENT_M + j * WEAVE_SEGMENT_M - 0.5 * WEAVE_TURN_M,
                WEAVE_TURN_M,
                (-2 * a if j % 2 == 0 else 2 * a),
            )
            for j in range(int(length // WEAVE_SEGMENT_M) + 1)
        ]
        heading, along = Ramps(psi + a, steps), 0.5 * length * np.cos(a)
    lat0, lon0 = LAT0_DEG * RAD, LON0_DEG * RAD
    rm, rn = radii(lat0)
    # start so that the road's middle (along its general heading) is at the origin
    de, dn = -along * np.sin(psi), -along * np.cos(psi)
    lat_s = lat0 + dn / (rm + H0_M)
    lon_s = lon0 + de / ((rn + H0_M) * np.cos(lat0))
    return Road(lat_s, lon_s, H0_M, length, heading, Ramps(0.0, []))


def day(
    road: int = 0,
    *,
    seed: int = 1,
    line_km: float | None = None,
    speed_mps: float = 15.0,
    end_stop_s: float = 150.0,
    passes: int = 2,
    accel_noise_ug_rthz: float = 5.0,
    accel_bias_ug: float = 20.0,
    date: str = "2023-03-20",
    **kw,
) -> Scenario:
    """One day of the survey: a static start at the road's start (the alignment, a tie point), then
    ``passes`` lines along the road, a stop of ``end_stop_s`` and a turn at each end, the last stop
    at the end reached. Lines: from the first to the last line point of each pass.

    Parameters
    ----------
    road : int
        Which road (0 straight, 1 weaving across it; see :func:`road_of`).
    seed : int
        Sensor-noise seed (the day's own turn-on biases).
    line_km : float, optional
        Line length (km); default ``LINE_KM[road]``.
    speed_mps : float
        Driving speed (m/s).
    end_stop_s : float
        Standing time at each end, half before and half after the turn (s).
    passes : int
        Number of lines driven (out and back alternately).
    accel_noise_ug_rthz : float
        Accelerometer white noise (µg/√Hz).
    accel_bias_ug : float
        Accelerometer turn-on bias, ± this on each axis with a random sign (µg).
    date : str
        Date of the drive (ISO).
    **kw
        Further :class:`~ldvsurvey.sim.scenario.Scenario` fields (e.g. ``imu_rate_hz``; ``with_ldv=False``
        for a day logged without an LDV, the same IMU and GNSS data as with one).

    Returns
    -------
    Scenario
        The day, its ``lines`` set (absolute times, s).
    """
    line_km = LINE_KM[road] if line_km is None else line_km
    rd = road_of(road, line_km)
    a, b = RUN_IN_M, RUN_IN_M + line_km * 1000.0
    ends = (0.0, rd.length_m)
    segs = [Static(300.0)]
    for k in range(passes):
        segs.append(Drive(ends[1] if k % 2 == 0 else ends[0], speed_mps, 20.0))
        segs += [Static(end_stop_s / 2), TurnInPlace(30.0, np.pi), Static(end_stop_s / 2)]
    sc_kw = dict(
        ldv=LdvSpecSim(
            pitch_rad=0.2 * RAD, heading_rad=-0.3 * RAD, scale=1.001, scale_up=1.001, noise_mps=0.01, kind="2d"
        ),
        gyro_bias_dph=0.003,
        accel_bias_ug=accel_bias_ug,
        gyro_arw_dprh=0.0005,
        accel_vrw_ug_rthz=accel_noise_ug_rthz,
        gravity_field=survey_field(),
        date=date,
        seed=seed,
    )
    sc_kw.update(kw)
    sc = Scenario(name=f"survey-road{road + 1}", road=rd, segments=segs, static_s=300.0, **sc_kw)
    m = Motion(rd, segs, sc.t0_s)
    lines = []
    for p in m.pieces:
        if p[2] == "drive":
            t = np.arange(p[0], p[1], 0.01)
            s = m.truth(t)["s_m"]
            ta, tb = t[int(np.argmin(np.abs(s - a)))], t[int(np.argmin(np.abs(s - b)))]
            lines.append((f"L{len(lines) + 1}", float(min(ta, tb)), float(max(ta, tb))))
    sc.lines = lines
    return sc


def tie_points(road: int = 0, line_km: float | None = None) -> list[tuple[float, float, float]]:
    """(lat_deg, lon_deg, h_m) of the two ends of a road, where its days stand still."""
    rd = road_of(road, line_km)
    lat, lon, h = rd.geodetic(np.array([0.0, rd.length_m]))
    return [(float(np.degrees(la)), float(np.degrees(lo)), float(hh)) for la, lo, hh in zip(lat, lon, h)]
