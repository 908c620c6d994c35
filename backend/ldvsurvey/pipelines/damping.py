"""``damping``: undamped, conventional and delayed-state water-velocity damping (methods §6)."""

from __future__ import annotations

import numpy as np
from pydantic import Field

from ldvsurvey.errors import ParameterError
from ldvsurvey.io.drivelog import DriveLog
from ldvsurvey.nav.attitude import q_from_c
from ldvsurvey.nav.damping import MODES, Damping, WaterLdv, run_damping
from ldvsurvey.nav.earth import enu_offset_m
from ldvsurvey.nav.kfloop import ImuIn, Start
from ldvsurvey.pipelines.base import (
    LogFacts,
    Params,
    Pipeline,
    PipelineResult,
    Progress,
    Reason,
    needs_gnss,
    needs_ldv,
    output_rate,
    rate_within_imu,
)
from ldvsurvey.pipelines.stages.aids import NavInputs, c_bs_of, initial_attitude, nav_inputs
from ldvsurvey.pipelines.stages.turntable_tilt import tilt_stage
from ldvsurvey.units import RAD_PER_DEG


class DampingParams(Params):
    """Parameters of ``damping``."""

    period_s: float = Field(
        1.0, gt=0.0, le=60.0, description="covariance and conventional update period of the filters in s (0 to 60 s)"
    )
    delayed_baseline_s: float = Field(
        60.0,
        gt=0.0,
        le=3600.0,
        description="time in s between the two residuals the delayed-state measurement differences (0 to 3600 s)",
    )
    ldv_sigma_mps: float = Field(0.05, gt=0.0, le=10.0, description="1-σ of one water-LDV sample in m/s")
    delayed_gate_sigma: float = Field(
        5.0, gt=0.0, le=100.0, description="gate on the delayed-state velocity change (a current change), in σ"
    )
    output_rate_hz: float = output_rate(1.0, "damping.csv")


def applicable(logs: list[LogFacts], params: DampingParams) -> list[Reason]:
    """Damping is for a vessel with a water-track LDV, moored at the start, with a GNSS reference."""
    out = []
    for f in logs:
        if f.platform != "vessel":
            out.append(Reason("platform", f"damping is for vessels: log '{f.name}' is a {f.platform}"))
        if not f.has_ldv:
            out += needs_ldv([f], "damping needs a water-track LDV", "ldv.kind")
        elif f.ldv_kind != "water":
            out.append(
                Reason("ldv.kind", f"damping needs a water-track LDV: log '{f.name}' has ldv.kind '{f.ldv_kind}'")
            )
        if f.platform == "vessel" and not f.static_s:
            out.append(
                Reason("initial.static_s", f"log '{f.name}' has no manifest initial.static_s (the moored period)")
            )
    return out + needs_gnss(logs, "the damping comparison needs a GNSS reference") + rate_within_imu(logs, params)


def _reference(log: DriveLog, t_s: np.ndarray) -> tuple:
    """Reference positions (IMU centre, rad/m) and velocities (m/s) from GNSS at fix 4/2/5."""
    g = log.gnss
    if g is None:
        raise ParameterError("the damping comparison needs a GNSS reference (no gnss.nmea)", file="gnss.nmea")
    k = np.isin(g.fix, (4, 5, 2)) & np.isfinite(g.lat_deg)
    if k.sum() < 60:
        raise ParameterError(
            "fewer than 60 GNSS fixes of quality 4, 5 or 2 for the reference", file="gnss.nmea", field="fix_quality"
        )
    tg = g.t_s[k]
    lat, lon, h = np.radians(g.lat_deg[k]), np.radians(g.lon_deg[k]), g.h_m[k]
    v = np.gradient(np.column_stack([lat, lon]), tg, axis=0)
    from ldvsurvey.nav.earth import radii

    rm, rn = radii(lat)
    v_n = np.column_stack([v[:, 1] * (rn + h) * np.cos(lat), v[:, 0] * (rm + h)])
    return tg, lat, lon, h, v_n


def _check_vessel(m) -> None:
    """A vessel with a water-track LDV and a moored period at the start, else a ParameterError."""
    if m.platform != "vessel":
        raise ParameterError(
            f"damping is for vessels: the manifest says platform '{m.platform}'", file="manifest.json", field="platform"
        )
    if m.ldv.kind != "water":
        raise ParameterError(
            f"damping needs a water-track LDV: the manifest says ldv.kind '{m.ldv.kind}'",
            file="manifest.json",
            field="ldv.kind",
        )
    if not m.initial.static_s:  # absent, or 0 (a log that starts under way)
        raise ParameterError(
            "a vessel log needs manifest initial.static_s (the moored period): the water LDV "
            "cannot tell when the vessel stands still",
            file="manifest.json",
            field="initial.static_s",
        )


