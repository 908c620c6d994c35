"""``dov``: DOV-induced INS position error by direct difference, RK4 and two mechanizations
("theoretical"), and compensation studies over grid step × update interval (methods §5)."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Annotated, Literal

import numpy as np
from pydantic import Field, field_validator

from ldvsurvey.errors import ParameterError
from ldvsurvey.io.drivelog import DriveLog, parse_imu
from ldvsurvey.io.imutime import check_no_long_gaps
from ldvsurvey.nav.align import coarse_align
from ldvsurvey.nav.attitude import c_from_q, q_from_c
from ldvsurvey.nav.dov import Deflection, Trajectory, initial_misalignment, propagate
from ldvsurvey.nav.dovgrid import DovGrid, area_for_track, egm_grid
from ldvsurvey.nav.earth import OMEGA_IE, enu_offset_m, normal_gravity, radii
from ldvsurvey.nav.mech import mechanize
from ldvsurvey.pipelines.base import (
    Floats,
    LogFacts,
    Params,
    Paths,
    Pipeline,
    PipelineResult,
    Progress,
    Reason,
    Text,
    needs_gnss,
    output_rate,
    rate_within_imu,
)
from ldvsurvey.pipelines.stages.aids import NavInputs, c_bs_of, gnss_ins, nav_inputs
from ldvsurvey.pipelines.stages.grid_cache import GRID_CACHE  # defined there, so setting it need not import this module
from ldvsurvey.pipelines.stages.plumb_line import load_grids
from ldvsurvey.pipelines.stages.turntable_tilt import tilt_stage
from ldvsurvey.units import ARCSEC_PER_RAD


class DovStudyParams(Params):
    """Parameters of ``dov``."""

    dov_grid: Paths | None = Field(
        None,
        description="two ICGEM .gdf files: ξ then η (arcsec); default: "
        "built-in EGM2008 (server files, not accepted by the API)",
    )
    grid_step_arcmin: float = Field(1.0, gt=0.0, le=60.0, description="step of the EGM2008 grid in arcmin (0 to 60′)")
    degree: int = Field(
        2190, ge=2, le=2190, description="maximum degree of the EGM2008 synthesis (2 to 2190, the model's maximum)"
    )
    interpolation: Literal["bilinear", "bicubic"] = Field("bilinear", description="grid interpolation along the track")
    update_s: float = Field(
        0.09, gt=0.0, le=60.0, description="error-update period in s of the direct and RK4 propagators (0 to 60 s)"
    )
    propagation_model: Literal["full", "paper"] = Field(
        "full",
        description="full: with the Coriolis coupling of the velocity errors; paper: eq. 10 exactly "
        "(Coriolis neglected)",
    )
    imu_nodov: Text | None = Field(
        None,
        description="imu.csv-format file of the same drive without the DOV "
        "(simulation only; server file, not accepted by the API)",
    )
    compensation: bool = Field(True, description="run the grid-step × update-interval compensation study")
    compensation_steps_arcmin: Annotated[Floats, Field(min_length=1, max_length=20)] = Field(
        [1.0, 2.5, 5.0, 10.0], description="grid steps of the study in arcmin (each 0 to 60′)"
    )
    compensation_updates_s: Annotated[Floats, Field(min_length=1, max_length=20)] = Field(
        [0.03, 0.15, 0.3, 3.0], description="update intervals of the study in s (each 0 to 60 s)"
    )
    output_rate_hz: float = output_rate(1.0, "dov.csv")

    @field_validator("compensation_steps_arcmin", "compensation_updates_s")
    @classmethod
    def _positive(cls, v):
        if not all(0.0 < x <= 60.0 for x in v):
            raise ValueError("every value must be > 0 and ≤ 60")
        return v


def applicable(logs: list[LogFacts], params: DovStudyParams) -> list[Reason]:
    """The DOV study takes its reference trajectory from GNSS."""
    return needs_gnss(logs, "the DOV pipeline needs GNSS for the reference trajectory") + rate_within_imu(logs, params)


def _grid(params: DovStudyParams, lat_deg, lon_deg, progress: Progress) -> DovGrid:
    """The DOV grid over the track (deg): the two ``dov_grid`` files, else EGM2008 synthesized at
    ``grid_step_arcmin`` to ``degree`` (kept in the caller's grid cache when there is one)."""
    paths = params.dov_grid
    if paths:
        if len(paths) != 2:
            raise ParameterError("give two .gdf files: dov_grid=xi.gdf,eta.gdf", field="dov_grid")
        grid = load_grids(paths)
    else:
        step = params.grid_step_arcmin
        area = area_for_track(lat_deg, lon_deg, step)
        key = f"egm2008:deg{params.degree}:step{step}:{area}"
        cache = GRID_CACHE.get()
        grid = cache.get(key) if cache is not None else None
        if grid is None:
            grid = egm_grid(area, step, params.degree, progress=lambda s, f: progress(s, 0.05 + 0.2 * f))
            if cache is not None:
                cache.put(key, grid)
    problem = grid.missing_cover(lat_deg, lon_deg)
    if problem:
        raise ParameterError(f"the DOV grid does not cover the track: {problem}", field="dov_grid")
    return grid


def _f_n_w_in(sol, inp: NavInputs):
    """Specific force in n (m/s²) and ω_in^n (rad/s) along the reference trajectory."""
    c = sol.c_bn() if sol.c_bs is None else c_from_q(sol.q_sn)
    dt = np.r_[np.diff(inp.t_s)[:1], np.diff(inp.t_s)]
    f_n = np.einsum("kij,kj->ki", c, inp.dvel_mps) / dt[:, None]
    lat, h = sol.pos[:, 0], sol.pos[:, 2]
    rm, rn = radii(lat)
    v = sol.v_n
    w_in = np.column_stack(
        [
            -v[:, 1] / (rm + h),
            OMEGA_IE * np.cos(lat) + v[:, 0] / (rn + h),
            OMEGA_IE * np.sin(lat) + v[:, 0] * np.tan(lat) / (rn + h),
        ]
    )
    return f_n, w_in


@dataclass(frozen=True)
class _FreeInertial:
    """Free-inertial mechanizations of one log from a coarse alignment over its static period, height
    held to the reference (``h_ref``: its height in m and vertical velocity in m/s per sample).

    ``rot`` = (C_b^s per sample, encoder angle per sample in rad) for a rotating IMU: the alignment
    removes the turntable motion and the mechanization starts from C_s^n = C_b^n (C_b^s)ᵀ."""

    t_s: np.ndarray
    dtheta_rad: np.ndarray
    dvel_mps: np.ndarray
    k_static: np.ndarray  #: the samples of the static period
    lat0_rad: float
    pos0: np.ndarray  #: lat, lon (rad), h (m) at the start
    h_ref: tuple
    rot: tuple | None = None

    def positions(self, dtheta_rad=None, dvel_mps=None, dov=None) -> np.ndarray:
        """Positions (lat, lon rad, h m per sample) of a pure INS of the increments (default: the
        log's), levelled to the plumb line; ``dov`` = (ξ, η) per sample (rad) compensates the gravity
        vector and the alignment (levelled to the normal) with that deflection."""
        dth = self.dtheta_rad if dtheta_rad is None else dtheta_rad
        dv = self.dvel_mps if dvel_mps is None else dvel_mps
        k_static, lat0 = self.k_static, self.lat0_rad
        if self.rot is None:
            c0 = coarse_align(dth[k_static], dv[k_static], lat0)
        else:
            cbs, turn = self.rot
            c0 = (
                coarse_align(dth[k_static], dv[k_static], lat0, c_bs=cbs[k_static], turntable_rad=turn[k_static])
                @ cbs[0].T
            )
        gravity = None
        if dov is not None:  # the alignment knows the deflection: undo the plumb-line levelling
            gravity = (*dov, np.zeros_like(dov[0]))
            phi0 = initial_misalignment(dov[0][0], dov[1][0], lat0)
            from ldvsurvey.nav.attitude import skew

            c0 = (np.eye(3) + skew(phi0)) @ c0
        q, v, p = mechanize(
            self.t_s, dth, dv, q_from_c(c0), np.zeros(3), self.pos0, gravity=gravity, height_ref=self.h_ref
        )
        return p


def _prepared(log: DriveLog, progress: Progress) -> tuple[NavInputs, tuple | None, list[str]]:
    """The loaded log (GNSS and a static start required), a rotating IMU's (C_b^s, encoder angle)
    with the base tilt applied, and the warnings so far."""
    warnings = []
    progress("preparing", 0.02)
    inp = nav_inputs(log)
    if log.gnss is None:
        raise ParameterError(
            "the DOV pipeline needs GNSS for the reference trajectory (no gnss.nmea)", file="gnss.nmea"
        )
    warnings += inp.warnings
    if inp.c_bn0 is not None:
        raise ParameterError(
            "the DOV pipeline's free-inertial mechanizations need a static period at the start "
            "(the log begins on the move): give manifest initial.static_s for a log that has one",
            file="manifest.json",
            field="initial.static_s",
        )
    rot = None
    if inp.eta_rad is not None:  # a rotating IMU: C_b^s from the encoder and the base tilt
        progress("base tilt of the rotating IMU", 0.03)
        est, _ = tilt_stage(inp)
        warnings += est.warnings
        rot = (c_bs_of(inp, est.alpha_rad, est.beta_rad), inp.eta_rad)
    return inp, rot, warnings


def _propagated(inp: NavInputs, ref, xi, eta, params: DovStudyParams) -> tuple[dict, np.ndarray]:
    """The DOV-induced position errors by the direct and the RK4 propagators along the reference:
    ``{"direct"|"rk4": (t_s, north_m, east_m)}``, and the initial misalignment (rad) the DOV causes."""
    f_n, w_in = _f_n_w_in(ref, inp)
    lat, h = ref.pos[:, 0], ref.pos[:, 2]
    gam = normal_gravity(lat, h)
    phi0 = initial_misalignment(xi[0], eta[0], lat[0])
    out = {}
    for name, rk in (("direct", False), ("rk4", True)):
        to, dn, de, _ = propagate(
            Trajectory(inp.t_s, lat, h, ref.v_n[:, 0], f_n, w_in, gam),
            Deflection(xi, eta),
            params.update_s,
            rk,
            phi0,
            params.propagation_model == "full",
        )
        out[name] = (to, dn, de)
    return out, phi0


def _theoretical(log: DriveLog, fi: _FreeInertial, xi, eta, imu_nodov: str | None, warnings: list):
    """The reference of the theoretical error: the mechanization of ``imu_nodov`` (the same drive
    without the DOV), else the mechanization compensated with the DOV along the track. Returns its
    positions, the compensated positions when computed (else None) and what the reference was."""
    if imu_nodov:
        path = Path(imu_nodov)
        if not path.is_file():
            raise ParameterError("no such file", file=str(path), field="imu_nodov")
        imu2, _ = parse_imu(path.read_bytes(), log.manifest)
        check_no_long_gaps(imu2.long_gaps, path.name)
        if len(imu2.t_s) != len(fi.t_s) or not np.allclose(imu2.t_s, fi.t_s):
            raise ParameterError("imu_nodov must have the same sample times as imu.csv", file=path.name, field="t")
        return fi.positions(imu2.dtheta_rad, imu2.dvel_mps), None, "two IMU files (with and without DOV)"
    warnings.append(
        "theoretical error from compensated vs uncompensated mechanization: give imu_nodov "
        "for two independent mechanizations"
    )
    p_exact = fi.positions(dov=(xi, eta))
    return p_exact, p_exact, "uncompensated vs compensated mechanization (no imu_nodov given)"


def _compensation_study(
    fi: _FreeInertial, grid: DovGrid, track_deg: tuple, p_exact: np.ndarray, params: DovStudyParams, progress
) -> list[dict]:
    """Residual of an INS compensated with a coarser grid and a held DOV against the exactly
    compensated one, per grid step (arcmin) × update interval (s): the largest horizontal residual (m)."""
    lat_deg, lon_deg = track_deg
    comp = []
    steps, updates = params.compensation_steps_arcmin, params.compensation_updates_s
    for i, st in enumerate(steps):
        g2 = grid if abs(st - grid.step_arcmin) < 1e-9 else grid.resample(st)
        xs, es, _ = g2.interpolate(lat_deg, lon_deg, "linear")
        for u in updates:
            progress(f"compensation study: {st}' grid, {u} s updates", 0.55 + 0.4 * i / len(steps))
            k = np.floor((fi.t_s - fi.t_s[0]) / u).astype(int)
            first = np.r_[0, np.flatnonzero(np.diff(k)) + 1]
            held = np.repeat(first, np.diff(np.r_[first, len(k)]))  # the DOV of each update held until the next
            p_c = fi.positions(dov=(xs[held], es[held]))
            r = enu_offset_m(p_exact[:, 0], p_exact[:, 1], p_exact[:, 2], p_c[:, 0], p_c[:, 1], p_exact[:, 2])
            comp.append(
                {"grid_step_arcmin": st, "update_s": u, "max_residual_m": float(np.max(np.hypot(r[:, 0], r[:, 1])))}
            )
    return comp


def _table(t_s, track_deg: tuple, xi, eta, out: dict, output_rate_hz: float) -> dict:
    """The ``dov.csv`` columns at ``output_rate_hz``: the track (deg), ξ, η (arcsec) and the north and
    east errors (m) of each method."""
    lat_deg, lon_deg = track_deg
    step = max(1, int(round(1.0 / (output_rate_hz * np.median(np.diff(t_s))))))
    t_out = t_s[step - 1 :: step]
    cols = {
        "t_s": t_out,
        "lat_deg": lat_deg[step - 1 :: step],
        "lon_deg": lon_deg[step - 1 :: step],
        "xi_arcsec": xi[step - 1 :: step] * ARCSEC_PER_RAD,
        "eta_arcsec": eta[step - 1 :: step] * ARCSEC_PER_RAD,
    }
    for name in ("direct", "rk4", "theoretical"):
        to, dn, de = out[name]
        cols[f"dn_{name}_m"] = np.interp(t_out, to, dn)
        cols[f"de_{name}_m"] = np.interp(t_out, to, de)
    return cols


def _maxima(out: dict, theo_kind: str) -> dict:
    """Per method the largest north and east errors (m, signed), and the direct and RK4 methods'
    deviation (%) from the theoretical one."""
    maxima = {}
    for name in ("direct", "rk4", "theoretical"):
        _, dn, de = out[name]
        maxima[name] = {"max_north_m": float(dn[np.argmax(np.abs(dn))]), "max_east_m": float(de[np.argmax(np.abs(de))])}
    th = maxima["theoretical"]
    for name in ("direct", "rk4"):
        maxima[name]["north_deviation_pct"] = 100 * (abs(maxima[name]["max_north_m"]) / abs(th["max_north_m"]) - 1)
        maxima[name]["east_deviation_pct"] = 100 * (abs(maxima[name]["max_east_m"]) / abs(th["max_east_m"]) - 1)
    maxima["theoretical"]["kind"] = theo_kind
    return maxima


def run(logs: list[DriveLog], params: DovStudyParams, progress: Progress) -> PipelineResult:
    """The INS position error the deflection of the vertical causes, by direct difference, RK4 and
    two mechanizations ("theoretical"), and the compensation study over grid step × update interval.

    Parameters
    ----------
    logs : list of DriveLog
        One parsed bundle with GNSS (the reference trajectory) and a static start.
    params : DovStudyParams
        The DOV source (``dov_grid`` files, else EGM2008 at ``grid_step_arcmin`` and ``degree``), the
        interpolation, the propagators' update period (s) and model, ``imu_nodov``, the study's grid
        steps (arcmin) and update intervals (s), the output rate (Hz).
    progress : Progress
        Stage reporter and cancellation.

    Returns
    -------
    PipelineResult
        ``dov.csv`` at ``output_rate_hz``: t_s, lat_deg, lon_deg, xi_arcsec, eta_arcsec and
        dn_/de_<method>_m for direct, rk4 and theoretical. Summary: ``max_north_error_m``,
        ``max_east_error_m`` per method, ``methods`` (with the deviations in %), ``compensation``
        (max_residual_m per grid step and update), ``dov_source``,
        ``mechanization_vs_reference_max_m``, ``rotating_imu``, ``initial_misalignment_arcsec``,
        ``xi_range_arcsec``, ``eta_range_arcsec``.
    """
    log = logs[0]
    inp, rot, warnings = _prepared(log, progress)
    progress("reference trajectory (GNSS/INS)", 0.04)
    ref = gnss_ins(inp, None if rot is None else rot[0])
    lat_deg, lon_deg = np.degrees(ref.pos[:, 0]), np.degrees(ref.pos[:, 1])
    grid = _grid(params, lat_deg, lon_deg, progress)
    method = "linear" if params.interpolation == "bilinear" else "cubic"
    xi, eta, _ = grid.interpolate(lat_deg, lon_deg, method)
    progress("direct and RK4 propagation", 0.3)
    out, phi0 = _propagated(inp, ref, xi, eta, params)
    progress("theoretical: two mechanizations", 0.45)
    fi = _FreeInertial(
        inp.t_s,
        inp.dtheta_rad,
        inp.dvel_mps,
        inp.t_s <= inp.static_end_s,
        ref.pos[0, 0],
        ref.pos[0].copy(),
        (ref.pos[:, 2], ref.v_n[:, 2]),
        rot,
    )
    p_unc = fi.positions()
    p_ref, p_exact, theo_kind = _theoretical(log, fi, xi, eta, params.imu_nodov, warnings)
    # how far the free-inertial mechanization strays from the GNSS/INS reference (its alignment and
    # sensor errors, not the DOV): the scale against which the DOV-induced errors are read
    drift = enu_offset_m(ref.pos[:, 0], ref.pos[:, 1], ref.pos[:, 2], p_unc[:, 0], p_unc[:, 1], ref.pos[:, 2])
    ins_drift_m = float(np.max(np.hypot(drift[:, 0], drift[:, 1])))
    d = enu_offset_m(p_ref[:, 0], p_ref[:, 1], p_ref[:, 2], p_unc[:, 0], p_unc[:, 1], p_ref[:, 2])
    out["theoretical"] = (inp.t_s, d[:, 1], d[:, 0])
    # compensation study: residual of a compensated INS against the exactly compensated one
    comp = []
    if params.compensation:
        if p_exact is None:  # compensated with the DOV along the track: computed once, used by both studies
            p_exact = fi.positions(dov=(xi, eta))
        comp = _compensation_study(fi, grid, (lat_deg, lon_deg), p_exact, params, progress)
    progress("writing", 0.95)
    cols = _table(inp.t_s, (lat_deg, lon_deg), xi, eta, out, params.output_rate_hz)
    maxima = _maxima(out, theo_kind)
    s = {
        "max_north_error_m": {k: v["max_north_m"] for k, v in maxima.items()},
        "max_east_error_m": {k: v["max_east_m"] for k, v in maxima.items()},
        "methods": maxima,
        "compensation": comp,
        "dov_source": grid.source,
        "mechanization_vs_reference_max_m": ins_drift_m,
        "rotating_imu": rot is not None,
        "initial_misalignment_arcsec": (phi0 * ARCSEC_PER_RAD).tolist(),
        "xi_range_arcsec": [float(cols["xi_arcsec"].min()), float(cols["xi_arcsec"].max())],
        "eta_range_arcsec": [float(cols["eta_arcsec"].min()), float(cols["eta_arcsec"].max())],
    }
    return PipelineResult(summary=s, tables={"dov": cols}, warnings=warnings)


PIPELINE = Pipeline(
    "dov",
    run,
    DovStudyParams,
    "DOV-induced INS position error and its compensation",
    applicable=applicable,
    uses_grid_cache=True,
)
