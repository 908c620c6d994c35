"""``gravity``: strapdown gravity from SINS/2-D LDV, repeated-line internal coincidence, SINS/GNSS beside.

The raw chains are in :mod:`ldvsurvey.pipelines.gravity.chains` (f_U from the navigation's own
mechanization step, LDV and GNSS gaps bridged so they cost only their own samples). Rows missing
from imu.csv are bridged (or refused) when the log is read; the summary reports them. Drift ties
at repeated stops: :mod:`drift`. Filtering and statistics (:mod:`report`): the
zero-phase Blackman FIR, the lines trimmed at their ends (the FIR would otherwise mix the
turnaround and the acceleration into them), the coincidence on common along-track points with
per-line statistics, crossovers, and the white-noise floor of the coincidence from the sensors'
noise and the FIR's noise gain, printed beside the measured figure.
"""

from __future__ import annotations

import copy
from dataclasses import dataclass, field
from typing import Literal

import numpy as np
from pydantic import Field, field_validator

from ldvsurvey.errors import ParameterError
from ldvsurvey.nav.earth import ARCSEC
from ldvsurvey.nav.gravity import MGAL, Lowpass
from ldvsurvey.pipelines.base import (
    LogFacts,
    Paths,
    Pipeline,
    PipelineResult,
    Reason,
    Text,
    needs_gnss,
    needs_ldv,
    output_rate,
    rate_within_imu,
    window_inside,
)
from ldvsurvey.pipelines.gravity.chains import gnss_chain, ldv_chain
from ldvsurvey.pipelines.gravity.drift import drift_correction
from ldvsurvey.pipelines.gravity.floor import combine, drift_floor
from ldvsurvey.pipelines.gravity.netfloor import network_floors
from ldvsurvey.pipelines.gravity.network import parse_ties, survey_network
from ldvsurvey.pipelines.gravity.report import (
    Evaluation,
    block,
    chain_difference,
    edge_gain_max,
    evaluate,
    floor_of,
    frame_tilt,
    with_imu_bridges,
)
from ldvsurvey.pipelines.gravity.tieheight import separation_warnings
from ldvsurvey.pipelines.navigate import run_navigation
from ldvsurvey.pipelines.stages.aids import gnss_aid
from ldvsurvey.pipelines.stages.aids import run_navigation_filter as navigate
from ldvsurvey.pipelines.stages.ldv_mounting import CalibrationParams, calibration_applicable, ldv_aid_of


class GravityParams(CalibrationParams):
    """Parameters of ``gravity``."""

    fir_length_s: float = Field(
        150.0, ge=10.0, le=3600.0, description="FIR filter length L in s (cut-off 1/L Hz; 10 to 3600 s)"
    )
    lines: Text | None = Field(
        None,
        max_length=10000,
        description="survey lines as t0-t1 pairs in s, comma "
        "separated (default: manifest lines, else detected repeated passes)",
    )
    spacing_m: float = Field(
        10.0, gt=0.0, le=1000.0, description="spacing of the common along-track points in m (0 to 1000 m)"
    )
    output_rate_hz: float = output_rate(1.0, "gravity.csv")
    gnss_comparison: bool = Field(True, description="also run the SINS/GNSS chain when GNSS is present")
    gnss_fixes: Text = Field(
        "4", max_length=20, description="GNSS fix qualities the SINS/GNSS chain uses (comma separated; 4 = RTK fixed)"
    )
    gnss_aided: bool = Field(False, description="also compute the LDV gravity on an LDV+GNSS navigation and show both")
    drift_correction: Literal["auto", "stops", "none"] = Field(
        "auto",
        description="vertical accelerometer drift tied at repeated stops: auto (where significant "
        "against the stops' noise), stops (always) or none",
    )
    line_leveling: Literal["none", "bias", "linear"] = Field(
        "none",
        description="repeat-line adjustment about the mean line: every line shifted by its mean residual "
        "(bias), by its least-squares linear drift along the line (linear), or not (none); makes the internal "
        "coincidence optimistic",
    )
    base_ties: Text | None = Field(
        None,
        max_length=10000,
        description="base stations as LAT,LON,H_M,G_MGAL[,SIGMA_MGAL];... (degrees, ellipsoidal height in m, "
        "absolute g in mGal, optionally its 1-σ in mGal, more than 0 and at most 100; without it the g is taken "
        "as exact): a log standing still within tie_radius_m of one is tied to it; ties at the start and end of "
        "a log fix its level and linear drift",
    )
    tie_radius_m: float = Field(
        30.0, gt=0.0, le=1000.0, description="a stop within this distance (m) of a base tie observes it (0 to 1000 m)"
    )
    network: Literal["auto", "none"] = Field(
        "auto",
        description="adjust all lines of all logs as one network (repeats, crossovers, ties): auto (with "
        "base_ties or several logs) or none",
    )
    network_drift: Literal["auto", "linear", "none"] = Field(
        "auto",
        description="linear drift per log in the network: auto (logs with ties at least 10 min apart), "
        "linear (every log) or none",
    )
    network_line_bias: bool = Field(True, description="a bias per line in the network (summing to zero per log)")
    outlier_sigma: float = Field(
        3.0, gt=0.0, le=100.0, description="network residuals beyond this many σ are flagged as outliers"
    )
    map_grid: bool = Field(
        True, description="with the network: a gridded map of the adjusted δg inside the survey's hull (netCDF)"
    )
    external_model: Literal["egm2008", "grid", "none"] = Field(
        "egm2008",
        description="external check of the adjusted δg: the built-in EGM2008 (degree 2190), a grid "
        "(external_grid or external_grid_id) or none",
    )
    external_grid: Paths | None = Field(
        None,
        description="ICGEM .gdf grid of δg (mGal), or ξ,η,δg grids, for external_model=grid (server files, "
        "not accepted by the API)",
    )
    external_grid_id: Text | None = Field(
        None, max_length=200, description="id of grids uploaded with POST /api/grids (external_model=grid)"
    )
    line_end_trim_s: float | None = Field(
        None,
        ge=0.0,
        le=3600.0,
        description="time in s trimmed at both "
        "ends of every line (default: half the FIR length, the filter's "
        "main lobe); 0 keeps the whole line",
    )

    @field_validator("lines")
    @classmethod
    def _lines(cls, v):
        return _parses(parse_lines, v)

    @field_validator("base_ties")
    @classmethod
    def _ties(cls, v):
        return _parses(parse_ties, v)

    @field_validator("gnss_fixes")
    @classmethod
    def _fixes(cls, v):
        return _parses(parse_fixes, v, none_ok=False)


