"""``calibrate``: LDV mounting pitch η_L, heading φ_L and scale K against the GNSS track (methods §1)."""

from __future__ import annotations

from pydantic import Field, field_validator

from ldvsurvey.io.drivelog import DriveLog
from ldvsurvey.pipelines.base import (
    Floats,
    LogFacts,
    Pipeline,
    PipelineResult,
    Progress,
    Reason,
    needs_gnss,
    needs_ldv,
    window_inside,
)
from ldvsurvey.pipelines.stages.aids import c_bs_of, nav_inputs
from ldvsurvey.pipelines.stages.ldv_mounting import calibration_stage, time_window
from ldvsurvey.pipelines.stages.plumb_line import DovParams, apply_dov
from ldvsurvey.pipelines.stages.turntable_tilt import tilt_stage
from ldvsurvey.units import G0_MPS2, RAD_PER_DEG


class CalibrateParams(DovParams):
    """Parameters of ``calibrate``."""

    calibration_window: Floats | None = Field(
        None,
        description="t0,t1 in s (time of day, inside the log) of the stretch to use (default: the "
        "longest good-GNSS moving stretch)",
    )

    @field_validator("calibration_window")
    @classmethod
    def _window(cls, v):
        return time_window(v)


def applicable(logs: list[LogFacts], params: CalibrateParams) -> list[Reason]:
    """Calibration compares the LDV with GNSS: the log needs both, the window must be inside it."""
    return (
        needs_ldv(logs, "the calibration estimates the LDV mounting and scale")
        + needs_gnss(logs, "the calibration compares the LDV with GNSS")
        + window_inside(logs, params.calibration_window, "calibration_window")
    )


def run(logs: list[DriveLog], params: CalibrateParams, progress: Progress) -> PipelineResult:
    """Calibrate the LDV mounting (pitch η_L, heading φ_L, pitch compliance k_η) and scale K
    against the GNSS track, with the closed-form dead-reckoning estimate beside.

    Parameters
    ----------
    logs : list of DriveLog
        One parsed bundle with an LDV and GNSS.
    params : CalibrateParams
        The calibration window ``t0, t1`` (s; None: every good fix for the filter, the longest
        good-GNSS moving stretch for the closed form) and the deflection of the vertical.
    progress : Progress
        Stage reporter and cancellation.

    Returns
    -------
    PipelineResult
        ``calibration_track.csv``: the calibrated dead-reckoning track over the window (t_s,
        lat_deg, lon_deg, h_m at 10 Hz). Summary: ``ldv_pitch_deg``, ``ldv_heading_deg``,
        ``ldv_scale``, ``ldv_pitch_k_rad_per_mps2`` (each with ``_sigma``),
        ``ldv_pitch_compliance_deg_per_g``, ``fix_qualities``, ``segment_t_s``, ``closed_form``,
        ``sigma_inflation``, ``dov``, with a 2-D LDV ``ldv_scale_up``, with a rotating IMU
        ``alpha_rad``, ``beta_rad``.
    """
    log = logs[0]
    progress("preparing", 0.02)
    inp = nav_inputs(log)
    inp.require_ldv()
    dov_info, warnings = apply_dov(inp, params, progress)
    cbs = None
    extra = {}
    if inp.eta_rad is not None:
        progress("base tilt of the rotating IMU", 0.05)
        est, _ = tilt_stage(inp)
        cbs = c_bs_of(inp, est.alpha_rad, est.beta_rad)
        extra = {"alpha_rad": est.alpha_rad, "beta_rad": est.beta_rad}
    cal = calibration_stage(inp, cbs, params.calibration_window, progress)
    s = {
        "ldv_pitch_deg": cal.pitch_rad / RAD_PER_DEG,
        "ldv_pitch_deg_sigma": cal.sigma["pitch"] / RAD_PER_DEG,
        "ldv_heading_deg": cal.heading_rad / RAD_PER_DEG,
        "ldv_heading_deg_sigma": cal.sigma["heading"] / RAD_PER_DEG,
        "ldv_scale": cal.scale,
        "ldv_scale_sigma": cal.sigma["scale"],
        "ldv_pitch_k_rad_per_mps2": cal.pitch_k_rad_per_mps2,
        "ldv_pitch_k_rad_per_mps2_sigma": cal.sigma["pitch_k"],
        "ldv_pitch_compliance_deg_per_g": cal.pitch_k_rad_per_mps2 / RAD_PER_DEG * G0_MPS2,
        "fix_qualities": list(cal.fixes),
        "segment_t_s": list(cal.window_s),
        "method": "kalman filter with LDV states: travel direction (pitch, heading, pitch compliance "
        "per m/s² of forward acceleration) and scale; closed form beside",
        "closed_form": cal.closed_form,
        "dov": dov_info,
        **extra,
        "sigma_inflation": cal.sigma_inflation,
    }
    if inp.nu_u_mps is not None:
        s["ldv_scale_up"] = cal.scale_up
        s["ldv_scale_up_sigma"] = cal.sigma["scale_up"]
        if cal.sigma["scale_up"] is None:
            warnings.append(cal.closed_form["note"])
    if "note_compliance" in cal.closed_form:
        warnings.append(cal.closed_form["note_compliance"])
    return PipelineResult(summary=s, tables={"calibration_track": cal.track}, warnings=warnings)


PIPELINE = Pipeline(
    "calibrate", run, CalibrateParams, "LDV mounting angles and scale factor against GNSS", applicable=applicable
)
