"""What the pipelines' applicability checks know of a log, found once when it is read or stored.

The facts are small (JSON): which sensors the log has, whether its IMU rotates, and how many
repeated survey passes its speed shows. The store keeps them beside the log (``logs.facts``), so a
submit can refuse a pipeline that cannot apply without reading any sample.
"""

from __future__ import annotations

import numpy as np

from ldvsurvey.io.drivelog import DriveLog

#: a pass: a moving stretch (faster than this, m/s) between stops or turnarounds ...
PASS_SPEED_MPS = 2.0
#: ... at least this long (m); passes within 25 % of the median pass length are repeats of a line
PASS_MIN_LENGTH_M = 1000.0
PASS_LENGTH_TOLERANCE = 0.25


def repeated_passes(t_s: np.ndarray, speed_mps: np.ndarray, min_length_m: float = PASS_MIN_LENGTH_M) -> list:
    """Straight passes between stops/turnarounds that repeat a line: moving stretches of similar length.

    Parameters
    ----------
    t_s : (N,) times in s (increasing; need not be regular).
    speed_mps : (N,) horizontal speed in m/s (NaN: unknown, taken as stopped).
    min_length_m : shortest pass in m.

    Returns
    -------
    list of (t_start_s, t_end_s, length_m) of the passes within 25 % of the median pass length
    (empty when fewer than two passes of at least ``min_length_m`` exist).
    """
    t = np.asarray(t_s, float)
    sp = np.nan_to_num(np.asarray(speed_mps, float))
    if len(t) < 2:
        return []
    dt = np.diff(t, append=t[-1])
    dt = np.minimum(dt, 5.0 * float(np.median(np.diff(t))))  # a data gap drives no distance
    moving = sp > PASS_SPEED_MPS
    edges = np.flatnonzero(np.diff(np.r_[0, moving.astype(int), 0]))
    segs = []
    for a, b in zip(edges[::2], edges[1::2]):
        dist = float(np.sum(sp[a:b] * dt[a:b]))
        if dist >= min_length_m:
            segs.append((float(t[a]), float(t[b - 1]), dist))
    if len(segs) < 2:
        return []
    med = np.median([s[2] for s in segs])
    return [s for s in segs if abs(s[2] - med) < PASS_LENGTH_TOLERANCE * med]


def gnss_speed(t_s: np.ndarray, lat_deg: np.ndarray, lon_deg: np.ndarray, baseline: int = 2) -> np.ndarray:
    """Horizontal speed (m/s) at each fix from the fixes ``baseline`` epochs before and after it
    (central difference on a local flat Earth; the ends take the one-sided difference)."""
    t = np.asarray(t_s, float)
    n = len(t)
    if n < 2:
        return np.zeros(n)
    lat = np.radians(np.asarray(lat_deg, float))
    lon = np.radians(np.asarray(lon_deg, float))
    r_m = 6_371_000.0
    i = np.arange(n)
    a = np.clip(i - baseline, 0, n - 1)
    b = np.clip(i + baseline, 0, n - 1)
    de = (lon[b] - lon[a]) * r_m * np.cos(lat)
    dn = (lat[b] - lat[a]) * r_m
    span = t[b] - t[a]
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(span > 0, np.hypot(de, dn) / span, np.nan)


def speed_for_passes(ldv_t_s, ldv_v_mps, ldv_good, gnss) -> tuple[np.ndarray, np.ndarray, str] | None:
    """(t_s, speed m/s, source) a log's passes are found from: the LDV's forward speed where usable,
    else the GNSS track (fixes of any quality); None without either."""
    if ldv_t_s is not None and np.count_nonzero(ldv_good) >= 2:
        return np.asarray(ldv_t_s)[ldv_good], np.abs(np.asarray(ldv_v_mps)[ldv_good]), "ldv"
    if gnss is not None:
        t, lat, lon, fix = gnss
        ok = (np.asarray(fix) > 0) & np.isfinite(lat) & np.isfinite(lon)
        if np.count_nonzero(ok) >= 5:
            return np.asarray(t)[ok], gnss_speed(np.asarray(t)[ok], np.asarray(lat)[ok], np.asarray(lon)[ok]), "gnss"
    return None


def facts_from_streams(*, ldv_kind: str | None, imu_rotating: bool, ldv=None, min_quality=None, gnss=None) -> dict:
    """The facts of a log from its streams (see :func:`log_facts`); ``ldv`` = (t_s, v_fwd_mps,
    quality or None), ``gnss`` = (t_s, lat_deg, lon_deg, fix)."""
    lt = lv = good = None
    if ldv is not None:
        lt, lv, lq = ldv
        good = np.isfinite(lv)
        if lq is not None and min_quality is not None:
            good &= np.asarray(lq) >= min_quality
    src = speed_for_passes(lt, lv, good, gnss)
    passes = [] if src is None else repeated_passes(src[0], src[1])
    return {
        "has_ldv": ldv_kind is not None,
        "ldv_kind": ldv_kind or "none",
        "has_gnss": gnss is not None,
        "imu_rotating": bool(imu_rotating),
        "repeated_lines": len(passes),
        "repeated_lines_from": None if src is None else src[2],
    }


def log_facts(log: DriveLog) -> dict:
    """JSON-ready facts of a parsed log: ``has_ldv``, ``ldv_kind`` (``none`` without an LDV),
    ``has_gnss``, ``imu_rotating``, ``repeated_lines`` (passes of similar length, at least 1 km,
    found from the LDV speed or else the GNSS track: what the gravity pipeline would detect) and
    ``repeated_lines_from`` (``ldv``, ``gnss`` or None)."""
    m = log.manifest
    ldv = None
    if log.ldv is not None:
        ldv = (log.ldv.t_s, log.ldv.v_fwd_mps, log.ldv.quality)
    g = log.gnss
    return facts_from_streams(
        ldv_kind=None if m.ldv is None else m.ldv.kind,
        imu_rotating=m.imu.rotating,
        ldv=ldv,
        min_quality=None if m.ldv is None else m.ldv.min_quality,
        gnss=None if g is None else (g.t_s, g.lat_deg, g.lon_deg, g.fix),
    )
