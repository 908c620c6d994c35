"""LDV calibration shared by pipelines: mounting, pitch compliance and scale from a GNSS window,
and the LDV set-up every pipeline applies."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np
from pydantic import Field, field_validator

from ldvsurvey.errors import ParameterError
from ldvsurvey.nav.earth import radii
from ldvsurvey.nav.filter import LdvAid, forward_accel_mps2
from ldvsurvey.nav.innovations import variance_inflation
from ldvsurvey.nav.turntable import TiltEstimate
from ldvsurvey.pipelines.base import Floats, LogFacts, Params, Progress, Reason, window_inside
from ldvsurvey.pipelines.stages.aids import (
    NAV_FIXES,
    NavInputs,
    attitude_at,
    c_bs_of,
    gnss_aid,
    ldv_aid,
    local_metres,
    pipeline_cfg,
    run_navigation_filter,
)
from ldvsurvey.pipelines.stages.turntable_tilt import tilt_stage
from ldvsurvey.units import G0_MPS2, RAD_PER_DEG


@dataclass
class Calibration:
    """LDV mounting, compliance and scale: values (rad, rad per m/s², –) with 1-σ, from the KF;
    closed-form values beside."""

    pitch_rad: float
    heading_rad: float
    scale: float
    scale_up: float
    sigma: dict
    closed_form: dict
    window_s: tuple[float, float]
    track: dict  # calibration_track columns
    pitch_k_rad_per_mps2: float = 0.0  #: pitch compliance: travel direction pitch per m/s² forward accel
    fixes: tuple = (4, 2)  #: GNSS fix qualities used
    #: factors (≥ 1) applied to the filter's 1-σ for time-correlated GNSS residuals (horizontal:
    #: heading, scale; vertical: pitch, compliance, up scale) with the innovation statistics
    sigma_inflation: dict | None = None
    #: the navigation the estimate came from when it was made jointly with the final navigation
    #: (``joint``: every sample's velocity and position kept, and its specific force if asked), else None
    solution: object = None


#: fix qualities for the calibration, best first: RTK fixed, then RTK float and differential
GOOD_FIXES = ((4,), (4, 5, 2))


def choose_window(inp: NavInputs, window=None, min_distance_m: float = 500.0) -> tuple[float, float]:
    """The calibration stretch: given, or the longest RTK-fixed (fix 4) moving stretch, else the
    longest one of fix 4, 5 or 2.

    Parameters
    ----------
    inp : NavInputs
        The loaded log (GNSS needed).
    window : (float, float) or None
        A given ``t0, t1`` (s), checked to lie inside the log and hold 10 good fixes.
    min_distance_m : float
        The shortest stretch (m) accepted when none is given.

    Returns
    -------
    (float, float)
        ``t0, t1`` (s) of the stretch.
    """
    return _choose_window(inp, window, min_distance_m)[0]


def _choose_window(inp: NavInputs, window=None, min_distance_m: float = 500.0):
    g = inp.log.gnss
    if g is None:
        raise ParameterError("calibration needs GNSS fixes (no gnss.nmea in the bundle)", file="gnss.nmea")
    t0, t1 = float(inp.t_s[0]), float(inp.t_s[-1])
    if window is not None:
        a, b = window
        if not (t0 <= a < b <= t1):
            raise ParameterError(
                f"calibration_window [{a}, {b}] s is not inside the log [{t0:.2f}, {t1:.2f}] s",
                field="calibration_window",
            )
        for fixes in GOOD_FIXES:
            good = np.isin(g.fix, fixes) & np.isfinite(g.lat_deg)
            if np.count_nonzero(good & (g.t_s >= a) & (g.t_s <= b)) >= 10:
                return (float(a), float(b)), fixes
        raise ParameterError(
            "fewer than 10 GNSS fixes of quality 4, 5 or 2 in the calibration window", field="calibration_window"
        )
    speed = np.interp(g.t_s, inp.t_s, np.abs(inp.nu_f_mps))
    for fixes in GOOD_FIXES:
        good = np.isin(g.fix, fixes) & np.isfinite(g.lat_deg)
        best, best_d = None, 0.0
        idx = np.flatnonzero(good)
        runs = np.split(idx, np.flatnonzero(np.diff(g.t_s[idx]) > 2.5) + 1) if len(idx) else []
        for r in runs:
            mv = r[speed[r] > 1.0]
            if len(mv) < 2:
                continue
            r = r[(r >= mv[0]) & (r <= mv[-1])]
            e, n = local_metres(
                g.lat_deg[r[0]] * RAD_PER_DEG,
                g.lon_deg[r[0]] * RAD_PER_DEG,
                g.lat_deg[r] * RAD_PER_DEG,
                g.lon_deg[r] * RAD_PER_DEG,
            )
            d = float(np.sum(np.hypot(np.diff(e), np.diff(n))))
            if d > best_d:
                best, best_d = (float(g.t_s[r[0]]), float(g.t_s[r[-1]])), d
        if best is not None and best_d >= min_distance_m:
            return best, fixes
    raise ParameterError(
        f"no moving stretch with good GNSS (fix 4, 5 or 2) of at least {min_distance_m:.0f} m for the calibration",
        file="gnss.nmea",
        field="fix_quality",
    )


def ldv_body_velocity(
    nu_f_mps, nu_u_mps, scale, pitch_rad, heading_rad, scale_up=1.0, pitch_k_rad_per_mps2=0.0, accel_fwd_mps2=None
):
    """The LDV velocity in the body frame: V^b = C_d^b(η_L + k_η a_f, φ_L) [0, ν_f/K, ν_u/K_u].

    Parameters
    ----------
    nu_f_mps, nu_u_mps : ndarray
        Measured speeds (m/s) along the head's forward and up axes (``nu_u_mps`` None: a 1-D LDV, ν_u = 0).
    scale, scale_up : float
        Scale factors K, K_u (dimensionless).
    pitch_rad, heading_rad : float
        Mounting pitch η_L and heading φ_L of the travel direction the LDV sees (rad).
    pitch_k_rad_per_mps2 : float
        Pitch compliance k_η (rad per m/s² of forward acceleration).
    accel_fwd_mps2 : ndarray or None
        Forward acceleration along the travel (m/s²) per sample, with the compliance.

    Returns
    -------
    ndarray
        (N, 3) body-frame velocity (m/s, right-forward-up).
    """
    nu_f = np.asarray(nu_f_mps, float)
    vd1 = nu_f / scale
    vd2 = np.asarray(nu_u_mps, float) / scale_up if nu_u_mps is not None else np.zeros_like(nu_f)
    pitch_k = pitch_k_rad_per_mps2
    eta = pitch_rad + (pitch_k * np.asarray(accel_fwd_mps2, float) if accel_fwd_mps2 is not None and pitch_k else 0.0)
    ce, se, cp, sp = np.cos(eta), np.sin(eta), np.cos(heading_rad), np.sin(heading_rad)
    return np.column_stack([-sp * ce * vd1 + sp * se * vd2, cp * ce * vd1 - cp * se * vd2, se * vd1 + ce * vd2])


def aid_body_velocity(aid: LdvAid) -> np.ndarray:
    """:func:`ldv_body_velocity` of an aid's samples through its mounting, compliance and scales (m/s, (N, 3))."""
    return ldv_body_velocity(
        aid.nu_f_mps,
        aid.nu_u_mps,
        aid.scale,
        aid.pitch_rad,
        aid.heading_rad,
        aid.scale_up,
        aid.pitch_k_rad_per_mps2,
        aid.accel_fwd_mps2,
    )


