"""Simulated drive logs: a scenario description, its simulation, and its bundle files.

A scenario is a road, a timeline, the instruments and their errors, the GNSS fix schedule
and optionally a gravity field. ``simulate`` returns sensor data with the truth beside it;
``bundle_files`` writes the ``ldv-drive-log/1`` files and ``truth_files`` what only a
simulation knows (truth trajectory, tilt angles, LDV mounting, biases).
"""

from __future__ import annotations

import datetime as dt
import json
from dataclasses import dataclass, field

import numpy as np

from ldvsurvey.nav.attitude import euler_from_c_bn
from ldvsurvey.sim.effects import Effects
from ldvsurvey.sim.imu import GravityField, ImuTruth, simulate_imu
from ldvsurvey.sim.motion import Motion, Turntable
from ldvsurvey.sim.road import Road
from ldvsurvey.sim.sensors import ImuErrors, LdvSpecSim, gnss_fixes, ldv_measure

GEOID_SEPARATION_M = -16.0


@dataclass
class Scenario:
    """Everything that defines one simulated drive (angles in rad unless named otherwise)."""

    name: str
    road: Road
    segments: list
    t0_s: float = 30000.0
    date: str = "2023-03-20"
    platform: str = "vehicle"
    imu_rate_hz: float = 100.0
    gyro_bias_dph: float = 0.003
    accel_bias_ug: float = 20.0
    gyro_arw_dprh: float = 0.0005
    accel_vrw_ug_rthz: float = 5.0
    rotating: bool = False
    turntable_dwell_s: float = 30.0
    alpha_rad: float = 0.0
    beta_rad: float = 0.0
    ldv: LdvSpecSim = field(default_factory=LdvSpecSim)
    ldv_rate_hz: float = 100.0
    ldv_dropout_share: float = 0.002  #: samples flagged below min_quality (and corrupted)
    ldv_fd: bool = False  #: write fd_hz instead of v_fwd
    #: False: the bundle has no LDV (an INS/GNSS log: no ldv.csv, no manifest ldv section; the LDV is
    #: still simulated, so the same seed gives the same IMU and GNSS data with or without it)
    with_ldv: bool = True
    gnss_lever_m: tuple = (0.0, 0.5, 1.6)
    fix_schedule: list = field(default_factory=list)  #: [(t_from_start_s, t_to_start_s, fix)], default 4
    gravity_field: GravityField | None = None
    static_s: float = 300.0
    lines: list = field(default_factory=list)  #: [(name, t_start_s, t_end_s)] absolute times
    current_n_mps: tuple | None = None  #: water current (vessel), ENU
    s0_m: float = 0.0  #: arc length of the road where the vehicle starts
    heading_offset0_rad: float = 0.0  #: initial heading relative to the road (a vessel turning onto it)
    current_from_s: float = 0.0  #: the current acts from here on (a moored vessel casting off)
    effects: Effects = field(default_factory=Effects.ideal)  #: real-drive effects (all off: ideal)
    seed: int = 1  #: sensor-noise seed used when ``simulate`` is not given one
    lead_s: float = 0.0  #: the motion starts this long before t0_s (a log that starts on the move)
    gnss_rate_hz: float = 1.0  #: GNSS fix rate (Hz; fixes at whole multiples of its interval)

    def fix_of_t(self, t):
        """GNSS fix quality (GGA code, 4 RTK fixed unless ``fix_schedule`` says otherwise) at times ``t`` (s)."""
        fix = np.full(len(t), 4)
        for a, b, q in self.fix_schedule:
            fix[(t >= self.t0_s + a) & (t < self.t0_s + b)] = q
        return fix


