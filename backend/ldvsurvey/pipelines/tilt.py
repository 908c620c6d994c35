"""``tilt``: base-tilt compensation of a single-axis rotation INS (methods §2)."""

from __future__ import annotations

import numpy as np

from ldvsurvey.errors import ParameterError
from ldvsurvey.io.drivelog import DriveLog
from ldvsurvey.nav.attitude import euler_from_c_bn
from ldvsurvey.nav.filter import NavSolution
from ldvsurvey.nav.turntable import TiltEstimate, oscillation_per_cycle
from ldvsurvey.pipelines.base import (
    LogFacts,
    Pipeline,
    PipelineResult,
    Progress,
    Reason,
    output_rate,
    rate_within_imu,
)
from ldvsurvey.pipelines.stages.aids import NavInputs, c_bs_of, gnss_aid, ldv_aid, nav_inputs, run_navigation_filter
from ldvsurvey.pipelines.stages.ldv_mounting import LdvMountingParams
from ldvsurvey.pipelines.stages.turntable_tilt import tilt_stage
from ldvsurvey.units import RAD_PER_DEG


class TiltParams(LdvMountingParams):
    """Parameters of ``tilt``: the LDV mounting for the aiding (none given: the manifest's nominal)."""

    output_rate_hz: float = output_rate(10.0, "attitude.csv")


def applicable(logs: list[LogFacts], params: TiltParams) -> list[Reason]:
    """Base tilt is estimated from the turntable's rotation: only a rotating IMU has one."""
    return [
        Reason(
            "imu.rotating",
            f"tilt compensation is for a rotating IMU: log '{f.name}' has a fixed IMU (manifest imu.rotating is false)",
        )
        for f in logs
        if not f.imu_rotating
    ] + rate_within_imu(logs, params)


def compensated_attitude(
    inp: NavInputs, est: TiltEstimate, params: TiltParams, progress: Progress, frac: float = 0.4
) -> tuple[NavSolution, np.ndarray, np.ndarray, np.ndarray]:
    """Navigation with LDV aiding (a log without an LDV: GNSS aiding, if any) and the tilt applied.

    Parameters
    ----------
    inp : NavInputs
        The loaded log of a rotating IMU.
    est : TiltEstimate
        The base tilt α, β (rad).
    params : TiltParams
        The LDV mounting (deg) and scale for the aiding (None: the manifest's nominal).
    progress : Progress
        Stage reporter; ``frac`` the fraction reported.

    Returns
    -------
    sol : NavSolution
        The navigation.
    c_sn, c_bn, raw : ndarray
        (N, 3, 3) C_s^n, C_b^n with the tilt compensated, and C_b^n with α = β = 0.
    """
    cbs = c_bs_of(inp, est.alpha_rad, est.beta_rad)
    progress("navigation with the tilt compensated", frac)
    if not inp.has_ldv:
        sol = run_navigation_filter(inp, cbs=cbs, gnss=gnss_aid(inp.log))
    else:
        aid = ldv_aid(
            inp,
            scale=params.ldv_scale,
            pitch_rad=None if params.ldv_pitch_deg is None else params.ldv_pitch_deg * RAD_PER_DEG,
            heading_rad=None if params.ldv_heading_deg is None else params.ldv_heading_deg * RAD_PER_DEG,
        )
        sol = run_navigation_filter(inp, cbs=cbs, ldv=aid)
    c_bn = sol.c_bn()
    c_sn = c_bn @ np.swapaxes(cbs, -1, -2)
    raw = c_sn @ c_bs_of(inp, 0.0, 0.0)
    return sol, c_sn, c_bn, raw


def oscillation(inp: NavInputs, c_bn: np.ndarray, raw: np.ndarray) -> dict | None:
    """Mean per-cycle peak-to-peak pitch and roll (rad), before (``raw`` C_b^n) and after (``c_bn``)
    compensation, over the static period (else every still interval), as ``{"before": (pitch, roll,
    cycles), "after": ...}``; None when no full turntable cycle lies in one."""
    for still in ([(inp.t_s[0] - 1.0, inp.static_end_s)], inp.still):
        out = {}
        for name, c in (("before", raw), ("after", c_bn)):
            p, r, _ = euler_from_c_bn(c)
            pp = oscillation_per_cycle(inp.t_s, p, inp.eta_rad, still)
            rr = oscillation_per_cycle(inp.t_s, r, inp.eta_rad, still)
            if pp:
                out[name] = (float(np.mean(pp)), float(np.mean(rr)), len(pp))
        if len(out) == 2:
            return out
    return None