def _parses(parse, v, none_ok: bool = True):
    """``v`` when ``parse`` accepts it (None passes when ``none_ok``); its ParameterError as the
    ValueError a pydantic validator raises, so the refusal names the field at submit."""
    if v is None and none_ok:
        return v
    try:
        parse(v)
    except ParameterError as exc:
        raise ValueError(exc.message) from None
    return v


def applicable(logs: list[LogFacts], params: GravityParams) -> list[Reason]:
    """Two survey lines at least (given, from the manifests, or the repeated passes found in a log
    without manifest lines when it was stored), given lines inside every log, an LDV or else GNSS
    (the SINS/GNSS chain is then the result), GNSS where the LDV+GNSS navigation is asked for."""
    out = rate_within_imu(logs, params)
    if any(f.has_ldv for f in logs):
        out += calibration_applicable(logs, params)
    for f in logs:
        if not f.has_ldv:
            out += needs_gnss([f], "without an LDV the gravity comes from the SINS/GNSS chain")
            if params.gnss_aided:
                out += needs_ldv([f], "gnss_aided adds an LDV+GNSS navigation", "gnss_aided")
    if params.gnss_aided:
        out += needs_gnss(logs, "gnss_aided needs GNSS", "gnss_aided")
    if params.lines:
        pairs = parse_lines(params.lines)
        for _name, a, b in pairs:
            out += window_inside(logs, (a, b), "lines")
        n = len(pairs) * len(logs)
    else:
        # a log without manifest lines: the repeated passes found when it was stored (the pipeline
        # detects them again in its navigation); not known (None): left to the pipeline
        found = [len(f.lines) if f.lines else f.repeated_lines for f in logs]
        n = None if any(k is None for k in found) else sum(found)
    if n is not None and n < 2:
        detected = any(not f.lines for f in logs) and not params.lines
        out.append(
            Reason(
                "lines",
                f"fewer than two survey lines ({n}) in the chosen log(s)"
                + (
                    " (no manifest lines, and no repeated passes of similar length, 1 km or longer, "
                    "found in the log's speed when it was stored)"
                    if detected
                    else ""
                )
                + ": give manifest lines, lines=t0-t1,t0-t1 or a second log",
            )
        )
    return out


def parse_lines(text):
    """``t0-t1,t0-t1,...`` into [(name, t0, t1)]."""
    out = []
    for k, item in enumerate(str(text).split(",")):
        try:
            a, b = (float(x) for x in item.strip().split("-", 1))
        except ValueError:
            raise ParameterError(f"expected t0-t1 pairs, got {item!r}", field="lines") from None
        if not b > a:
            raise ParameterError(f"line {item!r} ends before it starts", field="lines")
        out.append((f"L{k + 1}", a, b))
    return out