@dataclass
class SimResult:
    """A simulated drive: the sensor data (IMU increments rad, m/s; LDV m/s; GNSS deg, m) and the truth."""

    scenario: Scenario
    motion: Motion
    imu: ImuTruth
    errors: ImuErrors
    dtheta_rad: np.ndarray
    dvel_mps: np.ndarray
    ldv_t_s: np.ndarray
    ldv_v_fwd: np.ndarray
    ldv_v_up: np.ndarray
    ldv_quality: np.ndarray
    gnss_t_s: np.ndarray
    gnss_lat_deg: np.ndarray
    gnss_lon_deg: np.ndarray
    gnss_h_m: np.ndarray
    gnss_fix: np.ndarray
    imu_nodov: tuple | None = None  # (dtheta, dvel) of the same drive without the DOV
    extras: dict = field(default_factory=dict)  #: truth of the effects (see ``effect_truth``)
    body: object | None = None  #: the BodyModel when the body-attitude effect is on

    @property
    def gravity_field(self):
        """The gravity field the IMU sensed (the scenario's, or the effect's point masses), or None."""
        return self.extras.get("gravity_field", self.scenario.gravity_field)


OPTICS = {"wavelength_nm": 1064.0, "beam_angle_deg": 10.0, "surface_angle_deg": 30.0, "refractive_index": 1.00027}


def simulate(sc: Scenario, seed: int | None = None, with_nodov: bool = False) -> SimResult:
    """Simulate all sensors of a scenario.

    The effects of ``sc.effects`` draw from their own generator, so the ideal scenarios (all
    effects off) give exactly the sensor data they always gave. The stages run in a fixed order
    (each generator's draws follow it): motion, body, gravity field, turntable, IMU, LDV, GNSS.

    Parameters
    ----------
    sc : Scenario
        The drive.
    seed : int, optional
        Sensor-noise seed; default ``sc.seed``.
    with_nodov : bool
        Also simulate the IMU of the same drive without the deflection of the vertical (same sensor
        errors), in ``imu_nodov``; only when the drive has a gravity field.

    Returns
    -------
    SimResult
        Sensor data (IMU increments rad and m/s, LDV m/s, GNSS deg and m) with the truth beside it.
    """
    seed = sc.seed if seed is None else seed
    dt = 1.0 / sc.imu_rate_hz
    lead = round(sc.lead_s / dt) * dt
    motion = Motion(
        sc.road,
        sc.segments,
        sc.t0_s - lead,
        dt_s=1.0 / sc.imu_rate_hz,
        s0_m=sc.s0_m,
        heading_offset0_rad=sc.heading_offset0_rad,
        current_n_mps=sc.current_n_mps,
        current_from_s=sc.current_from_s + lead,
    )
    d = _Draw(sc, motion, dt, np.random.default_rng(seed), np.random.default_rng([sc.effects.seed, seed, 99]), {})
    body, c_bt = _travel_to_body(d)
    field = d.extras["gravity_field"] = _gravity_field(d)
    table = _turntable(d)
    n = int(round((motion.t_end_s - sc.t0_s) / dt))
    imu, ref = _ideal_imu(d, sc.t0_s + np.arange(n + 1) * dt, c_bt, field, table, with_nodov)
    err, dth, dv, nodov = _imu_errors(d, imu, ref)
    _recording(d, imu, table)
    t_l, vf, vu, quality = _ldv(d, body)
    t_g, lat, lon, h, fix = _gnss(d, c_bt)
    return SimResult(
        sc, motion, imu, err, dth, dv, t_l, vf, vu, quality, t_g, lat, lon, h, fix, nodov, extras=d.extras, body=body
    )


@dataclass
class _Draw:
    """What the stages of one simulation share: the drive, its motion, the IMU step, the two
    generators (sensor noise; the effects) and the effects' truth collected so far."""

    sc: Scenario
    motion: Motion
    dt_s: float
    rng: np.random.Generator
    erng: np.random.Generator
    extras: dict


def _travel_to_body(d: _Draw):
    """The body model (None without the body-attitude effect) and what takes the travel frame to the
    body: the LDV mounting C_b^t, or the body model itself."""
    sc = d.sc
    c_bt = sc.ldv.c_bt()
    body = None
    if sc.effects.body_attitude is not None:
        from ldvsurvey.sim.body import BodyModel

        body = c_bt = BodyModel(sc.effects.body_attitude, d.motion, sc.ldv.pitch_rad, sc.ldv.heading_rad, d.erng)
    return body, c_bt


