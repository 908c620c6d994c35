"""``tilt``: base-tilt compensation of a single-axis rotation INS (methods §2)."""

from __future__ import annotations

import numpy as np

from ldvsurvey.errors import ParameterError
from ldvsurvey.nav.attitude import euler_from_c_bn
from ldvsurvey.nav.tilt import oscillation_per_cycle
from ldvsurvey.pipelines.base import Param, Pipeline, PipelineResult
from ldvsurvey.pipelines.prep import c_bs_of, ldv_aid, nav_inputs, navigate
from ldvsurvey.pipelines.stages import RAD, tilt_stage

PARAMS = [
    Param("output_rate_hz", "float", 10.0, "rate of attitude.csv"),
    Param("ldv_pitch_deg", "float", None, "LDV mounting pitch for the aiding (default: manifest nominal)"),
    Param("ldv_heading_deg", "float", None, "LDV mounting heading (default: manifest nominal)"),
    Param("ldv_scale", "float", None, "LDV scale factor (default: manifest nominal)"),
]


def compensated_attitude(inp, est, params, progress, frac=0.4):
    """Navigation with LDV aiding and the tilt applied; returns (solution, C_s^n, C_b^n, raw C_b^n)."""
    cbs = c_bs_of(inp, est.alpha_rad, est.beta_rad)
    progress("navigation with the tilt compensated", frac)
    aid = ldv_aid(inp, scale=params.get("ldv_scale"),
                  pitch_rad=None if params.get("ldv_pitch_deg") is None else params["ldv_pitch_deg"] * RAD,
                  heading_rad=None if params.get("ldv_heading_deg") is None else params["ldv_heading_deg"] * RAD)
    sol = navigate(inp, cbs=cbs, ldv=aid)
    c_bn = sol.c_bn()
    c_sn = c_bn @ np.swapaxes(cbs, -1, -2)
    raw = c_sn @ c_bs_of(inp, 0.0, 0.0)
    return sol, c_sn, c_bn, raw


def oscillation(inp, c_bn, raw):
    """Mean per-cycle peak-to-peak pitch and roll (rad), before and after compensation, over the
    static period (else every still interval); None when no full turntable cycle lies in one."""
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


def run(logs, params, progress) -> PipelineResult:
    log = logs[0]
    progress("preparing", 0.02)
    inp = nav_inputs(log)
    if inp.eta_rad is None:
        raise ParameterError("tilt compensation needs a rotating IMU: the manifest says imu.rotating is false "
                             "and imu.csv has no turntable_deg", file="imu.csv", field="turntable_deg")
    progress("fine alignment and turntable stops", 0.1)
    est, stops = tilt_stage(inp)
    warnings = list(inp.warnings) + list(est.warnings)
    sol, c_sn, c_bn, raw = compensated_attitude(inp, est, params, progress)
    osc = oscillation(inp, c_bn, raw)
    if osc is None:
        warnings.append("no full turntable cycle while the vehicle stood still: the attitude oscillation "
                        "before and after compensation is not reported")
    progress("writing", 0.9)
    step = max(1, int(round(1.0 / (params["output_rate_hz"] * np.median(np.diff(inp.t_s))))))
    sl = slice(step - 1, None, step)
    p0, r0, _ = euler_from_c_bn(raw[sl])
    p1, r1, h1 = euler_from_c_bn(c_bn[sl])
    table = {"t_s": inp.t_s[sl], "turntable_deg": np.mod(np.degrees(inp.eta_rad[sl]), 360.0),
             "pitch_raw_deg": np.degrees(p0), "roll_raw_deg": np.degrees(r0), "pitch_deg": np.degrees(p1),
             "roll_deg": np.degrees(r1), "heading_deg": np.degrees(h1)}
    s = {"alpha_rad": est.alpha_rad, "alpha_rad_sigma": est.alpha_sigma_rad, "beta_rad": est.beta_rad,
         "beta_rad_sigma": est.beta_sigma_rad, "tilt_observable": est.observable, "n_pairs": len(est.pairs),
         "n_still_intervals": est.n_intervals, "turntable_diversity": est.diversity,
         "rms_residual_rad": est.rms_residual_rad,
         "method": "least squares of the up direction over the turntable angle in still intervals",
         "aiding": "ldv"}
    for key, i in (("pitch", 0), ("roll", 1)):
        s[f"{key}_oscillation_before_rad"] = osc["before"][i] if osc else None
        s[f"{key}_oscillation_after_rad"] = osc["after"][i] if osc else None
    s["n_cycles"] = osc["after"][2] if osc else 0
    return PipelineResult(summary=s, tables={"attitude": table}, warnings=warnings)


PIPELINE = Pipeline("tilt", run, PARAMS, "Base-tilt compensation of a single-axis rotation INS")
