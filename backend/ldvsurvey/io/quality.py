"""Quality report of a parsed bundle: durations, rates, gaps, GNSS fix shares, LDV quality."""

from __future__ import annotations

import numpy as np

from ldvsurvey.io.drivelog import DriveLog

FIX_NAMES = {0: "none", 1: "single", 2: "differential", 4: "rtk_fixed", 5: "rtk_float"}


def _stream(t_s: np.ndarray, nominal_hz: float | None) -> dict:
    """Rate and gap statistics of one time series (s)."""
    dt = np.diff(t_s)
    med = float(np.median(dt)) if len(dt) else float("nan")
    nominal_dt = 1.0 / nominal_hz if nominal_hz else med
    gap_mask = dt > 1.5 * nominal_dt
    return {
        "n": int(len(t_s)),
        "t_start_s": float(t_s[0]),
        "t_end_s": float(t_s[-1]),
        "duration_s": float(t_s[-1] - t_s[0]),
        "rate_hz": (1.0 / med) if med > 0 else None,
        "nominal_rate_hz": nominal_hz,
        "gaps": int(gap_mask.sum()),
        "longest_gap_s": float(dt[gap_mask].max()) if gap_mask.any() else 0.0,
        "jitter_s": float(np.std(dt)) if len(dt) else 0.0,
    }


def quality_report(log: DriveLog) -> dict:
    """JSON-ready quality report of a bundle.

    Durations in s, rates in Hz; ``fix_time_share`` is the share of the GNSS time span
    spent in each fix quality (each epoch weighted by the interval to the next one,
    outages counted as ``none``).
    """
    m = log.manifest
    imu = _stream(log.imu.t_s, m.imu.rate_hz)
    imu["duplicated_rows"] = log.imu.duplicated_rows
    imu["bridged_rows"] = log.imu.bridged_rows  # rows inserted over short gaps (counted apart from "gaps")
    # each bridged gap: [first inserted row, rows, t before, t after (s), 1 if lost (interpolated) else 0]
    imu["bridged_gaps"] = [[g.row, g.rows, g.t_before_s, g.t_after_s, int(g.lost)] for g in log.imu.bridges]
    imu["rotating"] = bool(log.imu.turntable_deg is not None)
    ldv = None  # a log without an LDV: no ldv section (the log page says "no LDV")
    if log.ldv is not None:
        ldv = _stream(log.ldv.t_s, m.ldv.rate_hz)
        ldv["duplicated_rows"] = log.ldv.duplicated_rows
        ldv["kind"] = m.ldv.kind
        ldv["source"] = log.ldv.source
        if log.ldv.quality is not None and m.ldv.min_quality is not None:
            below = int(np.sum(log.ldv.quality < m.ldv.min_quality))
            ldv["below_min_quality"] = below
            ldv["below_min_quality_share"] = below / len(log.ldv.t_s)
        else:
            ldv["below_min_quality"] = None
            ldv["below_min_quality_share"] = None
    report = {
        "duration_s": float(log.imu.t_s[-1] - log.imu.t_s[0]),
        "imu": imu,
        "ldv": ldv,
        "gnss": None,
        "warnings": list(log.warnings),
    }
    g = log.gnss
    if g is not None:
        gs = _stream(g.t_s, None)
        nominal = float(np.median(np.diff(g.t_s))) if len(g) > 1 else 1.0
        # time weight of each epoch: until the next epoch, outages beyond 1.5x nominal count as none
        w = np.append(np.minimum(np.diff(g.t_s), nominal), nominal)
        outage = float(np.sum(np.maximum(np.diff(g.t_s) - nominal, 0.0)))
        total = float(w.sum() + outage)
        shares = {name: 0.0 for name in FIX_NAMES.values()}
        for code in np.unique(g.fix):
            name = FIX_NAMES.get(int(code), f"q{int(code)}")
            shares[name] = shares.get(name, 0.0) + float(w[g.fix == code].sum()) / total
        shares["none"] += outage / total
        gs.update(
            {
                "fix_time_share": shares,
                "bad_checksum": g.bad_checksum,
                "malformed_lines": g.malformed_lines,
                "duplicate_epochs": g.duplicate_epochs,
                "skipped_sentences": g.skipped_sentences,
                "fix_timeline": _fix_timeline(g.t_s, g.fix),
            }
        )
        report["gnss"] = gs
    return report


def _fix_timeline(t_s: np.ndarray, fix: np.ndarray) -> list[dict]:
    """Runs of constant fix quality as [{t_start_s, t_end_s, fix}] (for the timeline view)."""
    change = np.flatnonzero(np.diff(fix) != 0) + 1
    starts = np.concatenate(([0], change))
    ends = np.concatenate((change - 1, [len(fix) - 1]))
    return [{"t_start_s": float(t_s[a]), "t_end_s": float(t_s[b]), "fix": int(fix[a])} for a, b in zip(starts, ends)]