def _gravity_field(d: _Draw):
    """The field the IMU senses: the scenario's, or the effect's point masses along the track, or None."""
    sc = d.sc
    field = sc.gravity_field
    if sc.effects.gravity_field is not None and field is None:
        from ldvsurvey.sim.pointmass import build_field

        tr = d.motion.truth(np.linspace(sc.t0_s, d.motion.t_end_s, 2001))
        field = build_field(sc.effects.gravity_field, tr["lat_rad"], tr["lon_rad"], tr["h_m"])
    return field


def _turntable(d: _Draw):
    """The turntable of a rotating IMU (the effect's schedule, or the 4-position scheme), or None."""
    sc = d.sc
    if sc.rotating and sc.effects.turntable is not None:
        from ldvsurvey.sim.turntable import ScheduledTurntable

        table = ScheduledTurntable(sc.effects.turntable, sc.t0_s, d.motion.t_end_s, d.dt_s, d.erng)
        d.extras["turntable"] = table
        return table
    if sc.rotating:
        return Turntable(sc.t0_s, dwell_s=sc.turntable_dwell_s, dt_s=d.dt_s)
    return None


def _ideal_imu(d: _Draw, t, c_bt, field, table, with_nodov):
    """Error-free IMU at times ``t`` (s), and with ``with_nodov`` the same drive sensing only the
    field's Δg (no deflection), else None."""
    sc = d.sc
    imu = simulate_imu(d.motion, t, c_bt, field, table, sc.alpha_rad, sc.beta_rad)
    ref = None
    if with_nodov and field is not None:

        def dg_only(lat, lon, h):
            _, _, dg = field(lat, lon, h)
            return 0.0 * lat, 0.0 * lat, dg

        ref = simulate_imu(d.motion, t, c_bt, dg_only, table, sc.alpha_rad, sc.beta_rad)
    return imu, ref


def _imu_errors(d: _Draw, imu, ref):
    """The sensor errors: the effects' (scale, misalignment, bias instability), then the turn-on biases
    and white noise. Returns the drawn ``ImuErrors``, the measured increments (rad, m/s) and those of
    ``ref`` with identical errors (None without ``ref``)."""
    sc, dt, rng = d.sc, d.dt_s, d.rng
    ideal_dth, ideal_dv = imu.dtheta_rad, imu.dvel_mps
    if sc.effects.imu_errors is not None:
        from ldvsurvey.sim.imuerrors import apply_imu_errors

        ideal_dth, ideal_dv, d.extras["imu_errors"] = apply_imu_errors(
            imu.dtheta_rad, imu.dvel_mps, dt, sc.effects.imu_errors, sc.gyro_bias_dph, sc.accel_bias_ug, d.erng
        )
    if sc.effects.engine_vibration is not None:
        from ldvsurvey.sim.imuerrors import engine_vibration

        v_th, v_v = engine_vibration(imu.t_s, dt, sc.effects.engine_vibration, d.erng)
        ideal_dth, ideal_dv = ideal_dth + v_th, ideal_dv + v_v
    err = ImuErrors.draw(rng, sc.gyro_bias_dph, sc.accel_bias_ug, sc.gyro_arw_dprh, sc.accel_vrw_ug_rthz)
    state = rng.bit_generator.state
    dth, dv = err.apply(ideal_dth, ideal_dv, dt, rng)
    nodov = None
    if ref is not None:  # identical sensor errors in both files
        rng.bit_generator.state = state
        r_dth, r_dv = ref.dtheta_rad, ref.dvel_mps
        if "imu_errors" in d.extras:
            x = d.extras["imu_errors"]
            r_dth = r_dth @ x["m_gyro"].T + x["gyro_gm_rps"] * dt
            r_dv = r_dv @ x["m_accel"].T + x["accel_gm_mps2"] * dt
        nodov = err.apply(r_dth, r_dv, dt, rng)
    return err, dth, dv, nodov


def _recording(d: _Draw, imu, table):
    """What the logger writes other than the sensor sensed (into ``extras``): dropped rows and jittered
    time tags, and the encoder's counts."""
    eff = d.sc.effects
    if eff.imu_timing is not None:
        from ldvsurvey.sim.imuerrors import timing

        d.extras["imu_keep"], d.extras["imu_t_written"] = timing(imu.t_s, d.dt_s, eff.imu_timing, d.erng)
    if table is not None and eff.turntable is not None:
        from ldvsurvey.sim.turntable import encoder_reading

        d.extras["encoder_deg"] = encoder_reading(imu.eta_rad, eff.turntable, d.erng)