def accel_fwd(inp: NavInputs) -> np.ndarray:
    """Forward acceleration along the travel (m/s²) at the IMU samples, from the LDV (once per run)."""
    if "accel_fwd" not in inp.cache:
        inp.cache["accel_fwd"] = forward_accel_mps2(inp.t_s, inp.nu_f_mps, inp.ldv_ok)
    return inp.cache["accel_fwd"]


def _dead_reckon(t_s: np.ndarray, c_bn: np.ndarray, ldv: LdvAid) -> np.ndarray:
    """ENU positions (m) from the LDV velocities through the attitude (trapezoid; unusable samples bridged)."""
    v_n = np.einsum("kij,kj->ki", c_bn, aid_body_velocity(ldv))
    v_n[~ldv.ok] = np.nan
    good = np.isfinite(v_n[:, 0])
    for i in range(3):  # bridge unusable LDV samples
        v_n[:, i] = np.interp(t_s, t_s[good], v_n[good, i])
    dt = np.diff(t_s)
    return np.vstack([np.zeros(3), np.cumsum(0.5 * (v_n[1:] + v_n[:-1]) * dt[:, None], axis=0)])


#: the fix qualities of the automatic calibration: RTK fixed, RTK float, differential
CAL_FIXES = (4, 5, 2)