def detect_lines(chain, min_length_m=1000.0):
    """Straight passes between stops/turnarounds: moving stretches of similar length (the rule the
    store applied to the log's speed, :func:`ldvsurvey.io.logfacts.repeated_passes`, here on the
    navigation's speed)."""
    from ldvsurvey.io.logfacts import repeated_passes

    found = repeated_passes(chain["t_s"], chain["speed"], min_length_m)
    return [(f"L{k + 1}", a, b) for k, (a, b, _d) in enumerate(found)]


def parse_fixes(text):
    """``4,5`` into (4, 5): the GNSS fix qualities a chain uses."""
    try:
        out = tuple(int(x) for x in str(text).split(","))
    except ValueError:
        raise ParameterError(f"expected fix qualities like 4 or 4,5, got {text!r}", field="gnss_fixes") from None
    if not out or any(f not in (1, 2, 4, 5) for f in out):
        raise ParameterError(f"fix qualities are 1, 2, 4 or 5, got {text!r}", field="gnss_fixes")
    return out


def imu_gap_report(logs):
    """What the reader did about rows missing from imu.csv (bridged short gaps; long ones are refused
    by the navigation before any gravity is computed)."""
    rows = int(sum(getattr(log.imu, "bridged_rows", 0) for log in logs))
    notes = [w for log in logs for w in log.warnings if w.startswith("imu.csv") and "gap" in w]
    lost = [g for log in logs for g in getattr(log.imu, "bridges", []) if g.lost]
    return {
        "bridged_rows": rows,
        "lost_gaps": len(lost),
        "lost_rows": int(sum(g.rows for g in lost)),
        "notes": notes,
        "handling": "rows missing from imu.csv bridged on an even grid when the log was read: a row "
        "that accumulated the gap is split evenly over it (its sum kept exactly); lost rows get "
        "increments interpolated between their neighbours, one IMU sampling interval each whatever "
        "the (jittering) time tags say. A lost row's increments are unknown: the prediction's error, "
        "measured next to every gap, is carried into the floor (noise_floor.imu_bridge_mgal), every "
        "line's imu_bridged_s and imu_bridge_cost_mgal, and the stop ties' σ; longer gaps refused",
    }


#: manifest keys of the in-run bias instability (first-order Gauss-Markov bias states in the filter)
BIAS_INSTABILITY_KEYS = ("gyro_bias_instability_dph", "accel_bias_instability_ug", "bias_correlation_s")


def navigation_log(log):
    """The log the gravity navigation runs on: biases modelled as random constants.

    A wandering vertical accelerometer bias is indistinguishable from Δg while driving, so a
    Gauss-Markov bias state in the navigation follows Δg + drift and couples it into the vertical
    channel and the LDV calibration (measured: coincidence 4.05 mGal with the states, 3.39 without,
    on realistic_gravity(seed=3)). The drift is handled where it is observable (stop ties, repeated
    lines) and its share is put in the floor from the manifest's figures (the original log)."""
    imu = log.manifest.imu
    extra = getattr(imu, "__pydantic_extra__", None) or {}
    if not any(k in extra for k in BIAS_INSTABILITY_KEYS):
        return log
    imu2 = imu.model_copy()
    imu2.__pydantic_extra__ = {k: v for k, v in extra.items() if k not in BIAS_INSTABILITY_KEYS}
    nav = copy.copy(log)
    nav.manifest = log.manifest.model_copy(update={"imu": imu2})
    return nav


@dataclass(frozen=True)
class RunSetup:
    """What every stage of one gravity run shares: the logs, the parameters and what follows from them."""

    logs: list
    params: GravityParams
    lowpass: Lowpass  #: the gravity filter, built once from ``fir_length_s``
    trim_s: float  #: trimmed at both ends of every line, s
    fixes: tuple  #: GNSS fix qualities the SINS/GNSS chains use
    primary: str  #: the main chain: "ldv", or "gnss" for logs without an LDV
    network: bool  #: the lines of all logs adjusted as one network


@dataclass
class ChainSet:
    """The raw chains of every log (:mod:`chains`) and the survey lines on them."""

    main: list = field(default_factory=list)  #: per log, the main chain
    gnss: list = field(default_factory=list)  #: per log, the SINS/GNSS comparison chain (None: not run)
    aided: list = field(default_factory=list)  #: per log, the LDV chain on the LDV+GNSS navigation (gnss_aided)
    lines: list = field(default_factory=list)  #: (name, log index, t0 s, t1 s)
    warnings: list = field(default_factory=list)
    drift_reports: list = field(default_factory=list)  #: per log, the stop-tie drift correction's report
    first_drift: dict | None = None  #: the first log's drift floor (:func:`floor.drift_floor`)


