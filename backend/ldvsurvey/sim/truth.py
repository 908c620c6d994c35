"""Truth of the simulator's effects: what only a simulation knows, beside the bundle.

The effective LDV travel direction (time series and means per drive, per line and overall), the
gravity field along the track and its ``.gdf`` grids, the IMU's bias instability and error matrices,
dropped rows, turntable stops and the effective turntable tilt the gyros see, LDV bursts and
GNSS events.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from ldvsurvey.sim.scenario import SimResult


def effective_travel_direction(sim: SimResult, t_s) -> tuple[np.ndarray, np.ndarray]:
    """Pitch and heading (rad) of the travel direction in IMU-body axes at times ``t_s``, in the LDV
    mounting convention: what an LDV calibration sees (equal to the mounting without body attitude)."""
    from ldvsurvey.sim.body import travel_direction

    t = np.atleast_1d(np.asarray(t_s, float))
    if sim.body is None:
        return np.full(len(t), sim.scenario.ldv.pitch_rad), np.full(len(t), sim.scenario.ldv.heading_rad)
    return travel_direction(sim.body(t, sim.motion.truth(t))[0])


def travel_unit_vector(pitch_rad, heading_rad) -> np.ndarray:
    """(N, 3) unit vectors (right, forward, up axes) of directions given by pitch and heading (rad) in the LDV
    mounting convention: the inverse of :func:`ldvsurvey.sim.body.travel_direction`."""
    p, h = np.atleast_1d(np.asarray(pitch_rad, float)), np.atleast_1d(np.asarray(heading_rad, float))
    return np.column_stack([-np.sin(h) * np.cos(p), np.cos(h) * np.cos(p), np.sin(p)])


def effective_scale(sim: SimResult, t_from_s: float, t_to_s: float) -> float:
    """The LDV scale a calibration over [t_from_s, t_to_s) sees: K·cos δ, speed-weighted at 10 Hz.

    The LDV measures the velocity component along its head axis (the forward column of C_d^b, from
    the simulated mounting), so it reports K·|v|·cos δ, δ the angle between the head axis and the
    true travel direction (stance pitch and crab, squat, bounce). Without body attitude δ = 0 and
    this is K. From the simulator's own parameters, never from the code under test.
    """
    from ldvsurvey.nav.errmodel import c_db

    ldv = sim.scenario.ldv
    t = np.arange(t_from_s, t_to_s, 0.1)
    p, h = effective_travel_direction(sim, t)
    cos_d = travel_unit_vector(p, h) @ c_db(ldv.pitch_rad, ldv.heading_rad)[:, 1]
    speed = sim.motion.truth(t)["speed_mps"]
    return float(ldv.scale * np.sum(cos_d * speed) / np.sum(speed))


def mean_travel_direction(
    sim: SimResult, t_from_s: float | None = None, t_to_s: float | None = None, min_speed_mps: float = 2.0
) -> dict:
    """Mean effective LDV pitch and heading over the moving samples, sampled at 10 Hz, with their std.

    Parameters
    ----------
    sim : SimResult
        The simulation.
    t_from_s, t_to_s : float, optional
        The span (s); default the whole drive.
    min_speed_mps : float
        Samples at least this fast count as moving (m/s).

    Returns
    -------
    dict
        ``pitch_rad``, ``heading_rad``, ``pitch_std_rad``, ``heading_std_rad`` (None when the log
        never moves), ``t_from_s``, ``t_to_s`` and ``n_samples``.
    """
    a = sim.scenario.t0_s if t_from_s is None else t_from_s
    b = sim.motion.t_end_s if t_to_s is None else t_to_s
    t = np.arange(a, b, 0.1)
    moving = sim.motion.truth(t)["speed_mps"] >= min_speed_mps
    if not moving.any():  # a log that never moves: no travel direction
        return {
            "pitch_rad": None,
            "heading_rad": None,
            "pitch_std_rad": None,
            "heading_std_rad": None,
            "t_from_s": float(a),
            "t_to_s": float(b),
            "n_samples": 0,
        }
    p, h = effective_travel_direction(sim, t[moving])
    return {
        "pitch_rad": float(np.mean(p)),
        "heading_rad": float(np.mean(h)),
        "pitch_std_rad": float(np.std(p)),
        "heading_std_rad": float(np.std(h)),
        "t_from_s": float(a),
        "t_to_s": float(b),
        "n_samples": int(moving.sum()),
    }


def imu_bias(sim: SimResult) -> tuple[np.ndarray, np.ndarray]:
    """True total IMU biases in sensor axes at the IMU samples, ((N, 3) gyro rad/s, (N, 3) accel m/s²):
    the turn-on bias of the run plus, with ``imu_errors``, the Gauss–Markov bias instability."""
    n = len(sim.imu.t_s)
    g = np.broadcast_to(sim.errors.gyro_bias_rps, (n, 3)).copy()
    a = np.broadcast_to(sim.errors.accel_bias_mps2, (n, 3)).copy()
    e = sim.extras.get("imu_errors")
    if e is not None:
        g += e["gyro_gm_rps"]
        a += e["accel_gm_mps2"]
    return g, a


def ldv_spike_index(sim: SimResult) -> np.ndarray:
    """Indices (into the LDV rows) of the isolated spikes the ``ldv_dropouts`` effect flagged good."""
    t = np.asarray(sim.extras.get("ldv_spikes_t", []), float)
    return np.unique(np.searchsorted(sim.ldv_t_s, t))


def effective_tilt(sim: SimResult) -> dict:
    """Turntable tilt (α, β) built into the simulation and the *effective* tilt the gyros see (rad).

    The turntable axis is body z; in sensor axes it is the third column of C_b^s(η, α, β),
    k_s = (−cos α sin β, sin α, cos α cos β). The rotation η̇ k_s reaches the output of a gyro triad
    with scale factors and non-orthogonality through its matrix M_g = I + S_g + N_g (``imuerrors``),
    so the gyros see the axis k' = M_g k_s. A tilt estimated from the rotation (and the one that
    compensates the attitude) is therefore α_eff = asin(k'_y/|k'|), β_eff = atan2(−k'_x, k'_z),
    to first order α + N_yz, β − N_xz. The accelerometers cannot tell a tilt from a bias fixed in
    the sensor frame, so their non-orthogonality does not enter. Computed here from the
    simulator's own parameters, never by the code under test. Without ``imu_errors`` the
    effective tilt is the built-in one.
    """
    a, b = float(sim.scenario.alpha_rad), float(sim.scenario.beta_rad)
    k = np.array([-np.cos(a) * np.sin(b), np.sin(a), np.cos(a) * np.cos(b)])
    e = sim.extras.get("imu_errors")
    m = np.asarray(e["m_gyro"], float) if e is not None else np.eye(3)
    kp = m @ k
    return {
        "alpha_rad": a,
        "beta_rad": b,
        "alpha_eff_rad": float(np.arcsin(kp[1] / np.linalg.norm(kp))),
        "beta_eff_rad": float(np.arctan2(-kp[0], kp[2])),
    }


def grid_files(sim: SimResult) -> dict[str, bytes]:
    """ICGEM ``.gdf`` grids of the effect's gravity field over the survey area: ``xi.gdf``,
    ``eta.gdf`` (arcsec) and ``dg.gdf`` (mGal) at the mean track height; empty without the effect."""
    from ldvsurvey.io.gdf import write_gdf
    from ldvsurvey.sim.pointmass import PointMassField, grid_axes

    field = sim.extras.get("gravity_field")
    eff = sim.scenario.effects.gravity_field
    if not isinstance(field, PointMassField) or eff is None:
        return {}
    lat, lon = grid_axes(sim.imu.lat_rad, sim.imu.lon_rad, eff.grid_step_arcmin)
    h = float(np.mean(sim.imu.h_m))
    xi, eta, dg = field.grids(lat, lon, h)
    return {
        "xi.gdf": write_gdf(lat, lon, xi, "xi", "arcsec"),
        "eta.gdf": write_gdf(lat, lon, eta, "eta", "arcsec"),
        "dg.gdf": write_gdf(lat, lon, dg, "gravity_disturbance", "mGal"),
    }


def effect_truth(sim: SimResult, sl=slice(None)) -> tuple[dict, dict]:
    """Truth of the effects: extra ``truth.csv`` columns at the IMU samples ``sl`` and ``truth.json`` keys.

    Columns: ``dg_mgal``, ``xi_arcsec``, ``eta_arcsec`` (the field at the IMU), ``ldv_travel_pitch_deg``,
    ``ldv_travel_heading_deg`` (effective travel direction in IMU-body axes, LDV mounting convention:
    compare with a calibrated mounting), ``head_travel_pitch_deg``, ``head_travel_heading_deg`` (the
    same direction in the LDV head's own axes; 0 for an LDV riding the travel direction),
    ``body_pitch_deg``, ``body_roll_deg``, ``body_yaw_deg`` (body over travel direction),
    ``gyro_gm_{x,y,z}_dph``, ``accel_gm_{x,y,z}_ug`` (bias instability, sensor axes).
    """
    from ldvsurvey.nav.earth import ARCSEC, MGAL

    sc, im, x = sim.scenario, sim.imu, sim.extras
    cols: dict = {}
    meta: dict = {"effects": sc.effects.describe(), "effects_seed": sc.effects.seed}
    t = im.t_s[sl]
    field = x.get("gravity_field")
    if sc.effects.gravity_field is not None and field is not None:
        xi, eta, dg = field(im.lat_rad[sl], im.lon_rad[sl], im.h_m[sl])
        cols.update(dg_mgal=dg / MGAL, xi_arcsec=xi / ARCSEC, eta_arcsec=eta / ARCSEC)
        if hasattr(field, "masses"):
            meta["gravity_field"] = {
                "model": "point masses, local ENU (m) around the origin",
                "origin_lat_deg": float(np.degrees(field.lat0_rad)),
                "origin_lon_deg": float(np.degrees(field.lon0_rad)),
                "origin_h_m": field.h0_m,
                "masses_e_n_u_gm": field.masses.tolist(),
            }
    if sim.body is not None:
        p, h = effective_travel_direction(sim, t)
        bp, br, by = sim.body.angles(t)
        from ldvsurvey.nav.errmodel import c_db

        u_d = travel_unit_vector(p, h) @ c_db(sc.ldv.pitch_rad, sc.ldv.heading_rad)  # C_b^d u_b, row-vector form
        cols.update(
            ldv_travel_pitch_deg=np.degrees(p),
            ldv_travel_heading_deg=np.degrees(h),
            head_travel_pitch_deg=np.degrees(np.arcsin(np.clip(u_d[:, 2], -1, 1))),
            head_travel_heading_deg=np.degrees(np.arctan2(-u_d[:, 0], u_d[:, 1])),
            body_pitch_deg=np.degrees(bp),
            body_roll_deg=np.degrees(br),
            body_yaw_deg=np.degrees(by),
        )
        b = sc.effects.body_attitude
        meta["body_attitude"] = {
            "stance_pitch_rad": b.stance_pitch_rad,
            "crab_rad": b.crab_rad,
            "squat_rad_per_mps2": b.squat_rad_per_g / 9.80665,
            "roll_rad_per_mps2": b.roll_rad_per_g / 9.80665,
        }
    meta["ldv_effective"] = mean_travel_direction(sim)
    meta["ldv_effective_by_drive"] = [
        mean_travel_direction(sim, max(a, sc.t0_s), b)
        for a, b, kind, _ in sim.motion.pieces
        if kind == "drive" and b > sc.t0_s
    ]
    if sc.lines:
        meta["ldv_effective_by_line"] = {name: mean_travel_direction(sim, a, b) for name, a, b in sc.lines}
    if "imu_errors" in x:
        e = x["imu_errors"]
        for i, ax in enumerate("xyz"):
            cols[f"gyro_gm_{ax}_dph"] = np.degrees(e["gyro_gm_rps"][sl, i]) * 3600.0
        for i, ax in enumerate("xyz"):
            cols[f"accel_gm_{ax}_ug"] = e["accel_gm_mps2"][sl, i] / 9.80665e-6
        meta["imu_errors"] = {
            "gyro_matrix": e["m_gyro"].tolist(),
            "accel_matrix": e["m_accel"].tolist(),
            "gyro_gm_sigma_rps": e["gyro_gm_sigma_rps"],
            "accel_gm_sigma_mps2": e["accel_gm_sigma_mps2"],
            "gyro_tau_s": e["gyro_tau_s"],
            "accel_tau_s": e["accel_tau_s"],
        }
    if "imu_keep" in x:
        keep = x["imu_keep"]
        meta["imu_dropped_t_s"] = im.t_s[~keep].tolist()
        meta["imu_jitter_max_s"] = float(np.max(np.abs(x["imu_t_written"] - im.t_s)))
    if sim.scenario.rotating:
        meta["tilt"] = effective_tilt(sim)
    if "turntable" in x:
        tt = x["turntable"]
        meta["turntable"] = {"scheme": tt.spec.scheme, "stops": tt.stops()}
    if "ldv_bursts" in x:
        meta["ldv_bursts"] = x["ldv_bursts"]
        meta["ldv_good_spikes_t_s"] = x["ldv_spikes_t"]
    if "gnss_events" in x:
        meta["gnss_events"] = x["gnss_events"]
        meta["gnss_lever_m"] = list(sc.gnss_lever_m)
    return cols, meta