def _epochs_fixed_by(epoch_t_s: np.ndarray, gnss, fixes, aided=NAV_FIXES) -> np.ndarray:
    """(M+1,) bool: the filter epochs whose GNSS update came from a fix of the qualities ``fixes``,
    the filter having taken the fixes of the qualities ``aided`` (a fix at t updates the epoch
    ending at or after t; of several in one epoch, the last one)."""
    ok = np.isfinite(gnss.lat_deg) & np.isin(gnss.fix, aided)
    j = np.searchsorted(epoch_t_s, gnss.t_s[ok], side="left")  # fix times never decrease: j sorted
    last = np.append(j[1:] != j[:-1], True) & (j < len(epoch_t_s))  # the last fix of each epoch
    out = np.zeros(len(epoch_t_s), dtype=bool)
    out[j[last]] = np.isin(gnss.fix[ok][last], fixes)
    return out


@dataclass(frozen=True)
class _Windows:
    """The calibration's stretches: the closed form's (``a_s``, ``b_s`` with its fix qualities) and
    the filter's GNSS window (``kf_win_s``, ``kf_fixes``)."""

    a_s: float
    b_s: float
    fixes: tuple
    kf_fixes: tuple
    kf_win_s: tuple[float, float]


def _windows(inp: NavInputs, window, joint: bool) -> _Windows:
    """The closed form's window and the filter's: a given window, else every good fix of the log
    (RTK fixed, float and differential, each weighted by its quality's σ; joint: every fix the
    navigation takes) — all starts, stops and both directions of travel."""
    (a, b), fixes = _choose_window(inp, window)
    g = inp.log.gnss
    if joint or window is None:
        kf_fixes = NAV_FIXES if joint else CAL_FIXES
        g_ok = np.isin(g.fix, kf_fixes) & np.isfinite(g.lat_deg)
        kf_win = (float(g.t_s[g_ok][0]), float(g.t_s[g_ok][-1]))
    else:
        kf_fixes, kf_win = fixes, (a, b)
    return _Windows(a, b, fixes, kf_fixes, kf_win)