def _ldv(d: _Draw, body):
    """LDV samples: times (s), forward and up speed (m/s) and quality, with the ordinary low-quality
    samples and the effect's dropouts."""
    sc, motion, rng = d.sc, d.motion, d.rng
    n_l = int(np.floor((motion.t_end_s - sc.t0_s) * sc.ldv_rate_hz + 1e-9))
    t_l = sc.t0_s + np.arange(1, n_l + 1) / sc.ldv_rate_hz
    current = None
    if sc.current_n_mps is not None:  # a water-track LDV sees the velocity relative to the water
        from ldvsurvey.sim.road import smooth_step

        frac = smooth_step((t_l - motion.current_t0) / motion.current_ramp)[0]
        current = frac[:, None] * np.asarray(sc.current_n_mps, float)
    vf, vu = ldv_measure(motion, t_l, sc.ldv, rng, current_n=current, body=body)
    quality = rng.integers(150, 400, len(t_l)).astype(float)
    bad = rng.random(len(t_l)) < sc.ldv_dropout_share
    quality[bad] = rng.integers(10, 90, bad.sum())
    vf[bad] += rng.normal(0, 2.0, bad.sum())
    vu[bad] += rng.normal(0, 2.0, bad.sum())
    if sc.effects.ldv_dropouts is not None:
        from ldvsurvey.sim.ldvfaults import apply_dropouts

        static_end = sc.t0_s + (sc.segments[0].duration_s if sc.static_s > 0 else 0.0)
        vf, vu, quality, bursts, spikes = apply_dropouts(
            t_l, vf, vu, quality, sc.effects.ldv_dropouts, static_end, d.erng
        )
        d.extras["ldv_bursts"], d.extras["ldv_spikes_t"] = bursts, spikes
    return t_l, vf, vu, quality


def _gnss(d: _Draw, c_bt):
    """GNSS fixes at whole multiples of the fix interval: times (s), latitude, longitude (deg), height
    (m) and fix quality, with the effect's outages and multipath."""
    sc, motion = d.sc, d.motion
    r = sc.gnss_rate_hz
    t_g = np.arange(np.ceil(sc.t0_s * r), np.floor(motion.t_end_s * r) + 1e-9, 1.0) / r
    fix_of_t, extra = sc.fix_of_t, None
    if sc.effects.gnss is not None:
        from ldvsurvey.sim.gnsseffects import fix_with_events, gnss_events, multipath_offsets

        ev = gnss_events(sc.effects.gnss, sc.t0_s, motion.t_end_s, d.erng)
        fix_of_t = fix_with_events(sc.fix_of_t, ev)
        extra = multipath_offsets(t_g, fix_of_t(t_g), ev)
        d.extras["gnss_events"] = ev
    lat, lon, h, fix = gnss_fixes(motion, t_g, c_bt, sc.gnss_lever_m, fix_of_t, d.rng, extra_enu_m=extra)
    return t_g, lat, lon, h, fix


#: correlation time the manifest states for the bias instability (s): the middle of the 10–60 min
#: the effect draws from, as a datasheet would give it
NOMINAL_BIAS_CORRELATION_S = 1800.0


def gnss_height_noise() -> dict:
    """The simulated receiver's height error by fix quality, as a datasheet states it (manifest
    ``gnss.height_noise``): the white part and the rest of the σ as a Gauss-Markov wander."""
    from ldvsurvey.sim.sensors import FIX_SIGMA, FIX_WHITE, GNSS_CORR_S

    return {
        str(q): {
            "white_m": FIX_WHITE[q][1],
            "correlated_m": float(np.sqrt(max(FIX_SIGMA[q][1] ** 2 - FIX_WHITE[q][1] ** 2, 0.0))),
            "correlation_s": GNSS_CORR_S,
        }
        for q in sorted(FIX_SIGMA)
    }


