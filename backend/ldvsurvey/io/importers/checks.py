"""Cross-checks of imported recordings against each other, the partial manifest and physics.

Each check gives figures for the import report (``ImportResult.summary["checks"]``); a check that
shows the recordings cannot belong together refuses the import, one that shows something doubtful
adds a warning.
"""

from __future__ import annotations

import datetime as dt
import math

import numpy as np

from ldvsurvey.errors import BundleError
from ldvsurvey.io.importers import gpstime

MANIFEST_FILE = "manifest (partial)"
OMEGA_IE_DPH = math.degrees(7.292115e-5) * 3600.0  #: Earth rotation rate, deg/h
GRAVITY_WARN = 0.01  #: |f| against normal gravity, relative: refused above unless the user accepts more
GRAVITY_REFUSE = 0.10  #: refused above whatever the user accepts (a unit or time-base error, not a sensor's)
RATE_WARN = 0.01  #: measured IMU rate against the declared one
OVERLAP_WARN = 0.90  #: share of the IMU span covered by GNSS fixes
NAV_GRADE_BIAS_DPH = 0.05  #: gyro bias (manifest imu.gyro_bias_dph) at or below which Earth rate is checked
EARTH_RATE_TOL_DPH = 1.0  #: allowed | |ω| − Earth rate | for those units, deg/h


def recording_day(stamps) -> tuple[dt.date, str] | None:
    """UTC day a recording states for its first sample (GPS week, UTC date or UNIX time), with how."""
    if stamps is None or not len(stamps.values):
        return None
    if stamps.kind == "gps" and stamps.week is not None:
        week = int(stamps.week[0])
        if week < 1024:
            return None  # a 10-bit week: the manifest's date is what resolves it
        return gpstime.utc_day_of_gps(week, float(stamps.values[0])), f"GPS week {week}"
    if stamps.kind == "utc_tod" and stamps.day is not None:
        return stamps.day, "its UTC date"
    if stamps.kind == "unix":
        return dt.datetime.fromtimestamp(float(stamps.values[0]) + stamps.offset_s, dt.UTC).date(), "UNIX time"
    return None


def check_dates(parts: dict, names: dict, manifest_date: dt.date | None) -> dict:
    """Every recording that states its day must agree with the manifest's date (and each other) to a day."""
    out = {}
    for role, p in parts.items():
        got = recording_day(p.stamps)
        if got is None:
            continue
        day, how = got
        out[role] = {"day": day.isoformat(), "from": how}
        if manifest_date is not None and abs((day - manifest_date).days) > 1:
            n_days = (day - manifest_date).days
            weeks = round(n_days / 7168) * 1024
            rollover = (
                f" (exactly {abs(weeks)} GPS weeks: a receiver's week-number roll-over bug; its date is wrong, the "
                "manifest's may be right)"
                if weeks and abs(n_days - weeks * 7) <= 1
                else ""
            )
            raise BundleError(
                f"the recording is dated {day} ({how}) but the partial manifest says {manifest_date}: its samples "
                f"would land {n_days} days away on the bundle clock{rollover}; correct the manifest's date "
                "(or leave it out: the recordings state it)",
                file=names[role],
                field="date",
            )
    days = {v["day"] for v in out.values()}
    if len(days) > 1:
        first = sorted(days)
        if (dt.date.fromisoformat(first[-1]) - dt.date.fromisoformat(first[0])).days > 1:
            role = max(out, key=lambda r: out[r]["day"])
            dated = ", ".join(f"{r} {v['day']} ({v['from']})" for r, v in out.items())
            raise BundleError(
                f"the recordings are dated {dated}: they cannot belong to one drive",
                file=names[role],
                field="date",
            )
    return out


def check_overlap(t: dict, names: dict) -> dict | None:
    """IMU and GNSS must overlap in time: refuse when no fix lies within the IMU's span (its ends included: a
    recording of one fix has a GNSS span of zero length), warn below 90 % of the IMU span."""
    if "gnss" not in t or not len(t["gnss"]) or not len(t["imu"]):
        return None
    i0, i1 = float(t["imu"][0]), float(t["imu"][-1])
    tg = np.asarray(t["gnss"], dtype=np.float64)
    g0, g1 = float(tg[0]), float(tg[-1])
    ov = max(0.0, min(i1, g1) - max(i0, g0))
    share = ov / (i1 - i0) if i1 > i0 else 0.0
    inside = int(np.count_nonzero((tg >= i0) & (tg <= i1)))
    res = {
        "imu_s": [round(i0, 3), round(i1, 3)],
        "gnss_s": [round(g0, 3), round(g1, 3)],
        "overlap_s": round(ov, 3),
        "share": round(share, 4),
        "fixes_inside": inside,
    }
    if inside:
        return res
    if g1 < i0 or g0 > i1:
        gap = max(g0 - i1, i0 - g1)
        why = f"do not overlap in time ({gap:.3f} s apart)"
    else:
        k = int(np.searchsorted(tg, i0))
        why = f"overlap, but no fix lies within the IMU's span (the fixes pause from {tg[k - 1]:.3f} to {tg[k]:.3f} s)"
    raise BundleError(
        f"the IMU ({i0:.3f}–{i1:.3f} s) and the GNSS fixes ({g0:.3f}–{g1:.3f} s on the bundle clock) {why}: wrong "
        "day, time scale or time base in one of them",
        file=names["gnss"],
        field="time",
    )