def _kalman_calibration(
    inp: NavInputs, cbs, win: _Windows, joint: bool, specific_force: bool
) -> tuple[Calibration, object]:
    """The filter with the LDV states augmented (LDV everywhere, GNSS in the filter's window): the
    mounting, compliance and scale with their 1-σ inflated for time-correlated GNSS residuals
    (``closed_form`` holding only its notes, ``track`` empty), and the navigation solution."""
    log = inp.log
    nom = log.manifest.ldv.nominal
    up = inp.nu_u_mps is not None
    a_f = accel_fwd(inp)
    # the up-axis scale is observable only when the LDV up channel carries motion
    moving = inp.ldv_ok & (np.abs(inp.nu_f_mps) > 1.0)
    up_obs = up and moving.any() and float(np.sqrt(np.mean(inp.nu_u_mps[moving] ** 2))) > 0.05
    in_win = (inp.t_s >= win.kf_win_s[0]) & (inp.t_s <= win.kf_win_s[1])
    # the compliance is observable when the window holds accelerations (≥ 0.3 m/s² for ≥ 10 s)
    k_obs = float(np.count_nonzero(in_win & inp.ldv_ok & (np.abs(a_f) > 0.3))) * np.median(np.diff(inp.t_s)) >= 10.0
    aug = ("scale", "pitch", "heading") + (("scale_up",) if up_obs else ()) + (("pitch_k",) if k_obs else ())
    cfg = pipeline_cfg(ldv_aug=aug)
    aid = ldv_aid(inp, scale_up=nom.scale)  # the up scale starts from (unobservable: stays at) the nominal
    aid.accel_fwd_mps2 = a_f
    sol = run_navigation_filter(
        inp,
        cbs=cbs,
        ldv=aid,
        gnss=gnss_aid(log, fixes=win.kf_fixes, window=win.kf_win_s),
        cfg=cfg,
        attitude_only=not joint,
        specific_force=specific_force,
    )  # its use: the LDV states and the attitude (joint: the whole navigation)
    p = sol.ldv_params
    pk, spk = p.get("pitch_k", (0.0, None)) if k_obs else (0.0, None)
    # GNSS errors are time-correlated (and unmodelled IMU errors show in the GNSS residuals the same
    # way): the filter, which takes them as white, is over-confident by √(s²·τ) of its GNSS
    # innovations (nav/innovations.py); horizontal residuals carry heading and scale, vertical pitch
    inn = sol.normalized_innovations[:, 6:9]
    if joint:  # the 1-σ speak for the calibration's own fixes (4, 5, 2), as in a calibration alone
        inn = np.where(_epochs_fixed_by(sol.epoch_t_s, log.gnss, CAL_FIXES, win.kf_fixes)[:, None], inn, np.nan)
    infl = [variance_inflation(inn[:, i], gate=cfg.gate_sigma or np.inf) for i in range(3)]
    f_h = np.sqrt(max(infl[0]["factor"], infl[1]["factor"]))
    f_v = np.sqrt(infl[2]["factor"])
    cal = Calibration(
        pitch_rad=p["pitch"][0],
        heading_rad=p["heading"][0],
        scale=p["scale"][0],
        scale_up=p["scale_up"][0] if up_obs else log.manifest.ldv.nominal.scale,
        sigma={
            "pitch": p["pitch"][1] * f_v,
            "heading": p["heading"][1] * f_h,
            "scale": p["scale"][1] * f_h,
            "scale_up": p["scale_up"][1] * f_v if up_obs else None,
            "pitch_k": None if spk is None else spk * f_v,
        },
        closed_form={},
        window_s=win.kf_win_s,
        track={},
        pitch_k_rad_per_mps2=pk,
        fixes=win.kf_fixes,
        sigma_inflation={"horizontal": float(f_h), "vertical": float(f_v), "gnss_innovations": dict(zip("enu", infl))},
        solution=sol if joint else None,
    )
    if up and not up_obs:
        cal.closed_form["note"] = (
            "up-axis scale not estimated: the LDV up channel shows no motion "
            "(rms < 0.05 m/s) in the window; the nominal scale is used"
        )
    if not k_obs:
        cal.closed_form["note_compliance"] = (
            "pitch compliance not estimated: the window holds less than 10 s "
            "of acceleration above 0.3 m/s²; none is applied"
        )
    return cal, sol


@dataclass(frozen=True)
class _WindowSamples:
    """The closed form's window: IMU samples (mask ``k``, times, the filter's C_b^n), its GNSS fixes
    (mask ``gk``) with the lever arm in ENU (m) at each and their latitude, longitude (rad)."""

    k: np.ndarray
    t_s: np.ndarray
    c_bn: np.ndarray
    gk: np.ndarray
    lev_n_m: np.ndarray
    lat_rad: np.ndarray
    lon_rad: np.ndarray


