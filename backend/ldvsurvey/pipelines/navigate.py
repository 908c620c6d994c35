"""``navigate``: alignment, the 15-state filter with 2-D (or 1-D) LDV aiding and/or GNSS, RTS smoother."""

from __future__ import annotations

from typing import Literal

import numpy as np
from pydantic import Field

from ldvsurvey.errors import ParameterError
from ldvsurvey.io.drivelog import DriveLog
from ldvsurvey.nav.attitude import euler_from_c_bn
from ldvsurvey.nav.earth import enu_offset_m
from ldvsurvey.nav.filter import NavSolution
from ldvsurvey.pipelines.base import (
    LogFacts,
    Pipeline,
    PipelineResult,
    Progress,
    Reason,
    needs_gnss,
    needs_ldv,
    output_rate,
    rate_within_imu,
    warn,
)
from ldvsurvey.pipelines.stages.aids import (
    NavInputs,
    attitude_at,
    c_bs_of,
    gnss_aid,
    nav_inputs,
    run_navigation_filter,
)
from ldvsurvey.pipelines.stages.ldv_mounting import (
    CalibrationParams,
    LdvSetup,
    calibration_applicable,
    ldv_aid_of,
    ldv_setup,
)
from ldvsurvey.pipelines.stages.plumb_line import DOV_HELP, DovChoice, DovParams, apply_dov
from ldvsurvey.pipelines.stages.turntable_tilt import tilt_stage
from ldvsurvey.units import DEG_PER_RAD, DPH_PER_RPS, UG_PER_MPS2


class NavigateParams(CalibrationParams, DovParams):
    """Parameters of ``navigate`` (deflection of the vertical off by default)."""

    aiding: Literal["auto", "ldv", "gnss", "ldv+gnss"] = Field(
        "auto", description="auto (ldv when the log has an LDV, else gnss), ldv, gnss or ldv+gnss"
    )
    smooth: bool = Field(True, description="run the RTS smoother after the forward filter")
    output_rate_hz: float = output_rate(10.0, "trajectory.csv")
    dov: DovChoice = Field("none", description=DOV_HELP)


def resolve_aiding(aiding: str, has_ldv: bool) -> str:
    """The aiding a navigation runs with: ``auto`` is ``ldv`` on a log with an LDV, else ``gnss``."""
    if aiding == "auto":
        return "ldv" if has_ldv else "gnss"
    return aiding


def applicable(logs: list[LogFacts], params: NavigateParams) -> list[Reason]:
    """LDV aiding needs an LDV, GNSS aiding GNSS (``auto``: whichever the log has); a calibration
    window must lie inside the log."""
    out = []
    for f in logs:
        aiding = resolve_aiding(params.aiding, f.has_ldv)
        if "ldv" in aiding:
            out += needs_ldv([f], f"aiding={aiding} includes the LDV", "aiding")
        if "gnss" in aiding:
            why = "aiding includes gnss" if params.aiding != "auto" else "a log without an LDV navigates with GNSS"
            out += needs_gnss([f], why, "aiding")
    ldv_runs = any("ldv" in resolve_aiding(params.aiding, f.has_ldv) for f in logs)
    return out + (calibration_applicable(logs, params) if ldv_runs else []) + rate_within_imu(logs, params)


