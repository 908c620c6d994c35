"""``height``: 1-D LDV height through the calibrated mounting and the tilt-compensated attitude (methods §3).

V_U = third row of C_b^n times V^b, V^b = C_d^b(η_L, φ_L) [0, v_fwd/K, (v_up/K_u)]; h(t) = h(t0) + ∫ V_U dt
(trapezoid at the LDV rate), with the LDV lever arm's vertical change removed so h refers to the IMU centre.
``h_uncompensated_m`` is the same chain run with α = β = 0 (what one gets without tilt compensation).
Judged against GNSS ellipsoidal height at fix 4 or 2, brought from the antenna to the IMU centre.
"""

from __future__ import annotations

import numpy as np
from pydantic import Field

from ldvsurvey.io.drivelog import DriveLog
from ldvsurvey.nav.filter import LdvAid, forward_accel_mps2
from ldvsurvey.pipelines.base import (
    LogFacts,
    Pipeline,
    PipelineResult,
    Progress,
    Reason,
    needs_ldv,
    output_rate,
    rate_within_imu,
)
from ldvsurvey.pipelines.stages.aids import (
    NavInputs,
    antenna_to_imu_h,
    attitude_at,
    c_bs_of,
    nav_inputs,
    run_navigation_filter,
    usable_ldv,
)
from ldvsurvey.pipelines.stages.ldv_mounting import (
    CalibrationParams,
    LdvSetup,
    aid_body_velocity,
    calibration_applicable,
    ldv_aid_of,
    ldv_setup,
)
from ldvsurvey.pipelines.stages.plumb_line import DovParams, apply_dov


class HeightParams(CalibrationParams, DovParams):
    """Parameters of ``height``."""

    initial_h_m: float | None = Field(
        None,
        ge=-1000.0,
        le=9000.0,
        description="height in m of the IMU centre at the start (−1000 to 9000 m; default: manifest, else GNSS)",
    )
    output_rate_hz: float = output_rate(100.0, "height.csv")


def applicable(logs: list[LogFacts], params: HeightParams) -> list[Reason]:
    """The height is the LDV's: a log without one is refused; a calibration window must lie inside
    the log; the output rate is at most the IMU rate."""
    return (
        needs_ldv(logs, "the height integrates the LDV velocity")
        + calibration_applicable(logs, params)
        + rate_within_imu(logs, params)
    )


def integrate_height(
    t_s: np.ndarray, c_bn: np.ndarray, ldv: LdvAid, h0_m: float, v_u_bridge_mps: np.ndarray | None = None
) -> np.ndarray:
    """Height of the IMU centre at the LDV times by trapezoidal integration of V_U.

    Parameters
    ----------
    t_s : ndarray
        (N,) LDV sample times (s).
    c_bn : ndarray
        (N, 3, 3) C_b^n at those times.
    ldv : LdvAid
        The LDV samples at those times (``ok`` usable, ``nu_f_mps``, ``nu_u_mps``) with the mounting
        (rad), compliance (rad per m/s², ``accel_fwd_mps2`` at those times: the vehicle's squat and
        dive pitch the travel direction the LDV sees), scales and lever arm (m, body RFU) to use.
    h0_m : float
        Height (m) of the IMU centre at the first sample.
    v_u_bridge_mps : ndarray or None
        (N,) vertical velocity (m/s) of the LDV-aided INS bridging unusable LDV samples (below
        min_quality or spikes); None: bridged linearly.

    Returns
    -------
    ndarray
        (N,) height (m) of the IMU centre, the lever arm's vertical change removed.
    """
    v_b = aid_body_velocity(ldv)
    v_u = np.einsum("kj,kj->k", c_bn[:, 2, :], v_b)
    ok = ldv.ok
    if v_u_bridge_mps is not None:
        v_u = np.where(ok, v_u, v_u_bridge_mps)
    else:
        v_u = np.interp(t_s, t_s[ok], v_u[ok])  # bridge samples below min_quality
    h = h0_m + np.concatenate([[0.0], np.cumsum(0.5 * (v_u[1:] + v_u[:-1]) * np.diff(t_s))])
    lev_u = c_bn[:, 2, :] @ np.asarray(ldv.lever_arm_m, float)
    return h + lev_u[0] - lev_u