def _window_samples(inp: NavInputs, sol, win: _Windows) -> _WindowSamples:
    """The samples and fixes of the closed form's window, with the filter's attitude."""
    k = (inp.t_s >= win.a_s) & (inp.t_s <= win.b_s)
    g = inp.log.gnss
    gk = np.isin(g.fix, win.fixes) & (g.t_s >= win.a_s) & (g.t_s <= win.b_s) & np.isfinite(g.lat_deg)
    lev = np.asarray(inp.log.manifest.gnss.lever_arm_m, float)
    c_fix = attitude_at(sol, g.t_s[gk])
    return _WindowSamples(
        k=k,
        t_s=inp.t_s[k],
        c_bn=sol.c_bn(k),  # over the window only
        gk=gk,
        lev_n_m=c_fix @ lev,
        lat_rad=g.lat_deg[gk] * RAD_PER_DEG,
        lon_rad=g.lon_deg[gk] * RAD_PER_DEG,
    )


def _closed_form(inp: NavInputs, w: _WindowSamples) -> dict:
    """Closed form over the window with the filter's attitude: similarity fit of the horizontal
    dead-reckoned track to the GNSS track (heading, scale), slope of the height residual (pitch); no
    compliance: it shows what a constant mounting gives. Values in deg and dimensionless, with 1-σ."""
    g = inp.log.gnss
    nom = inp.log.manifest.ldv.nominal
    lev_n = w.lev_n_m
    e, n = local_metres(w.lat_rad[0], w.lon_rad[0], w.lat_rad, w.lon_rad)
    gpos = np.column_stack([e - lev_n[:, 0], n - lev_n[:, 1], g.h_m[w.gk] - lev_n[:, 2]])
    gpos -= gpos[0]
    pitch, heading, scale = nom.pitch_deg * RAD_PER_DEG, nom.heading_deg * RAD_PER_DEG, nom.scale
    nu_u = inp.nu_u_mps[w.k] if inp.nu_u_mps is not None else None
    for _ in range(3):
        aid = LdvAid(
            inp.ldv_ok[w.k], inp.nu_f_mps[w.k], nu_u, scale=scale, pitch_rad=pitch, heading_rad=heading, scale_up=1.0
        )
        dr = _dead_reckon(w.t_s, w.c_bn, aid)
        drg = np.column_stack([np.interp(g.t_s[w.gk], w.t_s, dr[:, i]) for i in range(3)])
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
    rms_h = float(np.sqrt(np.mean(res2**2)))
    span = float(np.sqrt(np.sum(d2**2)))
    resid_v = res_h - np.polyval(np.polyfit(dist, res_h, 1), dist)
    return {
        "ldv_pitch_deg": pitch / RAD_PER_DEG,
        "ldv_heading_deg": heading / RAD_PER_DEG,
        "ldv_scale": scale,
        "ldv_pitch_deg_sigma": float(np.std(resid_v) / np.sqrt(np.sum((dist - dist.mean()) ** 2)) / RAD_PER_DEG),
        "ldv_heading_deg_sigma": rms_h / span / RAD_PER_DEG,
        "ldv_scale_sigma": rms_h / span * scale,
        "n_fixes": int(len(dist)),
    }


def _calibrated_track(inp: NavInputs, w: _WindowSamples, cal: Calibration) -> dict:
    """The calibrated dead-reckoning track over the window from the first fix, at 10 Hz: the
    ``calibration_track`` columns (t_s, lat_deg, lon_deg, h_m of the IMU centre)."""
    g = inp.log.gnss
    k = w.k
    t = w.t_s
    aid = LdvAid(
        inp.ldv_ok[k],
        inp.nu_f_mps[k],
        inp.nu_u_mps[k] if inp.nu_u_mps is not None else None,
        scale=cal.scale,
        pitch_rad=cal.pitch_rad,
        heading_rad=cal.heading_rad,
        scale_up=cal.scale_up,
        accel_fwd_mps2=accel_fwd(inp)[k],
        pitch_k_rad_per_mps2=cal.pitch_k_rad_per_mps2,
    )
    dr = _dead_reckon(t, w.c_bn, aid)
    t_first = g.t_s[w.gk][0]
    dr -= np.column_stack([np.interp(t_first, t, dr[:, i]) for i in range(3)])
    lat_r, lon_r, lev_n = w.lat_rad, w.lon_rad, w.lev_n_m
    rm, rn = radii(lat_r[0])
    lat = lat_r[0] - lev_n[0, 1] / rm + dr[:, 1] / rm
    lon = lon_r[0] - lev_n[0, 0] / (rn * np.cos(lat_r[0])) + dr[:, 0] / (rn * np.cos(lat_r[0]))
    h = g.h_m[w.gk][0] - lev_n[0, 2] + dr[:, 2]
    step = max(1, int(round(0.1 / np.median(np.diff(t)))))  # 10 Hz
    return {
        "t_s": t[::step],
        "lat_deg": np.degrees(lat[::step]),
        "lon_deg": np.degrees(lon[::step]),
        "h_m": h[::step],
    }