def run_navigation(
    log: DriveLog,
    params: CalibrationParams,
    progress: Progress,
    *,
    aiding: str = "auto",
    smooth: bool = True,
    dov: DovParams | None = None,
    specific_force: bool = True,
) -> tuple[NavInputs, LdvSetup | None, NavSolution]:
    """The navigation of a log with the LDV set up as ``params`` say (shared with the gravity pipeline).

    Parameters
    ----------
    log : DriveLog
        The parsed bundle.
    params : CalibrationParams
        The LDV calibration: automatic, nominal or given values (a gravity or navigate model works too).
    progress : Progress
        Stage reporter.
    aiding : {"auto", "ldv", "gnss", "ldv+gnss"}
        What aids the filter (``auto``: ``ldv`` on a log with a usable LDV, else ``gnss``).
    smooth : bool
        Run the RTS smoother after the forward filter.
    dov : DovParams or None
        The deflection of the vertical in the mechanization's gravity; None (a pipeline without
        those parameters): normal gravity.
    specific_force : bool
        False: the solution carries no per-sample up specific force (only gravity reads it).

    Returns
    -------
    inp : NavInputs
        The loaded log; ``inp.cache["aiding"]`` the aiding used, ``inp.cache["dov"]`` the DOV summary
        block and its warnings.
    setup : LdvSetup or None
        The LDV set-up used (None without LDV aiding).
    sol : NavSolution
        The navigation solution.
    """
    inp = nav_inputs(log)
    aiding = resolve_aiding(aiding, inp.has_ldv)
    if "ldv" in aiding:
        inp.require_ldv()
    if log.ldv is not None and not inp.has_ldv:
        warn(f"the LDV has no usable sample ({inp.ldv_unusable.message}): navigated with {aiding} aiding")
    dov_info, dov_warn = ({"source": "none"}, []) if dov is None else apply_dov(inp, dov, progress)
    inp.cache["dov"] = (dov_info, dov_warn)
    use_ldv = "ldv" in aiding
    use_gnss = "gnss" in aiding
    if use_gnss and log.gnss is None:
        raise ParameterError("aiding includes gnss but the bundle has no gnss.nmea", field="aiding")
    # LDV and GNSS, smoothed: the automatic calibration and the navigation are one filter run
    setup = (
        ldv_setup(inp, params, progress, joint=use_gnss and smooth, specific_force=specific_force) if use_ldv else None
    )
    cbs = setup.cbs if setup else None
    if setup is None and inp.eta_rad is not None:
        est, _ = tilt_stage(inp)
        cbs = c_bs_of(inp, est.alpha_rad, est.beta_rad)
    inp.cache["aiding"] = aiding
    if setup is not None and setup.solution is not None:
        return inp, setup, setup.solution
    progress(f"navigation ({aiding})", 0.5)
    sol = run_navigation_filter(
        inp,
        cbs=cbs,
        ldv=ldv_aid_of(inp, setup) if use_ldv else None,
        gnss=gnss_aid(log) if use_gnss else None,
        smooth=smooth,
        specific_force=specific_force,
    )
    return inp, setup, sol


def errors_vs_gnss(log: DriveLog, sol: NavSolution, fixes=(4,)):
    """Horizontal and height errors of the solution at the GNSS fixes of the given qualities.

    Parameters
    ----------
    log : DriveLog
        The parsed bundle.
    sol : NavSolution
        The navigation.
    fixes : tuple of int
        The fix qualities compared with.

    Returns
    -------
    horizontal_m, height_m : ndarray or None
        Per fix, the horizontal distance (m) and the height difference (m, solution minus fix) of
        the IMU centre (the fixes brought there through the lever arm); None without such a fix.
    n : int
        The number of fixes compared.
    """
    g = log.gnss
    if g is None:
        return None, None, 0
    k = np.isin(g.fix, fixes) & np.isfinite(g.lat_deg) & (g.t_s >= sol.t_s[0]) & (g.t_s <= sol.t_s[-1])
    if not k.any():
        return None, None, 0
    c = attitude_at(sol, g.t_s[k])
    lev = c @ np.asarray(log.manifest.gnss.lever_arm_m, float)
    lat = np.interp(g.t_s[k], sol.t_s, sol.pos[:, 0])
    lon = np.interp(g.t_s[k], sol.t_s, sol.pos[:, 1])
    h = np.interp(g.t_s[k], sol.t_s, sol.pos[:, 2])
    d = enu_offset_m(np.radians(g.lat_deg[k]), np.radians(g.lon_deg[k]), g.h_m[k], lat, lon, h + lev[:, 2])
    d[:, 0] += lev[:, 0]
    d[:, 1] += lev[:, 1]
    return np.hypot(d[:, 0], d[:, 1]), d[:, 2], int(k.sum())


def _bias_convergence(inp: NavInputs, sol: NavSolution) -> dict:
    """The filter's gyro-bias 1-σ (°/h, per axis) at the end of the alignment (the end of the
    standstill, or the first epoch of a moving start) and at the end of the log (smoothed σ when
    the solution is smoothed)."""
    from ldvsurvey.nav.errmodel import IX_EPS

    sig = sol.epoch_sigma
    if sig is None or len(sig) == 0:
        return {}
    al = inp.alignment
    t_al = inp.static_end_s if al is None or al.standstill_s is None else al.standstill_s[1]
    k = int(np.clip(np.searchsorted(sol.epoch_t_s, t_al), 0, len(sig) - 1))
    return {
        "gyro_bias_sigma_end_of_alignment_dph": (sig[k, IX_EPS : IX_EPS + 3] * DPH_PER_RPS).tolist(),
        "gyro_bias_sigma_end_dph": (sig[-1, IX_EPS : IX_EPS + 3] * DPH_PER_RPS).tolist(),
    }


