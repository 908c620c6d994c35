"""Stages shared by several pipelines: base-tilt estimation and LDV calibration."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ldvsurvey.errors import ParameterError
from ldvsurvey.nav.errmodel import c_db
from ldvsurvey.nav.tilt import TiltEstimate, estimate_tilt, find_stops
from ldvsurvey.pipelines.base import warn
from ldvsurvey.pipelines.prep import NavInputs, c_bs_of, gnss_aid, ldv_aid, local_metres, navigate, pipeline_cfg

RAD = np.pi / 180.0
ARCSEC = RAD / 3600.0


def static_part(inp: NavInputs) -> NavInputs:
    """The inputs cut to the static period at the start."""
    k = inp.t_s <= inp.static_end_s
    return NavInputs(log=inp.log, t_s=inp.t_s[k], dtheta_rad=inp.dtheta_rad[k], dvel_mps=inp.dvel_mps[k],
                     eta_rad=None if inp.eta_rad is None else inp.eta_rad[k], ldv_ok=inp.ldv_ok[k],
                     nu_f_mps=inp.nu_f_mps[k], nu_u_mps=None if inp.nu_u_mps is None else inp.nu_u_mps[k],
                     still=[(inp.t_s[0] - 1.0, inp.static_end_s)], static_end_s=inp.static_end_s,
                     pos0=inp.pos0, noise=inp.noise)


def _tilt_from(inp: NavInputs, sol, still, stops) -> TiltEstimate:
    from ldvsurvey.nav.attitude import c_from_q

    c_sn = c_from_q(sol.q_sn)
    bias_sig = 0.0
    if sol.epoch_sigma is not None and sol.epoch_sigma.shape[1] >= 15:
        bias_sig = float(np.median(sol.epoch_sigma[:, 12:14])) / 9.8
    return estimate_tilt(inp.t_s, c_sn, inp.eta_rad, still, bias_sigma_rad=bias_sig, stops=stops)


def tilt_stage(inp: NavInputs) -> tuple[TiltEstimate, list]:
    """Estimate (α, β) from every still stretch in which the turntable turns (methods §2).

    First the static period at the start (smoothed zero-velocity filter, which also calibrates the
    horizontal accelerometer biases: the rotation makes them observable). When the turntable does
    not turn enough there, the whole log is navigated (zero-velocity updates where still, nominal
    LDV aiding) and every later still interval with turntable motion is used. When nothing makes
    the tilt observable, α = β = 0 is returned with ``observable`` False and a warning in
    ``warnings``: the caller goes on (the attitude then keeps an oscillation of the tilt's size).
    """
    if inp.eta_rad is None:
        raise ParameterError("the IMU does not rotate (manifest imu.rotating is false, no turntable_deg)",
                             file="imu.csv", field="turntable_deg")
    key = ("tilt_stage",)
    if key in inp.cache:
        return inp.cache[key]
    st = static_part(inp)
    stops = find_stops(st.t_s, st.eta_rad)
    est = None
    if len(st.t_s) >= 100:
        sol = navigate(st, cbs=c_bs_of(st), cfg=pipeline_cfg(), smooth=True)
        est = _tilt_from(st, sol, st.still, stops)
    later = [(a, b) for a, b in inp.still if a >= inp.static_end_s - 1e-6]
    if (est is None or not est.observable) and later:
        stops_all = find_stops(inp.t_s, inp.eta_rad)
        sol = navigate(inp, cbs=c_bs_of(inp), ldv=ldv_aid(inp), cfg=pipeline_cfg(), smooth=True)
        est2 = _tilt_from(inp, sol, inp.still, stops_all)
        if est2.observable or est is None:
            est, stops = est2, stops_all
    for w in est.warnings:
        warn(w)
    inp.cache[key] = (est, stops)
    return est, stops


@dataclass
class Calibration:
    """LDV mounting and scale: values (rad, –) with 1-σ, from the KF; closed-form values beside."""

    pitch_rad: float
    heading_rad: float
    scale: float
    scale_up: float
    sigma: dict
    closed_form: dict
    window_s: tuple[float, float]
    track: dict  # calibration_track columns


def choose_window(inp: NavInputs, window=None, min_distance_m: float = 500.0) -> tuple[float, float]:
    """The calibration stretch: given, or the longest good-GNSS (fix 4/2) moving stretch."""
    g = inp.log.gnss
    if g is None:
        raise ParameterError("calibration needs GNSS fixes (no gnss.nmea in the bundle)", file="gnss.nmea")
    t0, t1 = float(inp.t_s[0]), float(inp.t_s[-1])
    good = np.isin(g.fix, (4, 2)) & np.isfinite(g.lat_deg)
    if window is not None:
        a, b = window
        if not (t0 <= a < b <= t1):
            raise ParameterError(f"calibration_window [{a}, {b}] s is not inside the log [{t0:.2f}, {t1:.2f}] s",
                                 field="calibration_window")
        if np.count_nonzero(good & (g.t_s >= a) & (g.t_s <= b)) < 10:
            raise ParameterError("fewer than 10 GNSS fixes of quality 4 or 2 in the calibration window",
                                 field="calibration_window")
        return float(a), float(b)
    speed = np.interp(g.t_s, inp.t_s, np.abs(inp.nu_f_mps))
    best, best_d = None, 0.0
    idx = np.flatnonzero(good)
    if len(idx) == 0:
        raise ParameterError("no GNSS fix of quality 4 (RTK fixed) or 2 (differential) for the calibration",
                             file="gnss.nmea", field="fix_quality")
    runs = np.split(idx, np.flatnonzero(np.diff(g.t_s[idx]) > 2.5) + 1)
    for r in runs:
        mv = r[speed[r] > 1.0]
        if len(mv) < 2:
            continue
        r = r[(r >= mv[0]) & (r <= mv[-1])]
        e, n = local_metres(g.lat_deg[r[0]] * RAD, g.lon_deg[r[0]] * RAD, g.lat_deg[r] * RAD, g.lon_deg[r] * RAD)
        d = float(np.sum(np.hypot(np.diff(e), np.diff(n))))
        if d > best_d:
            best, best_d = (float(g.t_s[r[0]]), float(g.t_s[r[-1]])), d
    if best is None or best_d < min_distance_m:
        raise ParameterError(f"no moving stretch with good GNSS (fix 4 or 2) of at least {min_distance_m:.0f} m "
                             "for the calibration", file="gnss.nmea", field="fix_quality")
    return best


def _dead_reckon(t, c_bn, nu_f, nu_u, ok, scale, pitch, heading, scale_up):
    """ENU positions (m) from LDV velocities through the attitude (trapezoid)."""
    vd = np.column_stack([np.zeros_like(nu_f), nu_f / scale, (nu_u / scale_up) if nu_u is not None else 0 * nu_f])
    v_n = np.einsum("kij,kj->ki", c_bn, vd @ c_db(pitch, heading).T)
    v_n[~ok] = np.nan
    good = np.isfinite(v_n[:, 0])
    for i in range(3):  # bridge unusable LDV samples
        v_n[:, i] = np.interp(t, t[good], v_n[good, i])
    dt = np.diff(t)
    return np.vstack([np.zeros(3), np.cumsum(0.5 * (v_n[1:] + v_n[:-1]) * dt[:, None], axis=0)])


def calibration_stage(inp: NavInputs, cbs, window=None, progress=None) -> Calibration:
    """Closed-form dead-reckoning comparison and the refined Kalman estimate (η_L, φ_L, K)."""
    log = inp.log
    a, b = choose_window(inp, window)
    nom = log.manifest.ldv.nominal
    up = inp.nu_u_mps is not None
    # 1) attitude from a GNSS-aided INS (all good fixes), no LDV
    if progress:
        progress("calibration: GNSS/INS attitude", 0.1)
    from ldvsurvey.pipelines.prep import gnss_ins

    sol_g = gnss_ins(inp, cbs)
    c_bn = sol_g.c_bn()
    k = (inp.t_s >= a) & (inp.t_s <= b)
    t = inp.t_s[k]
    g = log.gnss
    gk = np.isin(g.fix, (4, 2)) & (g.t_s >= a) & (g.t_s <= b) & np.isfinite(g.lat_deg)
    lev = np.asarray(log.manifest.gnss.lever_arm_m, float)
    from ldvsurvey.pipelines.prep import attitude_at

    c_fix = attitude_at(sol_g, g.t_s[gk], c_bn)
    lev_n = c_fix @ lev
    lat_r, lon_r = g.lat_deg[gk] * RAD, g.lon_deg[gk] * RAD
    e, n = local_metres(lat_r[0], lon_r[0], lat_r, lon_r)
    gpos = np.column_stack([e - lev_n[:, 0], n - lev_n[:, 1], g.h_m[gk] - lev_n[:, 2]])
    gpos -= gpos[0]
    # 2) closed form: similarity fit of the horizontal tracks, slope of the height residual
    pitch, heading, scale = nom.pitch_deg * RAD, nom.heading_deg * RAD, nom.scale
    nu_u = inp.nu_u_mps[k] if up else None
    for _ in range(3):
        dr = _dead_reckon(t, c_bn[k], inp.nu_f_mps[k], nu_u, inp.ldv_ok[k], scale, pitch, heading, 1.0)
        drg = np.column_stack([np.interp(g.t_s[gk], t, dr[:, i]) for i in range(3)])
        drg -= drg[0]
        d2 = drg[:, :2]
        g2 = gpos[:, :2]
        rho = np.arctan2(np.sum(d2[:, 0] * g2[:, 1] - d2[:, 1] * g2[:, 0]), np.sum(d2 * g2))
        rot = np.array([[np.cos(rho), -np.sin(rho)], [np.sin(rho), np.cos(rho)]])
        sig = np.sum(g2 * (d2 @ rot.T)) / np.sum(d2 * d2)
        heading += rho
        scale /= sig
        dist = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(g2, axis=0).T))])
        res_h = gpos[:, 2] - drg[:, 2]
        slope = np.polyfit(dist, res_h, 1)[0]
        pitch += np.arcsin(np.clip(slope, -1, 1))
    res2 = g2 - sig * (d2 @ rot.T)
    rms_h = float(np.sqrt(np.mean(res2 ** 2)))
    span = float(np.sqrt(np.sum(d2 ** 2)))
    resid_v = res_h - np.polyval(np.polyfit(dist, res_h, 1), dist)
    closed = {"ldv_pitch_deg": pitch / RAD, "ldv_heading_deg": heading / RAD, "ldv_scale": scale,
              "ldv_pitch_deg_sigma": float(np.std(resid_v) / np.sqrt(np.sum((dist - dist.mean()) ** 2)) / RAD),
              "ldv_heading_deg_sigma": rms_h / span / RAD, "ldv_scale_sigma": rms_h / span * scale,
              "n_fixes": int(len(dist))}
    # 3) refined: the filter with the LDV states augmented, GNSS only in the window
    if progress:
        progress("calibration: Kalman filter with LDV states", 0.5)
    # the up-axis scale is observable only when the LDV up channel carries motion
    moving = inp.ldv_ok & (np.abs(inp.nu_f_mps) > 1.0)
    up_obs = up and moving.any() and float(np.sqrt(np.mean(inp.nu_u_mps[moving] ** 2))) > 0.05
    aug = ("scale", "pitch", "heading") + (("scale_up",) if up_obs else ())
    cfg = pipeline_cfg(ldv_aug=aug)
    sol = navigate(inp, cbs=cbs, ldv=ldv_aid(inp), gnss=gnss_aid(log, fixes=(4, 2), window=(a, b)), cfg=cfg)
    p = sol.ldv_params
    cal = Calibration(pitch_rad=p["pitch"][0], heading_rad=p["heading"][0], scale=p["scale"][0],
                      scale_up=p["scale_up"][0] if up_obs else log.manifest.ldv.nominal.scale,
                      sigma={"pitch": p["pitch"][1], "heading": p["heading"][1], "scale": p["scale"][1],
                             "scale_up": p["scale_up"][1] if up_obs else None},
                      closed_form=closed, window_s=(a, b), track={})
    if up and not up_obs:
        cal.closed_form["note"] = ("up-axis scale not estimated: the LDV up channel shows no motion "
                                   "(rms < 0.05 m/s) in the window; the nominal scale is used")
    # 4) the calibrated dead-reckoning track over the window, from the first fix
    dr = _dead_reckon(t, c_bn[k], inp.nu_f_mps[k], nu_u, inp.ldv_ok[k], cal.scale, cal.pitch_rad,
                      cal.heading_rad, cal.scale_up)
    t_first = g.t_s[gk][0]
    dr -= np.column_stack([np.interp(t_first, t, dr[:, i]) for i in range(3)])
    from ldvsurvey.nav.earth import radii

    rm, rn = radii(lat_r[0])
    lat = lat_r[0] - lev_n[0, 1] / rm + dr[:, 1] / rm
    lon = lon_r[0] - lev_n[0, 0] / (rn * np.cos(lat_r[0])) + dr[:, 0] / (rn * np.cos(lat_r[0]))
    h = g.h_m[gk][0] - lev_n[0, 2] + dr[:, 2]
    step = max(1, int(round(0.1 / np.median(np.diff(t)))))  # 10 Hz
    cal.track = {"t_s": t[::step], "lat_deg": np.degrees(lat[::step]), "lon_deg": np.degrees(lon[::step]),
                 "h_m": h[::step]}
    return cal


#: the parameters shared by every pipeline that navigates with a calibrated LDV
def calibration_params():
    from ldvsurvey.pipelines.base import Param

    return [
        Param("calibration", "str", "auto", "auto: calibrate the LDV against GNSS in this log; nominal: use the "
              "manifest's nominal mounting; given values of ldv_* always win", choices=("auto", "nominal")),
        Param("calibration_window", "floats", None, "t0,t1 in s for the automatic calibration"),
        Param("ldv_pitch_deg", "float", None, "LDV mounting pitch η_L"),
        Param("ldv_heading_deg", "float", None, "LDV mounting heading φ_L"),
        Param("ldv_scale", "float", None, "LDV scale factor K"),
    ]


@dataclass
class LdvSetup:
    """Tilt (rotating IMU), LDV mounting and scale as used, and where they came from."""

    cbs: np.ndarray | None
    tilt: TiltEstimate | None
    pitch_rad: float
    heading_rad: float
    scale: float
    scale_up: float
    info: dict
    warnings: list


def ldv_setup(inp: NavInputs, params: dict, progress) -> LdvSetup:
    """Base tilt (if the IMU rotates), then the LDV calibration: given, automatic or nominal."""
    log = inp.log
    m = log.manifest
    warnings = list(inp.warnings)
    est = None
    cbs = None
    if inp.eta_rad is not None:
        progress("base tilt of the rotating IMU", 0.05)
        est, _ = tilt_stage(inp)
        warnings += est.warnings
        cbs = c_bs_of(inp, est.alpha_rad, est.beta_rad)
    given = {k: params[k] for k in ("ldv_pitch_deg", "ldv_heading_deg", "ldv_scale") if params.get(k) is not None}
    info = {"source": "nominal"}
    pitch, heading, scale, scale_up = (m.ldv.nominal.pitch_deg * RAD, m.ldv.nominal.heading_deg * RAD,
                                       m.ldv.nominal.scale, 1.0)
    if params.get("calibration", "auto") == "auto" and len(given) < 3:
        if log.gnss is None:
            warnings.append("no GNSS: the LDV is used with its nominal mounting (no calibration)")
        else:
            progress("LDV calibration against GNSS", 0.15)
            cal = calibration_stage(inp, cbs, params.get("calibration_window"))
            pitch, heading, scale, scale_up = cal.pitch_rad, cal.heading_rad, cal.scale, cal.scale_up
            info = {"source": "calibrate", "segment_t_s": list(cal.window_s)}
    if "ldv_pitch_deg" in given:
        pitch = given["ldv_pitch_deg"] * RAD
    if "ldv_heading_deg" in given:
        heading = given["ldv_heading_deg"] * RAD
    if "ldv_scale" in given:
        scale = given["ldv_scale"]
    if given:
        info["given"] = given
    info.update({"ldv_pitch_deg": pitch / RAD, "ldv_heading_deg": heading / RAD, "ldv_scale": scale})
    if inp.nu_u_mps is not None:
        info["ldv_scale_up"] = scale_up
    return LdvSetup(cbs, est, pitch, heading, scale, scale_up, info, warnings)


def ldv_aid_of(inp: NavInputs, setup: LdvSetup):
    return ldv_aid(inp, scale=setup.scale, pitch_rad=setup.pitch_rad, heading_rad=setup.heading_rad,
                   scale_up=setup.scale_up)