def calibration_stage(
    inp: NavInputs,
    cbs: np.ndarray | None,
    window: tuple[float, float] | list[float] | None = None,
    progress: Progress | None = None,
    joint: bool = False,
    specific_force: bool = True,
) -> Calibration:
    """The Kalman estimate of the travel direction the LDV sees (η_L, φ_L, pitch compliance k_η)
    and the scale K, with the closed-form dead-reckoning comparison beside.

    One navigation: the filter with the LDV states augmented, LDV everywhere and GNSS (fix 4, else
    4/5/2) in the window; its attitude also serves the closed form (no separate GNSS/INS run).

    Parameters
    ----------
    inp : NavInputs
        The loaded log (with GNSS and a usable LDV).
    cbs : ndarray or None
        C_b^s per sample of a rotating IMU (tilt applied), None for a fixed one.
    window : (float, float) or None
        ``t0, t1`` (s) of the stretch to calibrate on; None: every good fix of the log for the
        filter, the longest good-GNSS moving stretch for the closed form.
    progress : Progress or None
        Stage reporter.
    joint : bool
        No ``window``: the navigation of the ``navigate`` pipeline with ``aiding=ldv+gnss``, i.e.
        every fix the navigation takes (:func:`~ldvsurvey.pipelines.stages.aids.gnss_aid`'s
        qualities, the single-point ones included, each with its quality's σ), kept whole in
        ``Calibration.solution``: the LDV calibration estimated together with the navigation in one
        filter and smoother, instead of a second run with the estimate held fixed.
    specific_force : bool
        Whether that joint navigation keeps the up specific force per sample (as gravity needs).

    Returns
    -------
    Calibration
        Mounting pitch and heading (rad), compliance (rad per m/s²), scales, their 1-σ, the closed
        form (deg) and the calibrated track over the window.
    """
    if joint and window is not None:
        raise ValueError("a joint calibration takes every fix of the log: no window")
    win = _windows(inp, window, joint)
    if progress:
        progress("calibration: Kalman filter with LDV states", 0.1)
    cal, sol = _kalman_calibration(inp, cbs, win, joint, specific_force)
    if progress:
        progress("calibration: closed form", 0.8)
    w = _window_samples(inp, sol, win)
    cal.closed_form = {**_closed_form(inp, w), **cal.closed_form}
    cal.track = _calibrated_track(inp, w, cal)
    return cal


class LdvMountingParams(Params):
    """The LDV mounting and scale a user may give: each given value wins over the manifest's nominal
    one and over any calibration (shared by ``tilt``'s aiding and :class:`CalibrationParams`)."""

    ldv_pitch_deg: float | None = Field(
        None,
        ge=-45.0,
        le=45.0,
        description="LDV mounting pitch η_L in degrees (|η_L| ≤ 45°; default: calibrated or manifest nominal)",
    )
    ldv_heading_deg: float | None = Field(
        None,
        ge=-360.0,
        le=360.0,
        description="LDV mounting heading φ_L in degrees (−360° to 360°; default: calibrated or manifest nominal)",
    )
    ldv_scale: float | None = Field(
        None,
        ge=0.5,
        le=1.5,
        description="LDV scale factor K (dimensionless, 0.5 to 1.5; default: calibrated or manifest nominal)",
    )

    @property
    def mounting_given(self) -> bool:
        """Pitch, heading and scale are all given: nothing is left for a calibration to estimate."""
        return None not in (self.ldv_pitch_deg, self.ldv_heading_deg, self.ldv_scale)