def _filter_inputs(inp: NavInputs, cbs, params: DampingParams) -> tuple[ImuIn, Start, WaterLdv, Damping]:
    """The compiled filters' inputs: the IMU (normal gravity), the start state (C_s^n of the
    coarse alignment, at rest at the start position), the water LDV through the nominal mounting
    and the damping set-up (its ``mode`` set per run)."""
    q0 = q_from_c(initial_attitude(inp, cbs))  # C_s^n at the start
    cbs_arr = np.ascontiguousarray(np.eye(3)[None] if cbs is None else cbs)
    noise = inp.noise
    p0 = (
        np.concatenate(
            [
                np.array([0.05, 0.05, 2.0]) * RAD_PER_DEG,
                np.full(3, 0.05),
                np.full(3, 1.0),
                np.full(3, max(noise.gyro_bias_rps, 1e-9)),
                np.full(3, max(noise.accel_bias_mps2, 1e-5)),
                [0.01],
            ]
        )
        ** 2
    )
    qd = np.concatenate([np.full(3, noise.arw_psd), np.full(3, noise.vrw_psd), np.zeros(9), [1e-12]])
    nom = inp.log.manifest.ldv.nominal
    empty = np.empty(0)
    imu = ImuIn(inp.t_s, inp.dtheta_rad, inp.dvel_mps, cbs_arr, empty, empty, empty)  # normal gravity
    start = Start(q0, np.zeros(3), inp.pos0, np.zeros(6))
    water = WaterLdv(
        inp.ldv_ok,
        inp.nu_f_mps,
        1.0 / nom.scale,
        nom.pitch_deg * RAD_PER_DEG,
        nom.heading_deg * RAD_PER_DEG,
        float(params.ldv_sigma_mps),
    )
    dmp = Damping(
        mode=0,
        period_s=float(params.period_s),
        ds_every=max(1, int(round(params.delayed_baseline_s / params.period_s))),
        gate=float(params.delayed_gate_sigma),
        zupt_end_s=float(inp.static_end_s),
        p0=p0,
        qd=qd,
        h_ref=float(inp.pos0[2]),  # the vessel stays on the water surface
        vu_sigma=0.05,
        h_sigma=0.5,
    )
    return imu, start, water, dmp


def _errors_vs_gnss(inp: NavInputs, cbs, ref: tuple, q, v, p) -> dict:
    """The navigation's errors against GNSS (antenna brought to the IMU centre) at the fixes after
    the moored period: times (s), north/east position (m) and velocity (m/s) errors."""
    from ldvsurvey.nav.attitude import c_from_q

    tg, glat, glon, gh, gv = ref
    lever = np.asarray(inp.log.manifest.gnss.lever_arm_m, float)
    use = tg > inp.static_end_s
    j = np.clip(np.searchsorted(inp.t_s, tg[use]), 0, len(inp.t_s) - 1)  # sample at (or after) each fix
    c_fix = c_from_q(q[j]) if cbs is None else c_from_q(q[j]) @ cbs[j]  # C_b^n
    lev = c_fix @ lever
    lat = np.interp(tg[use], inp.t_s, p[:, 0])
    lon = np.interp(tg[use], inp.t_s, p[:, 1])
    d = enu_offset_m(glat[use], glon[use], gh[use], lat, lon, gh[use])
    d[:, 0] += lev[:, 0]
    d[:, 1] += lev[:, 1]
    dv = np.column_stack([np.interp(tg[use], inp.t_s, v[:, j]) for j in range(2)]) - gv[use]
    return {"t": tg[use], "dn": d[:, 1], "de": d[:, 0], "dvn": dv[:, 1], "dve": dv[:, 0]}