def manifest(sim: SimResult) -> dict:
    """The ``manifest.json`` of a simulation: the instruments as a datasheet states them (not the drawn errors).

    Parameters
    ----------
    sim : SimResult
        The simulation.

    Returns
    -------
    dict
        The ``ldv-drive-log/1`` manifest (rates Hz, biases °/h and µg, noise, lever arms m, initial
        position deg and m, lines with absolute times s); no ``ldv`` section without an LDV.
    """
    sc = sim.scenario
    m = {
        "format": "ldv-drive-log/1",
        "name": f"Simulated {sc.name} drive",
        "date": sc.date,
        "platform": sc.platform,
        "imu": {
            "rate_hz": sc.imu_rate_hz,
            "rotating": sc.rotating,
            "gyro_bias_dph": sc.gyro_bias_dph,
            "accel_bias_ug": sc.accel_bias_ug,
            "gyro_arw_deg_per_rth": sc.gyro_arw_dprh,
            "accel_noise_ug_per_rthz": sc.accel_vrw_ug_rthz,
        },
        "ldv": {
            "kind": sc.ldv.kind,
            "rate_hz": sc.ldv_rate_hz,
            "min_quality": 100,
            "nominal": {"pitch_deg": 0.0, "heading_deg": 0.0, "scale": 1.0},
            "optics": OPTICS,
            "lever_arm_m": list(sc.ldv.lever_arm_m),
            "noise_mps": sc.ldv.noise_mps,
        },
        "gnss": {"lever_arm_m": list(sc.gnss_lever_m), "height_noise": gnss_height_noise()},
        "initial": {
            "lat_deg": float(np.degrees(sim.imu.lat_rad[0])),
            "lon_deg": float(np.degrees(sim.imu.lon_rad[0])),
            "h_m": float(sim.imu.h_m[0]),
            "static_s": sc.static_s,
        },
        "simulated": {"software": "ldv-survey", "scenario": sc.name},
    }
    e = sc.effects.imu_errors
    if e is not None:  # what a datasheet states: the nominal instability and a typical correlation time
        m["imu"].update(
            gyro_bias_instability_dph=e.gyro_bi_frac * sc.gyro_bias_dph,  # (not the drawn τ)
            accel_bias_instability_ug=e.accel_bi_frac * sc.accel_bias_ug,
            bias_correlation_s=NOMINAL_BIAS_CORRELATION_S,
        )
    if sc.lines:
        m["lines"] = [{"name": n, "t_start": a, "t_end": b} for n, a, b in sc.lines]
    if not sc.with_ldv:
        del m["ldv"]
    return m


def bundle_files(sim: SimResult) -> dict[str, bytes]:
    """The four ``ldv-drive-log/1`` files of a simulation (three without ``ldv.csv`` when the
    scenario has no LDV, ``with_ldv`` False).

    Parameters
    ----------
    sim : SimResult
        The simulation.

    Returns
    -------
    dict of str to bytes
        ``manifest.json``, ``imu.csv`` (increments rad and m/s, turntable deg), ``ldv.csv`` (m/s, or
        Doppler Hz with ``ldv_fd``) and ``gnss.nmea``, with the recording effects applied.
    """
    from ldvsurvey.io.drivelog import fd_to_v_fwd
    from ldvsurvey.io.manifest import LdvOptics
    from ldvsurvey.io.writers import imu_csv, ldv_csv, manifest_json, nmea_text

    sc = sim.scenario
    turn = np.mod(np.degrees(sim.imu.eta_rad), 360.0) if sc.rotating else None
    if "encoder_deg" in sim.extras:
        turn = sim.extras["encoder_deg"]
    t_imu, dth, dv = sim.imu.t_s, sim.dtheta_rad, sim.dvel_mps
    if "imu_keep" in sim.extras:  # dropped rows and jittered time tags
        keep = sim.extras["imu_keep"]
        t_imu, dth, dv = sim.extras["imu_t_written"][keep], dth[keep], dv[keep]
        turn = turn[keep] if turn is not None else None
    v_up = sim.ldv_v_up if sc.ldv.kind == "2d" else None
    if sc.ldv_fd:
        per_mps = 1.0 / fd_to_v_fwd(np.array([1.0]), LdvOptics(**OPTICS))[0]
        ldv = ldv_csv(
            sim.ldv_t_s,
            fd_hz=sim.ldv_v_fwd * per_mps,
            v_up_mps=v_up,
            quality=sim.ldv_quality,
            comment="simulated LDV, Doppler frequency",
        )
    else:
        ldv = ldv_csv(sim.ldv_t_s, v_fwd_mps=sim.ldv_v_fwd, v_up_mps=v_up, quality=sim.ldv_quality)
    files = {
        "manifest.json": manifest_json(manifest(sim)),
        "imu.csv": imu_csv(
            t_imu, dth, dv, turn, comment="ldv-drive-log/1 IMU increments over (t_prev, t], sensor frame s"
        ),
        "ldv.csv": ldv,
        "gnss.nmea": nmea_text(
            sim.gnss_t_s,
            sim.gnss_lat_deg,
            sim.gnss_lon_deg,
            sim.gnss_h_m,
            sim.gnss_fix,
            sep_m=GEOID_SEPARATION_M,
            talker="GN",
        ),
    }
    if not sc.with_ldv:
        del files["ldv.csv"]
    return files