class _CalibrationChoice(Params):
    """How the LDV is calibrated (declared before the mounting so forms and tables list it first)."""

    calibration: Literal["auto", "nominal"] = Field(
        "auto",
        description="auto: calibrate the LDV against GNSS in this log; nominal: use the manifest's "
        "nominal mounting; given values of ldv_* always win",
    )
    calibration_window: Floats | None = Field(
        None, description="t0,t1 in s (time of day, inside the log) for the automatic calibration"
    )

    @field_validator("calibration_window")
    @classmethod
    def _window(cls, v):
        return time_window(v)


class CalibrationParams(LdvMountingParams, _CalibrationChoice):
    """The parameters shared by every pipeline that navigates with a calibrated LDV: the calibration
    choice, the given mounting and scale (:class:`LdvMountingParams`) and the pitch compliance."""

    ldv_pitch_k_rad_per_mps2: float | None = Field(
        None,
        ge=-0.02,
        le=0.02,
        description="pitch compliance k_η: pitch of the travel direction the LDV "
        "sees per m/s² of forward acceleration (squat/dive), rad per m/s² (|k_η| ≤ 0.02, about 11° per g)",
    )

    @property
    def given_ldv(self) -> dict[str, float]:
        """The ``ldv_*`` values given (deg, dimensionless, rad per m/s²) by name, in declaration order:
        each wins over a calibration."""
        values = {
            "ldv_pitch_deg": self.ldv_pitch_deg,
            "ldv_heading_deg": self.ldv_heading_deg,
            "ldv_scale": self.ldv_scale,
            "ldv_pitch_k_rad_per_mps2": self.ldv_pitch_k_rad_per_mps2,
        }
        return {k: v for k, v in values.items() if v is not None}


def time_window(v):
    """A ``t0,t1`` window in s: two finite numbers, t1 > t0."""
    if v is not None and (len(v) != 2 or not v[1] > v[0]):
        raise ValueError("expected two times t0,t1 in s with t1 > t0")
    return v


def calibration_applicable(logs: list[LogFacts], params: CalibrationParams) -> list[Reason]:
    """The calibration window, when given, lies inside the log."""
    return window_inside(logs, params.calibration_window, "calibration_window")


@dataclass
class LdvSetup:
    """Tilt (rotating IMU), LDV mounting, compliance and scale as used, and where they came from."""

    cbs: np.ndarray | None
    tilt: TiltEstimate | None
    pitch_rad: float
    heading_rad: float
    scale: float
    scale_up: float
    info: dict
    warnings: list
    pitch_k_rad_per_mps2: float = 0.0
    accel_fwd_mps2: np.ndarray | None = None  #: at the IMU samples
    #: the LDV+GNSS navigation the calibration was estimated jointly with (see ``ldv_setup``), else None
    solution: object = None


def _calibration_info(cal: Calibration, joint: bool) -> dict:
    """The summary block of an automatic calibration: its window (s), fix qualities, 1-σ (deg,
    dimensionless, rad per m/s²) and their inflation."""
    info = {
        "source": "calibrate",
        "segment_t_s": list(cal.window_s),
        "fix_qualities": list(cal.fixes),
        "sigma": {
            "ldv_pitch_deg": cal.sigma["pitch"] / RAD_PER_DEG,
            "ldv_heading_deg": cal.sigma["heading"] / RAD_PER_DEG,
            "ldv_scale": cal.sigma["scale"],
            "ldv_pitch_k_rad_per_mps2": cal.sigma["pitch_k"],
        },
        "sigma_inflation": cal.sigma_inflation,
    }
    if joint:
        info["estimated_with_navigation"] = True
    return info