def run(logs: list[DriveLog], params: NavigateParams, progress: Progress) -> PipelineResult:
    """Navigate one log: alignment, the filter with the chosen aiding (and the LDV calibration it
    needs), the RTS smoother.

    Parameters
    ----------
    logs : list of DriveLog
        One parsed bundle.
    params : NavigateParams
        Aiding, smoothing, output rate (Hz), the LDV calibration and the deflection of the vertical.
    progress : Progress
        Stage reporter and cancellation.

    Returns
    -------
    PipelineResult
        ``trajectory.csv`` at ``output_rate_hz``: t_s, lat_deg, lon_deg, h_m, v_e/v_n/v_u_mps,
        pitch/roll/heading_deg and their 1-σ (deg, m/s, m). Summary: ``aiding``, ``smoothed``,
        ``max_horizontal_error_m``, ``max_height_error_m``, ``rms_horizontal_error_m`` against fix-4
        GNSS (IMU centre) and ``n_reference``, ``rejected_measurements``, ``gyro_bias_dph``,
        ``accel_bias_ug``, ``dov`` and, with the LDV, ``calibration``; the start's alignment
        (``alignment_method``, ``alignment_heading_sigma_deg``, ``standstill_s``,
        ``initial_gyro_bias_dph`` and its σ, see :class:`~ldvsurvey.pipelines.stages.start.Alignment`)
        and the filter's gyro-bias σ ``gyro_bias_sigma_end_of_alignment_dph`` and ``gyro_bias_sigma_end_dph``.
    """
    log = logs[0]
    progress("preparing", 0.02)
    inp, setup, sol = run_navigation(
        log, params, progress, aiding=params.aiding, smooth=params.smooth, dov=params, specific_force=False
    )
    progress("writing", 0.9)
    horiz, vert, n_ref = errors_vs_gnss(log, sol)
    step = max(1, int(round(1.0 / (params.output_rate_hz * np.median(np.diff(sol.t_s))))))
    sl = slice(step - 1, None, step)
    p, r, hd = euler_from_c_bn(sol.c_bn(sl))
    sg = sol.sigma_at(sl)
    table = {
        "t_s": sol.t_s[sl],
        "lat_deg": sol.pos[sl, 0] * DEG_PER_RAD,
        "lon_deg": sol.pos[sl, 1] * DEG_PER_RAD,
        "h_m": sol.pos[sl, 2],
        "v_e_mps": sol.v_n[sl, 0],
        "v_n_mps": sol.v_n[sl, 1],
        "v_u_mps": sol.v_n[sl, 2],
        "pitch_deg": p * DEG_PER_RAD,
        "roll_deg": r * DEG_PER_RAD,
        "heading_deg": hd * DEG_PER_RAD,
        "tilt_e_sigma_deg": sg[:, 0] * DEG_PER_RAD,
        "tilt_n_sigma_deg": sg[:, 1] * DEG_PER_RAD,
        "heading_sigma_deg": sg[:, 2] * DEG_PER_RAD,
        "v_e_sigma_mps": sg[:, 3],
        "v_n_sigma_mps": sg[:, 4],
        "v_u_sigma_mps": sg[:, 5],
        "e_sigma_m": sg[:, 6],
        "n_sigma_m": sg[:, 7],
        "h_sigma_m": sg[:, 8],
    }
    s = {
        "aiding": inp.cache["aiding"],
        "smoothed": bool(params.smooth),
        "max_horizontal_error_m": None if horiz is None else float(np.max(horiz)),
        "max_height_error_m": None if vert is None else float(vert[np.argmax(np.abs(vert))]),
        "rms_horizontal_error_m": None if horiz is None else float(np.sqrt(np.mean(horiz**2))),
        "n_reference": n_ref,
        "rejected_measurements": sol.rejected,
        "gyro_bias_dph": (sol.gyro_bias_rps * DPH_PER_RPS).tolist(),
        "accel_bias_ug": (sol.accel_bias_mps2 * UG_PER_MPS2).tolist(),
    }
    s.update(_bias_convergence(inp, sol))
    s["dov"], warnings = inp.cache["dov"]
    warnings = list(warnings)
    if setup is not None:
        s["calibration"] = setup.info
        warnings += setup.warnings
    if "gnss" in inp.cache["aiding"]:
        warnings.append("errors against GNSS are not independent when GNSS aids the solution")
    return PipelineResult(summary=s, tables={"trajectory": table}, warnings=warnings)


PIPELINE = Pipeline(
    "navigate", run, NavigateParams, "SINS/LDV (and/or GNSS) navigation with RTS smoothing", applicable=applicable
)