def truth_files(sim: SimResult, every: int = 10) -> dict[str, bytes]:
    """Truth beside the bundle: ``truth.csv`` (every ``every``-th IMU sample) and ``truth.json``.

    Parameters
    ----------
    sim : SimResult
        The simulation.
    every : int
        Keep every this-many-th IMU sample in ``truth.csv``.

    Returns
    -------
    dict of str to bytes
        ``truth.csv`` (position deg and m, velocity m/s, attitude deg, the effects' columns),
        ``truth.json`` (tilt rad, LDV mounting rad and scale, biases rad/s and m/s², the effects'
        truth) and, with the no-DOV twin, ``imu_nodov.csv``.
    """
    from ldvsurvey.io.writers import csv_bytes, imu_csv

    im = sim.imu
    sl = slice(every - 1, None, every)
    pitch, roll, heading = euler_from_c_bn(im.c_bn[sl])
    cols = {
        "t": im.t_s[sl],
        "lat_deg": np.degrees(im.lat_rad[sl]),
        "lon_deg": np.degrees(im.lon_rad[sl]),
        "h_m": im.h_m[sl],
        "v_e_mps": im.v_n[sl, 0],
        "v_n_mps": im.v_n[sl, 1],
        "v_u_mps": im.v_n[sl, 2],
        "pitch_deg": np.degrees(pitch),
        "roll_deg": np.degrees(roll),
        "heading_deg": np.degrees(heading),
    }
    if im.eta_rad is not None:
        cols["turntable_deg"] = np.mod(np.degrees(im.eta_rad[sl]), 360.0)
    sc = sim.scenario
    meta = {
        "scenario": sc.name,
        "alpha_rad": sc.alpha_rad,
        "beta_rad": sc.beta_rad,
        "ldv": {
            "pitch_rad": sc.ldv.pitch_rad,
            "heading_rad": sc.ldv.heading_rad,
            "scale": sc.ldv.scale,
            "scale_up": sc.ldv.scale_up,
        },
        "gyro_bias_rps": sim.errors.gyro_bias_rps.tolist(),
        "accel_bias_mps2": sim.errors.accel_bias_mps2.tolist(),
        "created": dt.datetime.now(dt.UTC).isoformat(timespec="seconds"),
    }
    if sc.effects.on():
        more_cols, more_meta = effect_truth(sim, sl)
        cols.update(more_cols)
        meta.update(more_meta)
    out = {
        "truth.csv": csv_bytes(cols, comment="simulation truth at the IMU centre"),
        "truth.json": (json.dumps(meta, indent=2) + "\n").encode(),
    }
    if sim.imu_nodov is not None:
        out["imu_nodov.csv"] = imu_csv(
            im.t_s,
            sim.imu_nodov[0],
            sim.imu_nodov[1],
            np.mod(np.degrees(im.eta_rad), 360.0) if im.eta_rad is not None else None,
            comment="the same drive without the deflection of the vertical",
        )
    return out


# the effects' truth lives in truth.py; re-exported here for one import place
from ldvsurvey.sim.truth import effect_truth, effective_travel_direction, grid_files, mean_travel_direction  # noqa: E402, F401