def setup_run(logs, params: GravityParams) -> RunSetup:
    """The run's shared values; a ParameterError for a combination of parameters and logs that cannot run."""
    fir_s = params.fir_length_s
    if not fir_s > 0:
        raise ParameterError("must be positive", field="fir_length_s")
    trim_s = fir_s / 2 if params.line_end_trim_s is None else params.line_end_trim_s
    if not trim_s >= 0:
        raise ParameterError("must be zero or positive", field="line_end_trim_s")
    network = params.network == "auto" and bool(params.base_ties or len(logs) > 1)
    if network and params.line_leveling != "none":
        # levelling moves each log's turn-on bias into its lines, the ties (read at the unlevelled stops)
        # would then put it back: wrong absolute values without a word
        raise ParameterError(
            "line levelling and the survey network exclude each other: the network estimates each log's and "
            "line's bias itself (give line_leveling=none, or network=none)",
            field="line_leveling",
        )
    primary = "ldv" if logs[0].ldv is not None else "gnss"
    if not network and any((log.ldv is not None) != (primary == "ldv") for log in logs):
        # one summary block and one coincidence of two kinds of chains would mix their floors: only the
        # network weighs each log by its own floor
        raise ParameterError(
            "some logs have an LDV and some have none: give logs of one kind, or adjust them as one network "
            "(network=auto)",
            field="log_ids",
        )
    return RunSetup(logs, params, Lowpass(fir_s), trim_s, parse_fixes(params.gnss_fixes), primary, network)


def ldv_log_chains(rs: RunSetup, i: int, out: ChainSet, progress) -> None:
    """Navigate log ``i`` with its LDV and add its chains to ``out``: SINS/LDV, the SINS/GNSS comparison on
    the same navigation (where asked and fixes allow), the LDV chain on an LDV+GNSS navigation (gnss_aided)."""
    log, n, params = rs.logs[i], len(rs.logs), rs.params
    progress(f"bundle {i + 1}/{n}: SINS/LDV navigation", 0.05 + 0.6 * i / n)
    inp, setup, sol = run_navigation(navigation_log(log), params, progress, aiding="ldv", smooth=True)
    out.warnings += setup.warnings
    has_gnss = log.gnss is not None and np.count_nonzero(np.isin(log.gnss.fix, rs.fixes)) > 100
    gch = gskip = None
    if params.gnss_comparison and has_gnss:
        # before the SINS/LDV chain: its few per-sample temporaries then never meet that chain's columns
        progress(f"bundle {i + 1}/{n}: SINS/GNSS chain", 0.05 + 0.6 * (i + 0.3) / n)
        try:
            # f_U, attitude and the Eötvös velocity of the SINS/LDV navigation: the chains then differ
            # only in the vertical acceleration (LDV vs GNSS heights), and no third filter runs
            gch = gnss_chain(log, inp, sol, rs.lowpass, rs.fixes)
            gch["still"] = inp.still
            fl = floor_of(log, gch, rs.lowpass)
            if fl.get("gnss_height_mgal"):  # see report.break_edges
                gch["edge_gain_max"] = edge_gain_max(fl)
        except ValueError as exc:
            gskip = f"SINS/GNSS chain skipped for bundle {i + 1}: {exc}"
    ch = ldv_chain(inp, sol, setup)
    ch["still"] = inp.still
    if ch["screened"]:
        out.warnings.append(f"{ch['screened']} LDV sample(s) far off the navigation velocity treated as gaps")
    out.main.append(ch)
    out.gnss.append(gch)
    if gskip:
        out.warnings.append(gskip)
    if params.gnss_aided:
        if log.gnss is None:
            raise ParameterError("gnss_aided needs GNSS: the bundle has no gnss.nmea", field="gnss_aided")
        progress(f"bundle {i + 1}/{n}: LDV+GNSS navigation", 0.05 + 0.6 * (i + 0.6) / n)
        sol_a = navigate(inp, cbs=setup.cbs, ldv=ldv_aid_of(inp, setup), gnss=gnss_aid(log), smooth=True)
        out.aided.append(ldv_chain(inp, sol_a, setup))
        del sol_a
    # the chains hold what follows needs: the navigation's per-sample result goes before the statistics
    # (and before the next bundle's navigation)
    del inp, setup, sol