def measure_imu_rate(t_imu: np.ndarray, declared_hz: float | None) -> dict:
    """The IMU rate measured over the recording (gaps left out) against the manifest's, if it states one."""
    d = np.diff(np.asarray(t_imu, dtype=np.float64))
    med = float(np.median(d))
    regular = d[d < 1.5 * med]
    measured = 1.0 / float(np.mean(regular)) if len(regular) else 1.0 / med
    res = {"measured_hz": round(measured, 4), "declared_hz": declared_hz, "gaps": int(len(d) - len(regular))}
    if declared_hz:
        res["error_rel"] = round(measured / float(declared_hz) - 1.0, 5)
    return res


def static_figures(
    dth_rfu: np.ndarray,
    dv_rfu: np.ndarray,
    t_imu: np.ndarray,
    static_s: float,
    lat_deg: float | None,
    h_m: float | None,
) -> dict:
    """Mean |f| and |ω| over the first ``static_s`` seconds, with normal gravity and Earth rate beside them.

    Parameters
    ----------
    dth_rfu, dv_rfu : (N, 3) arrays
        Angle (rad) and velocity (m/s) increments in the bundle's axes.
    t_imu : (N,) array
        Their times, s.
    static_s : float
        Length of the static start, s (at least 1 s is used).
    lat_deg, h_m : float or None
        Where the start is (latitude deg, ellipsoidal height m), for normal gravity; None when unknown.

    Returns
    -------
    dict
        ``window_s``, ``measured_mps2`` (|f|, m/s²), ``omega_dph`` (|ω|, deg/h), ``earth_rate_dph``; with a
        position also ``normal_mps2``, ``error_rel`` (|f|/γ − 1) and ``at``.
    """
    t = np.asarray(t_imu, dtype=np.float64)
    sel = t <= t[0] + max(static_s, 1.0)
    if sel.sum() < 2:
        sel[:2] = True
    k = np.flatnonzero(sel)
    span = float(t[k[-1]] - t[k[0]]) + float(np.median(np.diff(t)))
    f = float(np.linalg.norm(dv_rfu[sel].sum(axis=0))) / span
    w_dph = math.degrees(float(np.linalg.norm(dth_rfu[sel].sum(axis=0))) / span) * 3600.0
    res = {"window_s": round(span, 3), "measured_mps2": round(f, 6), "omega_dph": round(w_dph, 4)}
    if lat_deg is not None and h_m is not None:
        from ldvsurvey.nav.localframe import normal_gravity  # nav.earth would load numba (0.2 s)

        g = float(normal_gravity(math.radians(lat_deg), h_m))
        res["normal_mps2"] = round(g, 6)
        res["error_rel"] = round(f / g - 1.0, 6)
        res["at"] = [round(lat_deg, 7), round(h_m, 3)]
    res["earth_rate_dph"] = round(OMEGA_IE_DPH, 4)
    return res


def judge_static(
    fig: dict, gyro_bias_dph: float | None, file: str, warnings: list, gravity_tolerance: float | None = None
) -> None:
    """Judge the static start's |f| against normal gravity and |ω| against Earth rate.

    Parameters
    ----------
    fig : dict
        :func:`static_figures` of the start (``error_rel``: |f| / γ − 1, dimensionless).
    gyro_bias_dph : float or None
        The manifest's gyro bias, deg/h: Earth rate is judged for navigation-grade units (≤ 0.05 deg/h).
    file : str
        The IMU recording's name, for the messages.
    warnings : list
        Appended to.
    gravity_tolerance : float or None
        The relative |f| error the user accepts (``import.imu.static_gravity_tolerance``, e.g. 0.03 for an
        uncalibrated MEMS accelerometer); None: 1 %. Beyond it the import is refused naming the option;
        beyond 10 % always (a unit, scale or time-base error, not a sensor's). Accepted errors over 1 %
        are warned.
    """
    err = fig.get("error_rel")
    tol = GRAVITY_WARN if gravity_tolerance is None else min(float(gravity_tolerance), GRAVITY_REFUSE)
    if err is not None:
        said = (
            f"at rest (the first {fig['window_s']:.1f} s) the specific force is {fig['measured_mps2']:.4f} m/s², "
            f"{err * 100:+.2f} % off normal gravity there ({fig['normal_mps2']:.4f} m/s²)"
        )
        if abs(err) > GRAVITY_REFUSE:
            raise BundleError(
                f"{said}: the accelerometer's unit, scale or the time base is wrong", file=file, field="dvel"
            )
        if abs(err) > tol:
            raise BundleError(
                f"{said}, more than the {tol * 100:.1f} % accepted: an uncalibrated accelerometer's scale error, "
                "or the first seconds were not at rest (see initial.static_s). If the sensor is known to read so, "
                f"set import.imu.static_gravity_tolerance to at least {abs(err) + 0.001:.3f} to import it",
                file=file,
                field="dvel",
            )
        if abs(err) > GRAVITY_WARN:
            warnings.append(
                f"{file}: {said}: accepted (import.imu.static_gravity_tolerance {tol:g}); an uncalibrated "
                "accelerometer's scale error, to be calibrated before navigation-grade work"
            )
    if gyro_bias_dph is not None and gyro_bias_dph <= NAV_GRADE_BIAS_DPH:
        d = fig["omega_dph"] - fig["earth_rate_dph"]
        fig["earth_rate_error_dph"] = round(d, 4)
        if abs(d) > EARTH_RATE_TOL_DPH:
            warnings.append(
                f"{file}: at rest the gyros measure {fig['omega_dph']:.3f} °/h against Earth rate "
                f"{fig['earth_rate_dph']:.3f} °/h for a navigation-grade unit (imu.gyro_bias_dph "
                f"{gyro_bias_dph}): a rate unit or scale error, or the first seconds were not at rest"
            )