def ldv_setup(
    inp: NavInputs, params: CalibrationParams, progress: Progress, joint: bool = False, specific_force: bool = True
) -> LdvSetup:
    """Base tilt (if the IMU rotates), then the LDV calibration: given, automatic or nominal.

    Parameters
    ----------
    inp : NavInputs
        The loaded log.
    params : CalibrationParams
        ``calibration`` (auto, nominal), ``calibration_window`` (s) and the given ``ldv_*`` values,
        which always win.
    progress : Progress
        Stage reporter.
    joint : bool
        For a smoothed LDV+GNSS navigation: when the calibration is automatic over the whole log and
        no ldv_* value is given, estimate it together with that navigation, in one filter with the
        LDV states augmented, and hand the navigation back in ``LdvSetup.solution``; otherwise (a
        calibration window, a given value, nominal) the calibration, if any, runs alone as without.
    specific_force : bool
        Whether that joint navigation keeps the up specific force per sample.

    Returns
    -------
    LdvSetup
        C_b^s and the tilt (rotating IMU), the mounting (rad), compliance (rad per m/s²) and scales
        used, the summary block ``info`` (deg) and the warnings.
    """
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
    given = params.given_ldv
    info = {"source": "nominal"}
    pitch, heading, scale, scale_up = (
        m.ldv.nominal.pitch_deg * RAD_PER_DEG,
        m.ldv.nominal.heading_deg * RAD_PER_DEG,
        m.ldv.nominal.scale,
        1.0,
    )
    pitch_k = 0.0
    if params.calibration == "auto" and not params.mounting_given:
        if log.gnss is None:
            warnings.append("no GNSS: the LDV is used with its nominal mounting (no calibration)")
        else:
            window = params.calibration_window
            joint = joint and window is None and not given
            stage = "LDV calibration and navigation (ldv+gnss), one filter" if joint else "LDV calibration against GNSS"
            progress(stage, 0.15)
            cal = calibration_stage(inp, cbs, window, joint=joint, specific_force=specific_force)
            pitch, heading, scale, scale_up = cal.pitch_rad, cal.heading_rad, cal.scale, cal.scale_up
            pitch_k = cal.pitch_k_rad_per_mps2
            info = _calibration_info(cal, joint)
    if "ldv_pitch_deg" in given:
        pitch = given["ldv_pitch_deg"] * RAD_PER_DEG
    if "ldv_heading_deg" in given:
        heading = given["ldv_heading_deg"] * RAD_PER_DEG
    if "ldv_scale" in given:
        scale = given["ldv_scale"]
    if "ldv_pitch_k_rad_per_mps2" in given:
        pitch_k = given["ldv_pitch_k_rad_per_mps2"]
    if given:
        info["given"] = given
    info.update(
        {
            "ldv_pitch_deg": pitch / RAD_PER_DEG,
            "ldv_heading_deg": heading / RAD_PER_DEG,
            "ldv_scale": scale,
            "ldv_pitch_k_rad_per_mps2": pitch_k,
            "ldv_pitch_compliance_deg_per_g": pitch_k / RAD_PER_DEG * G0_MPS2,
        }
    )
    if inp.nu_u_mps is not None:
        info["ldv_scale_up"] = scale_up
    solution = cal.solution if info["source"] == "calibrate" else None
    return LdvSetup(
        cbs=cbs,
        tilt=est,
        pitch_rad=pitch,
        heading_rad=heading,
        scale=scale,
        scale_up=scale_up,
        info=info,
        warnings=warnings,
        pitch_k_rad_per_mps2=pitch_k,
        accel_fwd_mps2=accel_fwd(inp) if pitch_k else None,
        solution=solution,
    )


def ldv_aid_of(inp: NavInputs, setup: LdvSetup) -> LdvAid:
    """The filter's LDV aid at the IMU samples through the mounting, compliance and scales of ``setup``."""
    aid = ldv_aid(
        inp, scale=setup.scale, pitch_rad=setup.pitch_rad, heading_rad=setup.heading_rad, scale_up=setup.scale_up
    )
    if setup.pitch_k_rad_per_mps2:
        aid.accel_fwd_mps2 = setup.accel_fwd_mps2 if setup.accel_fwd_mps2 is not None else accel_fwd(inp)
        aid.pitch_k_rad_per_mps2 = setup.pitch_k_rad_per_mps2
    return aid