def all_chains(rs: RunSetup, progress) -> ChainSet:
    """Every log's chains and the survey lines on them (at least two)."""
    out = ChainSet()
    for i, log in enumerate(rs.logs):
        if log.ldv is None:  # no LDV: the SINS/GNSS chain is the result (same lines, floor, coincidence)
            out.main.append(gnss_primary_chain(rs, i, progress))
            out.gnss.append(None)
        else:
            ldv_log_chains(rs, i, out, progress)
        out.lines += _lines_of(log, out.main[-1], rs.params, i, len(rs.logs))
    if len(out.lines) < 2:
        raise ParameterError(
            "fewer than two survey lines: give manifest lines or --set lines=t0-t1,t0-t1", field="lines"
        )
    return out


def remove_drift(rs: RunSetup, cs: ChainSet) -> list[dict]:
    """The accelerometer drift tied at repeated stops, removed from every chain of the log it was found in
    (the same accelerometer); the chains are replaced, not changed. Returns the drift report per log."""
    mode = rs.params.drift_correction
    reports = []
    for i, ch in enumerate(cs.main):
        rep = {"method": "none", "reason": "drift_correction=none"}
        if mode != "none":  # both chains carry their static δg (SINS/LDV: f_U − γ; SINS/GNSS: the same)
            b, rep = drift_correction(ch, ch["still"], rs.logs[i].manifest.imu.accel_noise_ug_per_rthz, mode)
            if b is not None:
                # the network's ties read the stops with the same drift removed (drift_mps2)
                cs.main[i] = {**ch, "dg": ch["dg"] - b, "drift_mps2": b}
                for others in (cs.gnss, cs.aided):
                    if i < len(others) and others[i] is not None:  # the same accelerometer: the same drift
                        o = others[i]
                        others[i] = {**o, "dg": o["dg"] - np.interp(o["t_s"], ch["t_s"], b)}
            elif "not applied" not in rep.get("reason", ""):
                cs.warnings.append(f"bundle {i + 1}: no accelerometer drift correction ({rep['reason']})")
        reports.append(rep)
    return reports


def main_summary(rs: RunSetup, cs: ChainSet, res: Evaluation, drift_reports: list) -> dict:
    """The summary of the main chain: its block with the floor (white, drift, lost IMU rows), what was
    screened or bridged, the IMU gaps and the drift ties."""
    params, lowpass = rs.params, rs.lowpass
    drift = drift_floor(
        rs.logs[0],
        cs.main[0],
        res,
        lowpass,
        params.spacing_m,
        tie_applied=drift_reports[0].get("method") == "repeated stops",
        leveling=params.line_leveling,
    )
    cs.drift_reports, cs.first_drift = drift_reports, drift
    floor = with_imu_bridges(combine(floor_of(rs.logs[0], cs.main[0], lowpass), drift), res)
    summary = block(res, lowpass, rs.trim_s, rs.primary, floor)
    kinds = {c["kind"] for c in cs.main}  # both in a network of logs with and without an LDV
    if "ldv" in kinds:
        cs.warnings += ldv_gap_warnings(res, cs.main)
        summary["ldv_screened_samples"] = int(sum(c["screened"] for c in cs.main if c["kind"] == "ldv"))
    if "gnss" in kinds:
        summary["gnss_fixes"] = list(rs.fixes)
        summary["screened_fixes"] = int(sum(c["screened"] for c in cs.main if c["kind"] == "gnss"))
    if kinds == {"gnss"}:
        summary["chain"] = (
            "SINS/GNSS: the log has no LDV; δg from the GNSS-aided navigation's specific force less the "
            "vertical acceleration of the GNSS heights"
        )
    elif len(kinds) > 1:
        summary["chain"] = (
            "per log: SINS/LDV where the log has an LDV, SINS/GNSS where it has none (logs "
            + ", ".join(f"B{i + 1}" for i, c in enumerate(cs.main) if c["kind"] == "gnss")
            + "); the summary block is the first log's kind, the network weighs each log by its own floor"
        )
    summary["imu_gaps"] = imu_gap_report(rs.logs)
    summary["drift_correction"] = drift_reports[0] if len(drift_reports) == 1 else drift_reports
    return summary