def error_stats(err: np.ndarray) -> dict:
    """Largest (signed), standard deviation and RMS of errors (their unit); None each for no error."""
    if len(err) == 0:
        return {"max": None, "std": None, "rms": None}
    i = int(np.argmax(np.abs(err)))
    return {"max": float(err[i]), "std": float(np.std(err)), "rms": float(np.sqrt(np.mean(err**2)))}


def _ldv_samples(log: DriveLog, inp: NavInputs, setup: LdvSetup) -> tuple[LdvAid, np.ndarray]:
    """The LDV's own samples inside the IMU span, screened as the filter's input is (min_quality,
    spikes), with the mounting, compliance and scales of ``setup``, and their times (s)."""
    m = log.manifest
    ldv = log.ldv
    t_l = ldv.t_s
    ok = usable_ldv(log)  # the same screen as the filter's input
    inside = (t_l >= inp.t_s[0]) & (t_l <= inp.t_s[-1])
    t_l, ok = t_l[inside], ok[inside]
    nu_f = ldv.v_fwd_mps[inside]
    pk = setup.pitch_k_rad_per_mps2
    return LdvAid(
        ok,
        nu_f,
        ldv.v_up_mps[inside] if ldv.v_up_mps is not None else None,
        scale=setup.scale,
        pitch_rad=setup.pitch_rad,
        heading_rad=setup.heading_rad,
        scale_up=setup.scale_up,
        lever_arm_m=tuple(m.ldv.lever_arm_m),
        accel_fwd_mps2=forward_accel_mps2(t_l, nu_f / setup.scale, ok) if pk else None,
        pitch_k_rad_per_mps2=pk,
    ), t_l


def _judge_against_gnss(log: DriveLog, sol, t_l: np.ndarray, h: np.ndarray, h_raw: np.ndarray):
    """The heights against GNSS fix 4 or 2 at the IMU centre: the summary's error keys (m), and the
    ``h_gnss_m`` and ``fix_quality`` columns at the LDV sample nearest each fix."""
    m = log.manifest
    g = log.gnss
    h_gnss_col = np.full(len(t_l), np.nan)
    fix_col = np.zeros(len(t_l))
    ref = np.isin(g.fix, (4, 2)) & np.isfinite(g.h_m) & (g.t_s >= t_l[0]) & (g.t_s <= t_l[-1])
    h_ref = antenna_to_imu_h(log, attitude_at(sol, g.t_s))
    err = np.interp(g.t_s[ref], t_l, h) - h_ref[ref]
    err_raw = np.interp(g.t_s[ref], t_l, h_raw) - h_ref[ref]
    st, st_raw = error_stats(err), error_stats(err_raw)
    st4 = error_stats(err[g.fix[ref] == 4])
    summary = {
        "max_error_m": st["max"],
        "std_error_m": st["std"],
        "rms_error_m": st["rms"],
        "n_reference": int(ref.sum()),
        "max_error_m_uncompensated": st_raw["max"],
        "max_error_m_fix4": st4["max"],
        "std_error_m_fix4": st4["std"],
        "n_reference_fix4": int(np.count_nonzero(g.fix[ref] == 4)),
        "std_error_m_uncompensated": st_raw["std"],
        "rms_error_m_uncompensated": st_raw["rms"],
    }
    j = np.clip(np.searchsorted(t_l, g.t_s), 0, len(t_l) - 1)
    j0 = np.clip(j - 1, 0, len(t_l) - 1)
    j = np.where(np.abs(t_l[j0] - g.t_s) < np.abs(t_l[j] - g.t_s), j0, j)
    near = np.abs(t_l[j] - g.t_s) <= 0.5 / m.ldv.rate_hz + 1e-9
    h_gnss_col[j[near & ref]] = h_ref[near & ref]
    fix_col[j[near]] = g.fix[near]
    return summary, h_gnss_col, fix_col


#: the summary's error keys of a log without GNSS
NO_REFERENCE = {
    "max_error_m": None,
    "std_error_m": None,
    "rms_error_m": None,
    "n_reference": 0,
    "max_error_m_uncompensated": None,
    "std_error_m_uncompensated": None,
    "rms_error_m_uncompensated": None,
}