def _summary(results: dict) -> dict:
    """Per mode the largest and RMS position (m) and velocity (m/s) errors, the delayed-state filter's
    improvement over the conventional one (%), the LDV scale estimates and the skipped measurements."""
    summary = {}
    for name, r in results.items():
        pe = np.hypot(r["dn"], r["de"])
        ve = np.hypot(r["dvn"], r["dve"])
        summary[name] = {
            "max_position_error_m": float(pe.max()),
            "rms_position_error_m": float(np.sqrt(np.mean(pe**2))),
            "rms_velocity_error_mps": float(np.sqrt(np.mean(ve**2))),
            "max_velocity_error_mps": float(ve.max()),
        }
    c, d = summary["conventional"], summary["delayed_state"]
    summary["position_improvement_pct"] = 100 * (1 - d["rms_position_error_m"] / c["rms_position_error_m"])
    summary["velocity_improvement_pct"] = 100 * (1 - d["rms_velocity_error_mps"] / c["rms_velocity_error_mps"])
    summary["reference"] = "GNSS fixes of quality 4, 5, 2 (antenna brought to the IMU centre)"
    summary["ldv_scale_estimate"] = {k: r["scale"] for k, r in results.items() if k != "undamped"}
    summary["delayed_state_skipped"] = results["delayed_state"]["rejected"]
    return summary


def _table(results: dict, output_rate_hz: float) -> dict:
    """The ``damping.csv`` columns: every ``1/output_rate_hz``-th fix, each mode's north and east
    position (m) and velocity (m/s) errors."""
    step = max(1, int(round(1.0 / output_rate_hz)))
    cols = {"t_s": results["undamped"]["t"][::step]}
    for name, r in results.items():
        for key, col in (
            ("dn", "north_error_m"),
            ("de", "east_error_m"),
            ("dvn", "north_velocity_error_mps"),
            ("dve", "east_velocity_error_mps"),
        ):
            cols[f"{name}_{col}"] = r[key][::step]
    return cols


def run(logs: list[DriveLog], params: DampingParams, progress: Progress) -> PipelineResult:
    """Navigate a vessel three ways (undamped, conventional and delayed-state water-velocity
    damping) and compare each with GNSS.

    Parameters
    ----------
    logs : list of DriveLog
        One parsed vessel bundle with a water-track LDV, a moored period (manifest
        ``initial.static_s``) and GNSS.
    params : DampingParams
        The filters' update period (s), the delayed-state baseline (s), the water LDV's 1-σ (m/s),
        the delayed-state gate (σ) and the output rate (Hz, of the GNSS fixes).
    progress : Progress
        Stage reporter and cancellation.

    Returns
    -------
    PipelineResult
        ``damping.csv``: t_s and per mode ``<mode>_north/east_error_m``,
        ``<mode>_north/east_velocity_error_mps``. Summary: per mode ``max/rms_position_error_m``,
        ``rms/max_velocity_error_mps``; ``position_improvement_pct``, ``velocity_improvement_pct``
        (delayed-state over conventional), ``reference``, ``ldv_scale_estimate``,
        ``delayed_state_skipped`` and, with a rotating IMU, ``tilt``.
    """
    log = logs[0]
    _check_vessel(log.manifest)
    progress("preparing", 0.02)
    inp = nav_inputs(log)
    inp.require_ldv()
    warnings = list(inp.warnings)
    ref = _reference(log, inp.t_s)
    if inp.eta_rad is not None:  # a rotating IMU: C_b^s from the encoder and the base tilt
        progress("base tilt of the rotating IMU", 0.05)
        est, _ = tilt_stage(inp)
        warnings += est.warnings
        cbs = c_bs_of(inp, est.alpha_rad, est.beta_rad)
    else:
        cbs = None
    imu, start, water, dmp = _filter_inputs(inp, cbs, params)
    results = {}
    for i, name in enumerate(MODES):
        progress(f"{name.replace('_', ' ')} navigation", 0.1 + 0.28 * i)
        q, v, p, s, n_rej = run_damping(imu, start, water, dmp._replace(mode=MODES[name]))
        results[name] = {**_errors_vs_gnss(inp, cbs, ref, q, v, p), "scale": 1.0 / s[-1], "rejected": int(n_rej)}
    summary = _summary(results)
    cols = _table(results, params.output_rate_hz)
    if cbs is not None:
        summary["tilt"] = {"alpha_rad": est.alpha_rad, "beta_rad": est.beta_rad, "observable": est.observable}
    return PipelineResult(summary=summary, tables={"damping": cols}, warnings=warnings)


PIPELINE = Pipeline(
    "damping",
    run,
    DampingParams,
    "Water-velocity horizontal damping of SINS (delayed-state filter)",
    applicable=applicable,
)