def gnss_comparison(rs: RunSetup, cs: ChainSet, res: Evaluation, summary: dict) -> Evaluation | None:
    """The SINS/GNSS chain beside the main one: the navigation frame's tilt fitted to their difference
    and removed from the SINS/GNSS chains (replaced in ``cs``), its block as ``summary["gnss_comparison"]``.
    Returns its evaluation (None when not run or skipped, with a warning saying why)."""
    params, lowpass = rs.params, rs.lowpass
    if not (params.gnss_comparison and all(g is not None for g in cs.gnss)):
        if params.gnss_comparison and len({c["kind"] for c in cs.main}) > 1:
            cs.warnings.append(
                "SINS/GNSS comparison skipped: some logs have no LDV (their SINS/GNSS chain is the result)"
            )
        return None
    kw = {"strict": False, "leveling": params.line_leveling}
    try:
        gres = evaluate(cs.gnss, cs.lines, lowpass, params.spacing_m, rs.trim_s, **kw)
        tilt = frame_tilt(res, cs.main, gres, cs.gnss, lowpass)
        if tilt is not None:  # the navigation frame's DOV: removed from the SINS/GNSS chain
            cs.gnss = [{**g, "dg": g["dg"] - (tilt["xi_rad"] * g["a_n"] + tilt["eta_rad"] * g["a_e"])} for g in cs.gnss]
            gres = evaluate(cs.gnss, cs.lines, lowpass, params.spacing_m, rs.trim_s, **kw)
        floor = with_imu_bridges(floor_of(rs.logs[0], cs.gnss[0], lowpass), gres)
        out = block(gres, lowpass, rs.trim_s, "gnss", floor)
        out["frame_tilt"] = frame_tilt_report(tilt)
        out["gnss_fixes"] = list(rs.fixes)
        out["screened_fixes"] = int(sum(g["screened"] for g in cs.gnss))
        out["ldv_minus_gnss"] = chain_difference(res, cs.main, gres, cs.gnss)
        summary["gnss_comparison"] = out
    except (ValueError, ParameterError) as exc:  # e.g. no common stretch with usable GNSS
        cs.warnings.append(f"SINS/GNSS comparison skipped: {exc}")
        return None
    return gres


def gnss_aided_block(rs: RunSetup, cs: ChainSet, res: Evaluation, summary: dict) -> Evaluation | None:
    """The LDV chain on the LDV+GNSS navigation (gnss_aided): its block as ``summary["gnss_aided"]`` and its
    evaluation (None without it)."""
    if not cs.aided:
        return None
    params, lowpass = rs.params, rs.lowpass
    ares = evaluate(
        cs.aided, cs.lines, lowpass, params.spacing_m, rs.trim_s, strict=False, leveling=params.line_leveling
    )
    summary["gnss_aided"] = block(ares, lowpass, rs.trim_s, "ldv+gnss", floor_of(rs.logs[0], cs.aided[0], lowpass))
    summary["gnss_aided"]["ldv_minus_gnss_aided"] = chain_difference(res, cs.main, ares, cs.aided)
    return ares


def network_stage(rs: RunSetup, cs: ChainSet, res: Evaluation, summary: dict, progress) -> tuple[dict, dict]:
    """The survey network (base ties or several logs): ``summary["network"]``, the network's resolution as
    the summary's, and its tables and files; ({}, {}) without a network or when logs share no point."""
    if not rs.network:
        return {}, {}
    progress("network adjustment", 0.8)
    floors, floor_rows = network_floors(rs, cs, res)
    try:
        summary["network"], tables, files, warnings = survey_network(
            rs.logs, cs.main, res, rs.params, rs.lowpass, floors, progress
        )
        summary["network"]["log_floors"] = floor_rows  # the lines' weights: white and drift per log
    except ParameterError as exc:
        if rs.params.base_ties:  # asked for: a tie that cannot apply is the user's to fix
            raise
        # several logs without ties that share no point: each stays as it was (relative)
        cs.warnings.append(f"no network adjustment: {exc.message}")
        return {}, {}
    cs.warnings += warnings
    # one resolution in the summary: the network's (where the applied filter passes half the
    # amplitude, v/(2 f½)), the nominal v·L/2 kept under its own name
    net_res = [ln["resolution_m"] for ln in summary["network"]["lines"] if ln.get("resolution_m")]
    if net_res:
        summary["resolution_nominal_m"] = summary["resolution_m"]
        summary["resolution_m"] = float(np.median(net_res))
        summary["resolution_definition"] = (
            "resolution_m: half-wavelength v/(2 f½) at the frequency f½ where the applied filter passes "
            "half the amplitude (median over the network's lines, as network.lines[].resolution_m); "
            "resolution_nominal_m: v·L/2 at the single pass's cut-off 1/L"
        )
    return tables, files