def run(logs: list[DriveLog], params: TiltParams, progress: Progress) -> PipelineResult:
    """Estimate the base tilt of a rotating IMU's turntable axis and navigate with it compensated.

    Parameters
    ----------
    logs : list of DriveLog
        One parsed bundle of a rotating IMU.
    params : TiltParams
        Output rate (Hz) and the LDV mounting (deg) and scale for the aiding.
    progress : Progress
        Stage reporter and cancellation.

    Returns
    -------
    PipelineResult
        ``attitude.csv`` at ``output_rate_hz``: t_s, turntable_deg, pitch/roll_raw_deg (α = β = 0),
        pitch/roll/heading_deg (compensated). Summary: ``alpha_rad``, ``beta_rad`` and their
        ``_sigma``, ``tilt_observable``, ``n_pairs``, ``n_still_intervals``, ``turntable_diversity``,
        ``rms_residual_rad``, ``pitch/roll_oscillation_before/after_rad``, ``n_cycles``, ``aiding``.
    """
    log = logs[0]
    progress("preparing", 0.02)
    inp = nav_inputs(log)  # a fixed IMU: refused by applicable and by tilt_stage
    progress("fine alignment and turntable stops", 0.1)
    est, stops = tilt_stage(inp)
    if not est.observable:  # the other pipelines go on with α = β = 0; this one has nothing to report
        raise ParameterError(
            "no rotation of the turntable while the vehicle stood still: " + est.warnings[0],
            file="imu.csv",
            field="turntable_deg",
        )
    warnings = list(inp.warnings) + list(est.warnings)
    sol, c_sn, c_bn, raw = compensated_attitude(inp, est, params, progress)
    osc = oscillation(inp, c_bn, raw)
    if osc is None:
        warnings.append(
            "no full turntable cycle while the vehicle stood still: the attitude oscillation "
            "before and after compensation is not reported"
        )
    progress("writing", 0.9)
    step = max(1, int(round(1.0 / (params.output_rate_hz * np.median(np.diff(inp.t_s))))))
    sl = slice(step - 1, None, step)
    p0, r0, _ = euler_from_c_bn(raw[sl])
    p1, r1, h1 = euler_from_c_bn(c_bn[sl])
    table = {
        "t_s": inp.t_s[sl],
        "turntable_deg": np.mod(np.degrees(inp.eta_rad[sl]), 360.0),
        "pitch_raw_deg": np.degrees(p0),
        "roll_raw_deg": np.degrees(r0),
        "pitch_deg": np.degrees(p1),
        "roll_deg": np.degrees(r1),
        "heading_deg": np.degrees(h1),
    }
    s = {
        "alpha_rad": est.alpha_rad,
        "alpha_rad_sigma": est.alpha_sigma_rad,
        "beta_rad": est.beta_rad,
        "beta_rad_sigma": est.beta_sigma_rad,
        "tilt_observable": est.observable,
        "n_pairs": len(est.pairs),
        "n_still_intervals": est.n_intervals,
        "turntable_diversity": est.diversity,
        "rms_residual_rad": est.rms_residual_rad,
        "method": "least squares of the up direction over the turntable angle in still intervals",
        "aiding": "ldv" if inp.has_ldv else ("gnss" if log.gnss is not None else "none (ZUPT only)"),
    }
    for key, i in (("pitch", 0), ("roll", 1)):
        s[f"{key}_oscillation_before_rad"] = osc["before"][i] if osc else None
        s[f"{key}_oscillation_after_rad"] = osc["after"][i] if osc else None
    s["n_cycles"] = osc["after"][2] if osc else 0
    return PipelineResult(summary=s, tables={"attitude": table}, warnings=warnings)


PIPELINE = Pipeline(
    "tilt", run, TiltParams, "Base-tilt compensation of a single-axis rotation INS", applicable=applicable
)