def run(logs: list[DriveLog], params: HeightParams, progress: Progress) -> PipelineResult:
    """The height of the IMU centre from the 1-D (or 2-D) LDV through the calibrated mounting and
    the tilt-compensated attitude, with the same chain without the tilt compensation beside.

    Parameters
    ----------
    logs : list of DriveLog
        One parsed bundle with an LDV.
    params : HeightParams
        The start height (m; None: manifest, else GNSS), output rate (Hz), the LDV calibration and
        the deflection of the vertical.
    progress : Progress
        Stage reporter and cancellation.

    Returns
    -------
    PipelineResult
        ``height.csv`` at the LDV times thinned to ``output_rate_hz`` (every GNSS reference row
        kept): t_s, h_m, h_uncompensated_m, h_gnss_m (fix 4 or 2 at the IMU centre), fix_quality.
        Summary: ``calibration``, ``aiding``, ``tilt_compensated``, ``dov``, the tilt
        (``alpha_rad``, ``beta_rad``) and the errors against GNSS (``max/std/rms_error_m``, fix-4
        and uncompensated variants, ``n_reference``).
    """
    log = logs[0]
    progress("preparing", 0.02)
    inp = nav_inputs(log)
    inp.require_ldv()
    dov_info, warnings = apply_dov(inp, params, progress)
    setup = ldv_setup(inp, params, progress)
    warnings += setup.warnings
    est = setup.tilt
    progress("navigation (INS/LDV, no GNSS)", 0.5)
    aid = ldv_aid_of(inp, setup)
    sol = run_navigation_filter(inp, cbs=setup.cbs, ldv=aid)
    sol_raw = sol
    if est is not None:  # the same chain without the tilt compensation (α = β = 0)
        progress("navigation without the tilt compensation", 0.7)
        sol_raw = run_navigation_filter(inp, cbs=c_bs_of(inp, 0.0, 0.0), ldv=aid)
    progress("height integration", 0.85)
    ldv_l, t_l = _ldv_samples(log, inp, setup)
    h0 = params.initial_h_m if params.initial_h_m is not None else float(inp.pos0[2])
    c_l = attitude_at(sol, t_l)
    # LDV gaps are bridged by the INS's vertical velocity (smoothed, LDV-aided) at the IMU centre
    h = integrate_height(t_l, c_l, ldv_l, h0, np.interp(t_l, sol.t_s, sol.v_n[:, 2]))
    c_l_raw = attitude_at(sol_raw, t_l) if est is not None else c_l
    h_raw = integrate_height(t_l, c_l_raw, ldv_l, h0, np.interp(t_l, sol_raw.t_s, sol_raw.v_n[:, 2]))
    summary = {"calibration": setup.info, "aiding": "ldv", "tilt_compensated": est is not None, "dov": dov_info}
    if est is not None:
        summary.update({"alpha_rad": est.alpha_rad, "beta_rad": est.beta_rad})
    if log.gnss is not None:  # GNSS reference (fix 4 or 2) at the IMU centre
        errors, h_gnss_col, fix_col = _judge_against_gnss(log, sol, t_l, h, h_raw)
    else:
        warnings.append("no GNSS in the bundle: no reference to judge the height against")
        errors, h_gnss_col, fix_col = NO_REFERENCE, np.full(len(t_l), np.nan), np.zeros(len(t_l))
    summary.update(errors)
    step = max(1, int(round(1.0 / (params.output_rate_hz * np.median(np.diff(t_l))))))
    keep = np.zeros(len(t_l), bool)
    keep[::step] = True
    keep |= np.isfinite(h_gnss_col)  # every reference row stays
    table = {
        "t_s": t_l[keep],
        "h_m": h[keep],
        "h_uncompensated_m": h_raw[keep],
        "h_gnss_m": h_gnss_col[keep],
        "fix_quality": fix_col[keep].astype(int),
    }
    return PipelineResult(summary=summary, tables={"height": table}, warnings=warnings)


PIPELINE = Pipeline(
    "height",
    run,
    HeightParams,
    "Height from the 1-D LDV and the (tilt-compensated) INS attitude",
    applicable=applicable,
)