def coincidence_table(res: Evaluation) -> dict | None:
    """coincidence.csv: every compared line's filtered δg, the mean line and the residual (mGal) on the
    common points (None without a coincidence)."""
    co = res.coincidence
    if co is None:
        return None
    n, m = co.values.shape
    return {
        "line": [nm for nm in co.names for _ in range(m)],
        "distance_m": np.tile(co.distance_m, n),
        "dg_mgal": co.values.ravel(),
        "mean_mgal": np.tile(co.mean, n),
        "residual_mgal": co.residual.ravel(),
    }


def run(logs, params: GravityParams, progress) -> PipelineResult:
    """Strapdown gravity of the logs: chains, drift ties, filter and lines, coincidence, network.

    Parameters
    ----------
    logs : list of DriveLog
        One or several logs of one kind (all with an LDV, or all without).
    params : GravityParams
        The validated parameters.
    progress : callable
        ``progress(message, fraction)``.

    Returns
    -------
    PipelineResult
        The summary (figures in mGal, m, s), the tables ``gravity`` and ``coincidence`` (and the network's),
        warnings and the network's map file.
    """
    rs = setup_run(logs, params)
    cs = all_chains(rs, progress)
    cs.warnings += separation_warnings(rs.logs)  # GGA heights without a geoid separation: orthometric
    progress("drift, filtering and coincidence", 0.75)
    drift_reports = remove_drift(rs, cs)
    res = evaluate(cs.main, cs.lines, rs.lowpass, params.spacing_m, rs.trim_s, leveling=params.line_leveling)
    summary = main_summary(rs, cs, res, drift_reports)
    gres = gnss_comparison(rs, cs, res, summary)
    ares = gnss_aided_block(rs, cs, res, summary)
    net_tables, net_files = network_stage(rs, cs, res, summary, progress)
    progress("writing", 0.9)
    extra = {"dg_sins_gnss_mgal": (cs.gnss, gres), "dg_gnss_aided_mgal": (cs.aided, ares)}
    tables = {"gravity": gravity_table(cs.main, res, params.output_rate_hz, extra)}
    co = coincidence_table(res)
    if co is not None:
        tables["coincidence"] = co
    tables.update(net_tables)
    return PipelineResult(summary=summary, tables=tables, warnings=cs.warnings, files=net_files)


def _lines_of(log, chain, params: GravityParams, i: int, n_logs: int) -> list:
    """The survey lines of bundle ``i`` as (name, bundle index, t0, t1): given, the manifest's, or
    the repeated passes detected in ``chain``."""
    prefix = f"B{i + 1}-" if n_logs > 1 else ""
    if params.lines:
        found = parse_lines(params.lines)
    elif log.manifest.lines:
        found = [(ln.name, ln.t_start, ln.t_end) for ln in log.manifest.lines]
    else:
        found = detect_lines(chain)
    return [(prefix + nm, i, a, b) for nm, a, b in found]


def gnss_primary_chain(rs: RunSetup, i: int, progress) -> dict:
    """The SINS/GNSS chain of log ``i`` without an LDV: the GNSS-aided navigation (forward filter and
    RTS smoother, ZUPT at stops) and the chain of :func:`gnss_chain` on it; a ParameterError when
    the log has too few fixes of the chosen qualities."""
    log, n_logs = rs.logs[i], len(rs.logs)
    progress(f"bundle {i + 1}/{n_logs}: SINS/GNSS navigation", 0.05 + 0.6 * i / n_logs)
    inp, _, sol = run_navigation(navigation_log(log), rs.params, progress, aiding="gnss", smooth=True)
    progress(f"bundle {i + 1}/{n_logs}: SINS/GNSS chain", 0.05 + 0.6 * (i + 0.5) / n_logs)
    try:
        ch = gnss_chain(log, inp, sol, rs.lowpass, rs.fixes)
    except ValueError as exc:
        raise ParameterError(f"no SINS/GNSS chain for bundle {i + 1}: {exc}", field="gnss_fixes") from None
    ch["still"] = inp.still  # before the floor: its accelerometer density may come from the static start
    fl = floor_of(log, ch, rs.lowpass)
    if fl.get("gnss_height_mgal"):  # see report.break_edges
        ch["edge_gain_max"] = edge_gain_max(fl)
    return ch


def ldv_gap_warnings(res: Evaluation, chains=None) -> list[str]:
    """One warning naming, per line, the LDV data bridged through the navigation velocity (dropouts,
    low quality, screened values) and what was withheld as unsupported; none when nothing was bridged.
    With ``chains`` (the main chains) only the lines of SINS/LDV chains are named."""
    parts = []
    for ln in res.lines:
        if chains is not None and chains[ln.chain]["kind"] != "ldv":
            continue
        if ln.bridged_s > 0:
            share = ln.bridged_s / ln.duration_s if ln.duration_s > 0 else 0.0
            parts.append(
                f"{ln.name} {ln.bridged_s:.1f} s ({100 * share:.1f} %"
                + (f", {ln.unsupported_s:.0f} s withheld" if ln.unsupported_s > 0 else "")
                + ")"
            )
    if not parts:
        return []
    return [
        "LDV gaps (dropouts, low quality, screened values) bridged through the navigation velocity on the "
        "lines: " + ", ".join(parts)
    ]


def frame_tilt_report(tilt):
    """The summary entry of the SINS/GNSS chain's frame-tilt correction (arcsec)."""
    if tilt is None:
        return {
            "applied": False,
            "note": "too few compared samples or too little horizontal acceleration to "
            "estimate the navigation frame's tilt; SINS/GNSS keeps ξ·a_N + η·a_E",
        }
    return {
        "applied": True,
        "xi_arcsec": tilt["xi_rad"] / ARCSEC,
        "eta_arcsec": tilt["eta_rad"] / ARCSEC,
        "xi_sigma_arcsec": tilt["xi_sigma_rad"] / ARCSEC,
        "eta_sigma_arcsec": tilt["eta_sigma_rad"] / ARCSEC,
        "n_samples": tilt["n_samples"],
        "note": "the navigation levels to the plumb line, GNSS heights are ellipsoidal: the deflection of the "
        "vertical (ξ, η) the frame holds, fitted to SINS/LDV − SINS/GNSS against the horizontal "
        "accelerations, and ξ·a_N + η·a_E removed from the SINS/GNSS chain (two parameters per "
        "survey; the chains' remaining difference is still a check of the vertical acceleration)",
    }


def gravity_table(chains, res: Evaluation, rate_hz: float, extra: dict) -> dict:
    """gravity.csv: the main chain at ``rate_hz`` (Hz; raw block means and filtered values, mGal), plus the
    other chains' filtered δg at the same times in the ``extra`` columns ({column: (chains, Evaluation or
    None)}; NaN where absent). With several logs a ``log`` column (1-based) says whose clock ``t_s`` is."""
    names = ("t_s", "line", "distance_m", "lat_deg", "lon_deg", "h_m", "dg_raw_mgal", "dg_mgal")
    cols = {k: [] for k in (names[:1] + ("log",) + names[1:] if len(chains) > 1 else names)}
    cols.update({k: [] for k, (ch, r) in extra.items() if r is not None})
    line_of = {}
    for ln in res.lines:
        line_of.setdefault(ln.chain, []).append((ln.name, ln.samples, ln.along_m))
    for ci, ch in enumerate(chains):
        step = max(1, int(round(ch["fs"] / rate_hz)))
        n = len(ch["t_s"]) // step * step
        raw = np.nanmean(ch["dg"][:n].reshape(-1, step), axis=1) / MGAL
        idx = np.arange(step // 2, n, step)
        name_col = np.array([""] * len(idx), dtype=object)
        dist = np.full(len(idx), np.nan)
        for name, k, s in line_of.get(ci, []):  # k: the line's sample indices (sorted)
            if not len(s):
                continue
            sel = k[np.minimum(np.searchsorted(k, idx), len(k) - 1)] == idx
            name_col[sel] = name
            dist[sel] = np.interp(idx[sel], k, s)
        t = ch["t_s"][idx]
        cols["t_s"] += list(t)
        if "log" in cols:
            cols["log"] += [ci + 1] * len(t)
        cols["line"] += list(name_col)
        cols["distance_m"] += list(dist)
        cols["lat_deg"] += list(np.degrees(ch["lat"][idx]))
        cols["lon_deg"] += list(np.degrees(ch["lon"][idx]))
        cols["h_m"] += list(ch["h"][idx])
        cols["dg_raw_mgal"] += list(raw)
        cols["dg_mgal"] += list(res.filtered[ci][idx] / MGAL)
        for key, (other, ores) in extra.items():
            if ores is None:
                continue
            f = ores.filtered[ci]
            tt = other[ci]["t_s"]
            v = np.interp(t, tt, f / MGAL)  # NaN (withheld) samples stay NaN
            v[(t < tt[0]) | (t > tt[-1])] = np.nan
            cols[key] += list(v)
    out = {k: (np.array(v, dtype=float) if k != "line" else v) for k, v in cols.items()}
    if "log" in out:
        out["log"] = np.array(cols["log"], dtype=np.int64)
    return out


PIPELINE = Pipeline(
    "gravity",
    run,
    GravityParams,
    "Strapdown gravity, repeated-line coincidence, SINS/GNSS comparison",
    multi_input=True,
    applicable=applicable,
)
