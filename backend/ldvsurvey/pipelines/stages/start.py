"""How a log starts and where it stands still: still intervals, the static period at the start,
the start position, and the coarse alignment on the move when the log has no static start.

Shared by the pipelines through :func:`ldvsurvey.pipelines.stages.aids.nav_inputs`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ldvsurvey.errors import ParameterError
from ldvsurvey.io.drivelog import DriveLog
from ldvsurvey.nav.align import coarse_align
from ldvsurvey.nav.attitude import c_bs
from ldvsurvey.nav.earth import radii
from ldvsurvey.nav.running import all_ahead, running_mean, running_median_within
from ldvsurvey.units import G0_MPS2, RAD_PER_DEG

#: still: LDV speed below this (m/s)
STILL_SPEED_MPS = 0.03
#: still: the 1-s mean specific force in the body frame stays this close to its still value (m/s²)
#: and the body turns slower than this (rad/s); a vehicle cannot move off without either
STILL_ACCEL_MPS2 = 0.1
STILL_RATE_RPS = 0.01


def body_force_and_rate(t, dtheta, dvel, eta, window_s: float = 1.0):
    """Running means of the specific force in the body frame and of the body turn rate about the
    turntable axis, the signals the still detection tests.

    Parameters
    ----------
    t : ndarray
        (N,) IMU sample times (s).
    dtheta, dvel : ndarray
        (N, 3) angle (rad) and velocity (m/s) increments.
    eta : ndarray or None
        (N,) turntable angle (rad, unwrapped), removed with α = β = 0; None: a fixed IMU.
    window_s : float
        Length of the running mean (s).

    Returns
    -------
    f_b : ndarray
        (N, 3) specific force in the body frame (m/s²).
    w_z : ndarray
        (N,) body turn rate about the turntable axis (rad/s).
    """
    dt = np.diff(t, prepend=t[0] - (t[1] - t[0]))
    f = dvel / dt[:, None]
    wz = dtheta[:, 2] / dt
    if eta is not None:
        c, s = np.cos(eta), np.sin(eta)
        f = np.column_stack([c * f[:, 0] - s * f[:, 1], s * f[:, 0] + c * f[:, 1], f[:, 2]])
        wz = wz - np.diff(eta, prepend=eta[0]) / dt
    w = max(1, int(round(window_s / np.median(dt))))
    return running_mean(f, w), running_mean(wz, w)


def _quiet(f_b, w_z, ref_idx, f_all=None, w_all=None, tol=(STILL_ACCEL_MPS2, STILL_RATE_RPS)):
    """Samples whose body specific force and turn rate stay at the still values at ``ref_idx``
    (indices into ``f_all``/``w_all``, by default the same arrays), within ``tol`` (m/s², rad/s)."""
    f_all = f_b if f_all is None else f_all
    w_all = w_z if w_all is None else w_all
    f_ref = np.median(f_all[ref_idx], axis=0)
    w_ref = np.median(w_all[ref_idx])
    return (np.linalg.norm(f_b - f_ref, axis=1) < tol[0]) & (np.abs(w_z - w_ref) < tol[1])


#: how far (in σ of their own scatter at rest) the 1-s means may wander before it is motion
VIBRATION_K = 6.0


def vibration_tolerance(f_b, w_z, ref_idx) -> tuple[float, float]:
    """The still test's tolerances (m/s², rad/s) for a log whose IMU vibrates at rest.

    An idling engine shakes the IMU by metres per second squared and degrees per second from
    sample to sample, but it neither accelerates nor turns the vehicle: the 1-s *means* stay put.
    Their own scatter over the reference samples (the first seconds, assumed still) times
    :data:`VIBRATION_K` is the tolerance, never below the fixed :data:`STILL_ACCEL_MPS2` and
    :data:`STILL_RATE_RPS` a quiet IMU is judged with.

    Parameters
    ----------
    f_b, w_z : ndarray
        (N, 3) 1-s mean specific force (m/s²) and (N,) turn rate (rad/s) from :func:`body_force_and_rate`.
    ref_idx : ndarray
        Indices of the reference samples.

    Returns
    -------
    (float, float)
        Tolerance of the specific force (m/s²) and of the turn rate (rad/s).
    """
    f = f_b[ref_idx]
    sf = float(np.linalg.norm(np.std(f, axis=0))) if len(f) > 2 else 0.0
    sw = float(np.std(w_z[ref_idx])) if len(f) > 2 else 0.0
    return max(STILL_ACCEL_MPS2, VIBRATION_K * sf), max(STILL_RATE_RPS, VIBRATION_K * sw)


def still_intervals(t, speed, ok, min_len_s=3.0, thresh=STILL_SPEED_MPS, f_b=None, w_z=None):
    """Intervals where the vehicle stands still for at least ``min_len_s``.

    Still where the usable LDV speed (1-s running median) is below ``thresh``. Stretches where the LDV is unusable
    (samples below min_quality carry garbage, not zero) do not end a stop: a stretch next to a
    still LDV sample counts as still when the IMU shows neither acceleration nor turning in it
    (``f_b``, ``w_z`` from :func:`body_force_and_rate`), since a vehicle cannot start or stop without.

    Parameters
    ----------
    t : ndarray
        (N,) IMU sample times (s).
    speed, ok : ndarray
        (N,) speed at the IMU samples (m/s, LDV or GNSS) and where it is usable.
    min_len_s : float
        Shortest stop kept (s).
    thresh : float
        Still below this speed (m/s).
    f_b, w_z : ndarray or None
        Body specific force (m/s²) and turn rate (rad/s) from :func:`body_force_and_rate`; None:
        unusable stretches always end a stop.

    Returns
    -------
    list of (float, float)
        The still intervals (start, end) in s.
    """
    # the 1-s running median: LDV noise of a few cm/s, and an isolated spike flagged good, must not
    # chop a stop into slivers
    w = max(1, int(round(1.0 / np.median(np.diff(t)))))
    still = ok & running_median_within(speed, w, thresh)
    if f_b is not None:
        edges = np.flatnonzero(np.diff(np.r_[0, (~ok).astype(int), 0]))
        n = len(t)
        ref_w = max(5, int(round(1.0 / np.median(np.diff(t)))))
        for a, b in zip(edges[::2], edges[1::2]):
            left = a > 0 and still[a - 1]
            right = b < n and still[b]
            moving = (a > 0 and not still[a - 1]) or (b < n and not still[b])
            if not (left or right) or moving:
                continue
            ref = np.r_[np.arange(max(0, a - ref_w), a), np.arange(b, min(n, b + ref_w))]
            ref = ref[still[ref]]
            if len(ref) and _quiet(f_b[a:b], w_z[a:b], ref, f_b, w_z).all():
                still[a:b] = True
    out = []
    edges = np.flatnonzero(np.diff(np.r_[0, still.astype(int), 0]))
    for a, b in zip(edges[::2], edges[1::2]):
        if t[b - 1] - t[a] >= min_len_s:
            out.append((float(t[a]) + 0.5, float(t[b - 1]) - 0.5))
    return out


def detect_static_start(t, f_b, w_z, speed, ok, min_moving_s: float = 1.0, thresh=STILL_SPEED_MPS) -> float:
    """End (s) of the static period at the start of the log: the IMU stays at its initial specific
    force and turn rate (the 1-s means, within their own scatter at rest: an idling engine's
    vibration is no motion, :func:`vibration_tolerance`), and the usable speed stays below
    ``thresh`` (the speed's own noise limit) for ``min_moving_s`` in a row.

    Parameters
    ----------
    t : ndarray
        (N,) IMU times (s).
    f_b, w_z : ndarray
        (N, 3) 1-s mean body specific force (m/s²) and (N,) turn rate about the turntable axis
        (rad/s), from :func:`body_force_and_rate`.
    speed, ok : ndarray
        (N,) speed (m/s, LDV or GNSS) and where it is usable.
    min_moving_s : float
        How long (s) a speed must last to count as moving off.
    thresh : float or ndarray
        Moving at or above this speed (m/s; per sample for a GNSS speed, see :func:`gnss_still_speed`).

    Returns
    -------
    float
        The end of the static period (s), 2 s before the first motion.
    """
    n0 = max(10, int(round(2.0 / np.median(np.diff(t)))))
    ref = np.arange(min(n0, len(t)))
    quiet = _quiet(f_b, w_z, ref, tol=vibration_tolerance(f_b, w_z, ref))
    k_imu = int(np.argmin(quiet)) if not quiet.all() else len(t)
    mv = ok & (np.abs(speed) >= thresh)
    run = max(1, int(round(min_moving_s / np.median(np.diff(t)))))
    sustained = all_ahead(mv, run)
    k_ldv = int(np.argmax(sustained)) if sustained.any() else len(t)
    k = min(k_imu, k_ldv)
    # both tests fire about a second into a smooth start (0.1 m/s², 0.03 m/s): keep 2 s off it
    return float(t[max(0, k - 1)]) - 2.0


def first_motion(t, speed, ok, thresh, min_moving_s: float = 1.0) -> float | None:
    """The first time (s) the usable speed stays at or above ``thresh`` (m/s, scalar or per sample)
    for ``min_moving_s`` in a row, or None: what a speed says of a static period given by hand."""
    run = max(1, int(round(min_moving_s / np.median(np.diff(t)))))
    sustained = all_ahead(np.asarray(ok, bool) & (np.abs(speed) >= thresh), run)
    return float(t[int(np.argmax(sustained))]) if sustained.any() else None


#: fix qualities from best to worst for the start position
FIX_RANK = (4, 5, 2, 1)


def initial_position(log: DriveLog, t, static_end, eta=None, warnings=None, moving=None, c_bn=None) -> np.ndarray:
    """Start position of the IMU centre: lat, lon (rad), h (m).

    The manifest's ``initial`` position when given (authoritative). Otherwise the GNSS fixes of
    the static period at the start, of the best fix quality present there (4, 5, 2, 1 in this
    order), averaged, brought from the antenna to the IMU centre through the lever arm
    (``gnss.lever_arm_m``, body RFU) and the coarse-aligned attitude of the static period.
    Without a fix in the static period, the first fix of the best quality in the log is used with
    a warning (the vehicle may have moved by then).

    Parameters
    ----------
    log : DriveLog
        The parsed bundle.
    t : ndarray
        (N,) IMU times (s).
    static_end : float
        End of the static period at the start (s).
    eta : ndarray or None
        (N,) unwrapped turntable angle (rad) of a rotating IMU.
    warnings : list or None
        Receives what had to be assumed.
    moving : tuple or None
        The start state of :func:`moving_start` (a log that begins on the move), whose position is used.
    c_bn : ndarray or None
        (3, 3) C_b^n of the static period when its heading is known otherwise than from the gyros
        (:class:`Alignment`); None: the coarse alignment of the static period turns the lever arm.

    Returns
    -------
    ndarray
        Latitude, longitude (rad) and ellipsoidal height (m) of the IMU centre at the start.
    """
    m = log.manifest
    if m.initial.lat_deg is not None and m.initial.lon_deg is not None and m.initial.h_m is not None:
        return np.array([m.initial.lat_deg * RAD_PER_DEG, m.initial.lon_deg * RAD_PER_DEG, m.initial.h_m])
    if moving is not None:  # (C_b^n, v^n, position) of an alignment on the move
        return moving[2]
    g = log.gnss
    good = None if g is None else (g.fix > 0) & np.isfinite(g.lat_deg)
    if g is None or not good.any():
        raise ParameterError(
            "no start position: give manifest initial.lat_deg/lon_deg/h_m or a GNSS fix",
            file="manifest.json",
            field="initial",
        )
    in_static = good & (g.t_s >= t[0] - 0.5) & (g.t_s <= static_end)
    pool = in_static if in_static.any() else good
    best = next(q for q in FIX_RANK + tuple(np.unique(g.fix[pool])) if np.any(pool & (g.fix == q)))
    k = np.flatnonzero(pool & (g.fix == best))
    if not in_static.any():
        k = k[:1]
        if warnings is not None:
            warnings.append(
                f"no GNSS fix during the static period: the start position is the first fix of "
                f"quality {best} at t={g.t_s[k[0]]:.1f} s"
            )
    lat = float(np.mean(g.lat_deg[k])) * RAD_PER_DEG
    lon = float(np.mean(g.lon_deg[k])) * RAD_PER_DEG
    h = float(np.mean(g.h_m[k]))
    lever = np.asarray(m.gnss.lever_arm_m, float)
    ks = t <= static_end
    if c_bn is not None:
        lev_n = c_bn @ lever
    elif np.count_nonzero(ks) >= 100:
        imu = log.imu
        cbs = None if eta is None else c_bs(eta[ks])
        c_bn = coarse_align(
            imu.dtheta_rad[ks], imu.dvel_mps[ks], lat, c_bs=cbs, turntable_rad=None if eta is None else eta[ks]
        )
        lev_n = c_bn @ lever  # ENU
    else:
        lev_n = np.array([0.0, 0.0, lever[2]])
    rm, rn = radii(lat)
    return np.array([lat - lev_n[1] / (rm + h), lon - lev_n[0] / ((rn + h) * np.cos(lat)), h - lev_n[2]])


#: baseline (s) of the GNSS course at the start, by fix quality: long enough for the fix noise
#: (1-σ white part 1 cm … 0.2 m) to stay below ~0.1° at 10 m/s, short enough for the road's curvature
COURSE_BASELINE_S = {4: 1.0, 5: 2.0, 2: 3.0, 1: 5.0}


def _course_fixes(g, t0_s: float, what: str) -> tuple[int, int]:
    """The indices of the two GNSS fixes the course at the start comes from: of the best quality
    present in the first 30 s after ``t0_s`` (4, 5, 2, then 1), :data:`COURSE_BASELINE_S` apart;
    a ParameterError starting with ``what`` when there are none."""
    early = np.isfinite(g.lat_deg) & (g.t_s >= t0_s - 0.5) & (g.t_s <= t0_s + 30.0)
    for q in (4, 5, 2, 1):
        idx = np.flatnonzero(early & (g.fix == q))
        for i in idx:
            later = idx[
                (g.t_s[idx] >= g.t_s[i] + COURSE_BASELINE_S[q] - 0.01)
                & (g.t_s[idx] <= g.t_s[i] + COURSE_BASELINE_S[q] + 1.01)
            ]
            if len(later):
                return int(i), int(later[0])
    raise ParameterError(
        what + "two GNSS fixes of one quality a few seconds apart within the first 30 s",
        file="gnss.nmea",
        field="fix_quality",
    )


def _course_over_ground(g, k: np.ndarray, what: str) -> float:
    """The course over ground (rad from north) between the two fixes ``k``; a ParameterError
    starting with ``what`` when the vehicle is slower than 2 m/s there."""
    lat, lon, h = np.radians(g.lat_deg[k]), np.radians(g.lon_deg[k]), g.h_m[k]
    rm, rn = radii(lat[0])
    de = (lon[1] - lon[0]) * (rn + h[0]) * np.cos(lat[0])
    dn = (lat[1] - lat[0]) * (rm + h[0])
    dt_g = g.t_s[k[1]] - g.t_s[k[0]]
    if np.hypot(de, dn) / dt_g < 2.0:
        raise ParameterError(
            what + "the vehicle to move faster than 2 m/s at the first GNSS fixes (for the course over ground)",
            file="gnss.nmea",
            field="initial.static_s",
        )
    return float(np.arctan2(de, dn))


def _back_to_start(log: DriveLog, k: np.ndarray, c_bn: np.ndarray, v_n: np.ndarray, t0_s: float) -> np.ndarray:
    """The IMU-centre position (lat, lon rad, h m) at ``t0_s``: the first course fix less the lever
    arm and the distance driven since the start (straight line at the start velocity ``v_n``, m/s)."""
    g = log.gnss
    lat, lon, h = np.radians(g.lat_deg[k]), np.radians(g.lon_deg[k]), g.h_m[k]
    rm, rn = radii(lat[0])
    lev_n = c_bn @ np.asarray(log.manifest.gnss.lever_arm_m, float)
    back = v_n * (g.t_s[k[0]] - t0_s)  # driven from the start to the first fix (straight line)
    return np.array(
        [
            lat[0] - (lev_n[1] + back[1]) / (rm + h[0]),
            lon[0] - (lev_n[0] + back[0]) / ((rn + h[0]) * np.cos(lat[0])),
            h[0] - lev_n[2] - back[2],
        ]
    )


def moving_start(log: DriveLog, t, eta, nu_f, ok, window_s: float = 1.0):
    """Start state of a log that begins on the move: C_b^n, v^n (m/s) and the IMU-centre position
    (lat, lon rad, h m) at the first IMU sample, or a ParameterError naming what is missing.

    Heading from the GNSS course over ground between two fixes of the best quality present in the
    first 30 s (quality 4, 5, 2, then 1; a baseline of :data:`COURSE_BASELINE_S`, the vehicle
    faster than 2 m/s), carried back to the start with the body's turn rate from the gyros; level
    from the specific force less the LDV-measured acceleration over the first second (see
    :func:`ldvsurvey.nav.align.align_in_motion`); velocity from the LDV speed through the nominal
    mounting; position from the first of those fixes less the lever arm and the distance driven
    since the start (straight line at the start velocity).

    Parameters
    ----------
    log : DriveLog
        The parsed bundle (GNSS needed).
    t : ndarray
        (N,) IMU times (s).
    eta : ndarray or None
        (N,) unwrapped turntable angle (rad) of a rotating IMU.
    nu_f : ndarray
        (N,) forward speed (m/s) at the IMU samples: the LDV's, or the GNSS ground speed without one.
    ok : ndarray
        (N,) where ``nu_f`` is usable.
    window_s : float
        The span (s) at the start the level and the velocity come from.

    Returns
    -------
    c_bn : ndarray
        (3, 3) C_b^n at the first IMU sample.
    v_n : ndarray
        (3,) velocity (m/s, ENU) there.
    pos0 : ndarray
        IMU-centre latitude, longitude (rad) and ellipsoidal height (m) there.
    """
    from ldvsurvey.nav.align import align_in_motion
    from ldvsurvey.nav.errmodel import c_db

    m = log.manifest
    g = log.gnss
    what = (
        "the log has no static period at the start (manifest initial.static_s not given or 0, and the IMU "
        "or the LDV shows motion within 30 s), and an alignment on the move needs "
    )
    if g is None:
        raise ParameterError(what + "GNSS fixes (no gnss.nmea)", file="gnss.nmea", field="initial.static_s")
    k = np.array(_course_fixes(g, float(t[0]), what))
    course = _course_over_ground(g, k, what)
    kw = t <= t[0] + window_s
    use = kw & ok
    if np.count_nonzero(use) < 0.5 * np.count_nonzero(kw) or np.count_nonzero(use) < 10:
        raise ParameterError(
            what + ("a usable LDV speed" if m.ldv is not None else "GNSS fixes") + " during the first second",
            file="ldv.csv" if m.ldv is not None else "gnss.nmea",
            field="initial.static_s",
        )
    if m.ldv is not None:
        nom = m.ldv.nominal
        cdb, scale = c_db(nom.pitch_deg * RAD_PER_DEG, nom.heading_deg * RAD_PER_DEG), nom.scale
    else:  # nu_f is the GNSS ground speed: along the body's forward axis
        cdb, scale = np.eye(3), 1.0
    slope, v0 = np.polyfit(t[use] - t[0], nu_f[use] / scale, 1)
    dur = float(t[kw][-1] - t[0]) + float(np.median(np.diff(t)))
    # the body's turn between the start and the middle of the course baseline (ψ̇ ≈ −ω_up)
    t_mid = 0.5 * (g.t_s[k[0]] + g.t_s[k[1]])
    kt = t <= t_mid
    dth_z = log.imu.dtheta_rad[kt, 2].copy()
    if eta is not None:
        dth_z -= np.diff(eta[kt], prepend=eta[0])
    cbs = None if eta is None else c_bs(eta[kw])
    c_bn = align_in_motion(
        log.imu.dtheta_rad[kw],
        log.imu.dvel_mps[kw],
        dur,
        v_fwd_mps=float(v0 + slope * dur / 2),
        a_fwd_mps2=float(slope),
        course_rad=course,
        c_db_mount=cdb,
        c_bs=cbs,
        turntable_rad=None if eta is None else eta[kw],
    )
    from ldvsurvey.nav.attitude import c_bn_from_euler, euler_from_c_bn

    p0, r0, h_mid = euler_from_c_bn(c_bn)
    turn = float(np.sum(dth_z)) * np.cos(p0) * np.cos(r0)  # about the up axis, over (t0, t_mid]
    c_bn = c_bn_from_euler(p0, r0, h_mid + turn)
    v_n = c_bn @ (cdb @ np.array([0.0, v0, 0.0]))
    return c_bn, v_n, _back_to_start(log, k, c_bn, v_n, t[0])


# --- the standstill found in the data, and the alignment its sensors can observe ------------------

#: epoch-to-epoch horizontal noise (m, 1 σ) assumed per fix quality for speeds and courses from
#: differenced fixes over a second or two (the slowly wandering part of a fix's error cancels there)
GNSS_WHITE_H_M = {4: 0.01, 5: 0.05, 2: 0.2, 1: 0.5}
#: a GNSS speed whose still limit (3 σ) is above this cannot tell a standing vehicle from a creeping one
GNSS_JUDGE_MAX_MPS = 0.25
#: span (s) of the differenced fixes a standstill is judged on
GNSS_STILL_SPAN_S = 2.0


def gnss_still_speed(log: DriveLog, t_imu: np.ndarray, judge_max_mps: float = GNSS_JUDGE_MAX_MPS):
    """The GNSS ground speed at the IMU samples for the still test, with its own still limit.

    Speed from fixes :data:`GNSS_STILL_SPAN_S` apart (central differences: at 4 Hz over 8 epochs, at
    1 Hz over 2), its 1-σ √2·σ_h/span from the fix quality (:data:`GNSS_WHITE_H_M`), and the limit
    below which the vehicle counts as standing: 3 σ, never below :data:`STILL_SPEED_MPS`. Where that
    limit exceeds :data:`GNSS_JUDGE_MAX_MPS` (single-point fixes) the GNSS cannot tell standing from
    creeping and is not used for it.

    Parameters
    ----------
    log : DriveLog
        The parsed bundle.
    t_imu : ndarray
        (N,) IMU times (s).
    judge_max_mps : float
        The largest still limit (m/s) that can judge a standstill (np.inf: where the speed can show
        motion at all, see :func:`gnss_moving_limit`).

    Returns
    -------
    ok : ndarray
        (N,) bool: the GNSS speed can judge a standstill there (its limit at most ``judge_max_mps``).
    speed_mps : ndarray
        (N,) horizontal speed (m/s).
    limit_mps : ndarray
        (N,) still below this speed (m/s).
    """
    from ldvsurvey.io.logfacts import gnss_speed

    g = log.gnss
    n = len(t_imu)
    none = np.zeros(n, bool), np.zeros(n), np.full(n, STILL_SPEED_MPS)
    if g is None:
        return none
    k = (g.fix > 0) & np.isfinite(g.lat_deg) & np.isfinite(g.lon_deg)
    if np.count_nonzero(k) < 3:
        return none
    tg, fix = g.t_s[k], g.fix[k]
    step = float(np.median(np.diff(tg)))
    b = max(1, int(round(0.5 * GNSS_STILL_SPAN_S / step)))
    sp = gnss_speed(tg, g.lat_deg[k], g.lon_deg[k], baseline=b)
    i = np.arange(len(tg))
    lo, hi = np.clip(i - b, 0, len(tg) - 1), np.clip(i + b, 0, len(tg) - 1)
    span = np.maximum(tg[hi] - tg[lo], step)
    white = np.array([GNSS_WHITE_H_M.get(int(q), 1.0) for q in fix])
    sig_v = np.sqrt(2.0) * np.maximum(white[lo], white[hi]) / span
    limit = np.maximum(STILL_SPEED_MPS, 3.0 * sig_v)
    speed = np.interp(t_imu, tg, sp)
    lim = np.interp(t_imu, tg, limit)
    j = np.clip(np.searchsorted(tg, t_imu), 1, len(tg) - 1)
    ok = (tg[j] - tg[j - 1] <= 2.5 * step) & (t_imu >= tg[0] - step) & (t_imu <= tg[-1] + step)
    return ok & (lim <= judge_max_mps), speed, lim


#: a GNSS speed too noisy to call a standstill (limit above :data:`GNSS_JUDGE_MAX_MPS`) still shows
#: motion beyond this many of its σ: a 2-D speed of white noise exceeds 5 σ with probability
#: exp(−12.5) ≈ 4e-6 per sample (3 σ: 1 %, a false move-off in a 35-s stop of 1-Hz fixes every few logs)
GNSS_MOVING_SIGMAS = 5.0


def gnss_moving_limit(ok, limit):
    """The speed (m/s, per sample) above which the still test's GNSS speed shows the vehicle moving:
    its still limit (3 σ) where it can judge a standstill (``ok``), else 5 σ
    (:data:`GNSS_MOVING_SIGMAS`): single-point fixes at 1 Hz (σ_v 0.35 m/s) show a car at 15 m/s
    moving although they cannot tell standing from creeping."""
    return np.where(ok, limit, GNSS_MOVING_SIGMAS / 3.0 * np.asarray(limit, float))


#: the gyros gyrocompass when their heading σ (:func:`ldvsurvey.nav.align.gyrocompass_sigma`) is at most this (rad)
GYROCOMPASS_MAX_SIGMA_RAD = 1.0 * RAD_PER_DEG
#: heading σ (rad) beyond which the summary says heading was not observable
UNOBSERVABLE_SIGMA_RAD = 10.0 * RAD_PER_DEG
#: IMU-to-vehicle yaw allowance (rad, 1 σ) of a heading from the course: the vehicle's travel axis in
#: the IMU frame (no LDV: the IMU's forward axis as mounted; with an LDV: its nominal mounting)
MOUNT_YAW_SIGMA_RAD = {False: 1.0 * RAD_PER_DEG, True: 0.3 * RAD_PER_DEG}
#: gyro scale-factor allowance (relative, consumer MEMS up to ~1 %) on the yaw carried back
GYRO_SCALE_ALLOWANCE = 0.01
#: the course at move-off: at least this speed (m/s) and at most this σ (rad); a straight stretch
COURSE_MIN_SPEED_MPS = 3.0
COURSE_MAX_SIGMA_RAD = 0.5 * RAD_PER_DEG
COURSE_MAX_TURN_RAD = 1.0 * RAD_PER_DEG
COURSE_SEARCH_S = 120.0
#: the IMU's own speed along the travel axis tells forward from backward for a course this soon (s)
#: after the standstill (its drift: a 2 % grade's gravity, 0.2 m/s², gives 6 m/s in 30 s only when
#: driven all along; the sign is taken only with a magnitude 0.3-3 times the GNSS speed)
REVERSE_JUDGE_S = 30.0


@dataclass
class Alignment:
    """How the start attitude was found and how well (SI units, rad).

    ``c_bn`` is the body attitude at the first IMU sample when the heading came from anything but
    the gyros (None: the pipelines' static coarse alignment, gyrocompassing, is the start)."""

    method: str  #: gyrocompass, gnss_course, manifest or moving_start
    heading_sigma_rad: float
    standstill_s: tuple | None = None  #: (start, end) of the standstill at the start (s)
    standstill_found_by: str = ""
    c_bn: np.ndarray | None = None
    gyro_bias_rps: np.ndarray | None = None  #: initial gyro-bias estimate (sensor = body axes)
    gyro_bias_sigma_rps: np.ndarray | None = None
    gyrocompass_sigma_rad: float | None = None  #: what the gyros could have given
    course_t_s: float | None = None  #: the epoch of the course the heading came from
    observable: bool = True  #: heading known to better than :data:`UNOBSERVABLE_SIGMA_RAD`
    #: the standstill's noise as random walks over the filter's epoch (°/√h, µg/√Hz): vibration included
    gyro_arw_dprh: float | None = None
    accel_vrw_ug_rthz: float | None = None

    def summary(self) -> dict:
        """The summary keys (units in their names)."""
        from ldvsurvey.units import DEG_PER_RAD, DPH_PER_RPS

        def dph(x):
            return None if x is None else [float(v) for v in np.asarray(x) * DPH_PER_RPS]

        return {
            "alignment_method": self.method,
            "alignment_heading_sigma_deg": float(self.heading_sigma_rad * DEG_PER_RAD),
            "alignment_gyrocompass_sigma_deg": None
            if self.gyrocompass_sigma_rad is None
            else float(self.gyrocompass_sigma_rad * DEG_PER_RAD),
            "alignment_course_t_s": self.course_t_s,
            "standstill_s": None if self.standstill_s is None else [float(x) for x in self.standstill_s],
            "standstill_found_by": self.standstill_found_by,
            "initial_gyro_bias_dph": dph(self.gyro_bias_rps),
            "initial_gyro_bias_sigma_dph": dph(self.gyro_bias_sigma_rps),
            "standstill_gyro_arw_deg_rth": self.gyro_arw_dprh,
            "standstill_accel_noise_ug_rthz": self.accel_vrw_ug_rthz,
        }


def _manifest_heading(m):
    """(heading rad, σ rad) from the manifest's ``initial.heading_deg`` (and ``heading_sigma_deg``,
    default 1°), or None; a ParameterError naming the field when either is not a finite number."""
    val = getattr(m.initial, "heading_deg", None)
    if val is None:
        return None
    sig = getattr(m.initial, "heading_sigma_deg", 1.0)
    for name, v in (("heading_deg", val), ("heading_sigma_deg", sig)):
        if (
            isinstance(v, bool)
            or not isinstance(v, (int, float))
            or not np.isfinite(v)
            or (name[-9:] == "sigma_deg" and v <= 0)
        ):
            raise ParameterError(
                f"expected a finite number (positive for a σ), got {v!r}", file="manifest.json", field=f"initial.{name}"
            )
    return float(val) * RAD_PER_DEG, float(sig) * RAD_PER_DEG


def _body_increments(log: DriveLog, eta, k):
    """Angle and velocity increments (rad, m/s) of the samples ``k`` in the body frame (a rotating
    IMU's turntable taken out with its nominal axis)."""
    from ldvsurvey.nav.align import _increments_in_body

    imu = log.imu
    if eta is None:
        return imu.dtheta_rad[k], imu.dvel_mps[k]
    return _increments_in_body(imu.dtheta_rad[k], imu.dvel_mps[k], c_bs(eta[k]), eta[k])


def _travel_axis_b(log: DriveLog) -> np.ndarray:
    """The vehicle's travel direction in the body frame: the LDV's nominal axis, else the IMU's forward axis."""
    if log.ldv is None or log.manifest.ldv is None:
        return np.array([0.0, 1.0, 0.0])
    from ldvsurvey.nav.errmodel import c_db

    nom = log.manifest.ldv.nominal
    return c_db(nom.pitch_deg * RAD_PER_DEG, nom.heading_deg * RAD_PER_DEG) @ np.array([0.0, 1.0, 0.0])


def _course_candidates(g, t_from: float, t_to: float):
    """Pairs of fixes (i, j) of one quality, :data:`COURSE_BASELINE_S` apart, with i in [t_from, t_to]."""
    good = np.isfinite(g.lat_deg) & (g.fix > 0)
    idx = np.flatnonzero(good & (g.t_s >= t_from) & (g.t_s <= t_to + 3.0))
    for i in idx:
        if g.t_s[i] > t_to:
            break
        q = int(g.fix[i])
        base = COURSE_BASELINE_S.get(q, 5.0)
        later = idx[(g.fix[idx] == q) & (g.t_s[idx] >= g.t_s[i] + base - 0.01) & (g.t_s[idx] <= g.t_s[i] + base + 1.01)]
        if len(later):
            yield int(i), int(later[0]), q


def course_heading(log: DriveLog, t, eta, t_still_end: float, level, w_still_rps, w_sigma_rps, w_sample_rps):
    """The heading at the first IMU sample from the GNSS course at move-off, and its 1-σ.

    The vehicle does not turn while it stands: the heading at the start is the course at the first
    straight stretch driven fast enough for a sharp course (:data:`COURSE_MIN_SPEED_MPS`,
    :data:`COURSE_MAX_SIGMA_RAD`, turning less than :data:`COURSE_MAX_TURN_RAD` over the baseline;
    else the sharpest straight one within :data:`COURSE_SEARCH_S` at 1 m/s or more), less the
    body's yaw from the start to that epoch, integrated from the gyros with the standstill's mean
    rate removed (the bias and the Earth rate's vertical part: the integral over the standstill is
    zero by construction). The course is the IMU's (the antenna's less the lever arm's turn), and
    turned by 180° when the IMU's own speed along the travel axis shows it moving backwards.

    σ² = (√2 σ_h / (v Δt))² (the course; σ_h from :data:`GNSS_WHITE_H_M`) + (σ_b̄ Δ)² + σ_w² δt Δ
    (the yaw carried back over the Δ driven: the mean's σ and the per-sample noise) + (1 % of the
    yaw turned)² (gyro scale) + the IMU-to-vehicle yaw allowance (:data:`MOUNT_YAW_SIGMA_RAD`).

    Parameters
    ----------
    log : DriveLog
        The parsed bundle (GNSS needed).
    t : ndarray
        (N,) IMU times (s).
    eta : ndarray or None
        (N,) unwrapped turntable angle (rad).
    t_still_end : float
        End of the standstill (s).
    level : (float, float)
        Pitch and roll of the standstill (rad).
    w_still_rps, w_sigma_rps, w_sample_rps : ndarray
        (3,) the standstill's mean body rate, the σ of that mean and the per-sample σ (rad/s).

    Returns
    -------
    tuple or None
        (heading rad at ``t[0]``, σ rad, course epoch s); None without a usable course.
    """
    from ldvsurvey.nav.attitude import c_bn_from_euler

    g = log.gnss
    if g is None:
        return None
    dt = float(np.median(np.diff(t)))
    p0, r0 = level
    k_all = t <= min(t_still_end + COURSE_SEARCH_S + 10.0, t[-1])
    dth, dv = _body_increments(log, eta, k_all)
    yaw = np.concatenate([[0.0], np.cumsum(dth[:, 2] - w_still_rps[2] * dt)]) * np.cos(p0) * np.cos(r0)
    t_k = np.concatenate([[t[0] - dt], t[k_all]])
    fwd = c_bn_from_euler(p0, r0, 0.0) @ _travel_axis_b(log)
    v_along = _speed_along(dv, t[k_all] <= t_still_end, _travel_axis_b(log))
    best = None
    for i, j, q in _course_candidates(g, t_still_end, t_still_end + COURSE_SEARCH_S):
        lat, lon = np.radians(g.lat_deg[[i, j]]), np.radians(g.lon_deg[[i, j]])
        rm, rn = radii(lat[0])
        de = (lon[1] - lon[0]) * (rn + g.h_m[i]) * np.cos(lat[0])
        dn = (lat[1] - lat[0]) * (rm + g.h_m[i])
        dt_g = float(g.t_s[j] - g.t_s[i])
        v = float(np.hypot(de, dn)) / dt_g
        if v < 1.0 or g.t_s[j] > t_k[-1]:
            continue
        turn = abs(np.interp(g.t_s[j], t_k, yaw) - np.interp(g.t_s[i], t_k, yaw))
        if turn > COURSE_MAX_TURN_RAD:
            continue
        sig_c = np.sqrt(2.0) * GNSS_WHITE_H_M.get(q, 1.0) / (v * dt_g)
        t_mid = 0.5 * (g.t_s[i] + g.t_s[j])
        cand = (sig_c, float(np.arctan2(de, dn)), t_mid, de, dn, float(g.t_s[i]), float(g.t_s[j]))
        if v >= COURSE_MIN_SPEED_MPS and sig_c <= COURSE_MAX_SIGMA_RAD:
            best = cand
            break
        if best is None or sig_c < best[0]:
            best = cand
    if best is None:
        return None
    sig_c, course, t_mid, de, dn, t_i, t_j = best
    turned = float(np.interp(t_mid, t_k, yaw))  # counter-clockwise + (about up): heading falls by it
    az0 = np.arctan2(fwd[0], fwd[1])
    v_imu, v_gnss = float(np.interp(t_mid, t_k[1:], v_along)), float(np.hypot(de, dn) / (t_j - t_i))
    if t_mid - t_still_end <= REVERSE_JUDGE_S and -3.0 * v_gnss < v_imu < -0.3 * v_gnss:
        az0 += np.pi  # moving along −travel axis: reversing, or an IMU facing backwards in its mount
    lever_b = np.asarray(log.manifest.gnss.lever_arm_m, float)
    yaw_ij = np.interp([t_i, t_j], t_k, yaw)
    for _ in range(2):  # the antenna's course to the IMU's (the lever arm turns with the body)
        course = _imu_course(de, dn, yaw_ij - turned, course - az0, (p0, r0), lever_b)
    heading_mid = course - az0
    heading0 = float(np.mod(heading_mid + turned, 2 * np.pi))
    drive = max(0.0, t_mid - t_still_end)
    s_yaw2 = (w_sigma_rps[2] * drive) ** 2 + w_sample_rps[2] ** 2 * dt * drive + (GYRO_SCALE_ALLOWANCE * turned) ** 2
    sig = float(np.sqrt(sig_c**2 + s_yaw2 + MOUNT_YAW_SIGMA_RAD[log.ldv is not None] ** 2))
    return heading0, sig, float(t_mid)


def _speed_along(dv_mps, still, axis_b) -> np.ndarray:
    """(K,) speed (m/s) along ``axis_b`` since the standstill: the velocity increments less the
    standstill's mean (gravity and accelerometer bias), summed in the body frame. Its sign tells
    forward from backward at move-off (a few seconds: the neglected turn of the body and the bias
    change over them leave far less than the metres per second it is compared with)."""
    f_still = dv_mps[still].mean(axis=0) if still.any() else np.zeros(3)
    return np.cumsum(np.where(still, 0.0, (dv_mps - f_still) @ np.asarray(axis_b, float)))


def _imu_course(de_m: float, dn_m: float, yaw_rad, heading_mid_rad: float, level, lever_b) -> float:
    """The IMU centre's course (rad from north) between two fixes whose antenna moved (de, dn) m.

    The antenna's displacement less the lever arm's own turn with the body, (C_b^n(t_j) − C_b^n(t_i))
    l^b, the headings at the two fixes from ``heading_mid_rad`` less their yaw since the middle
    (``yaw_rad``: (2,) counter-clockwise + about up). On a bend of radius R an antenna l ahead of the
    IMU moves sideways by l/R of its course (3 m on 200 m: 0.9°)."""
    from ldvsurvey.nav.attitude import c_bn_from_euler

    c_ij = c_bn_from_euler(level[0], level[1], heading_mid_rad - np.asarray(yaw_rad, float))
    d = (c_ij[1] - c_ij[0]) @ np.asarray(lever_b, float)
    return float(np.arctan2(de_m - d[0], dn_m - d[1]))


def _random_walks(dth, dv, dt: float, span_s: float = 0.1) -> tuple[float, float]:
    """Angle and velocity random walks (°/√h, µg/√Hz) of a standstill as a filter epoch of
    ``span_s`` sees them: the σ of the increments summed over ``span_s`` blocks (their mean removed)
    divided by √span, the largest axis. An engine's vibration counts as far as it survives an epoch."""
    n = max(1, int(round(span_s / dt)))
    nb = len(dv) // n
    if nb < 3:
        return None, None
    sig_th = np.std(dth[: nb * n].reshape(nb, n, 3).sum(axis=1), axis=0)
    sig_v = np.std(dv[: nb * n].reshape(nb, n, 3).sum(axis=1), axis=0)
    span = n * dt
    return (
        float(np.max(sig_th)) / np.sqrt(span) / RAD_PER_DEG * 60.0,
        float(np.max(sig_v)) / np.sqrt(span) / (G0_MPS2 * 1e-6),
    )


def align_at_standstill(log: DriveLog, t, eta, still_s: tuple, found_by: str, lat_rad: float, noise) -> Alignment:
    """The alignment the sensors of a standstill start can observe (see ``docs/pipelines.md``).

    Roll and pitch from the standstill's mean specific force. Heading: the manifest's
    ``initial.heading_deg`` when given; else gyrocompassing when the gyros resolve the horizontal
    Earth rate to :data:`GYROCOMPASS_MAX_SIGMA_RAD` (:func:`ldvsurvey.nav.align.gyrocompass_sigma`
    with the larger of the manifest's gyro bias and the bias the standstill shows: on the vertical
    axis, where the Earth rate is known without heading, and as a horizontal rate beyond the Earth's
    ω cos L); else the GNSS course at move-off
    (:func:`course_heading`); else gyrocompassing at whatever σ it has (the summary says when that
    is no heading at all). Gyro biases: the standstill's mean less the Earth rate through the
    attitude found, σ from the mean's scatter and the Earth rate's horizontal part times the heading σ.

    Parameters
    ----------
    log : DriveLog
        The parsed bundle.
    t : ndarray
        (N,) IMU times (s).
    eta : ndarray or None
        (N,) unwrapped turntable angle (rad).
    still_s : (float, float)
        The standstill at the start (s).
    found_by : str
        How it was found (for the summary).
    lat_rad : float
        Latitude (rad).
    noise : ImuNoise
        The manifest's IMU figures (``gyro_bias_rps``).

    Returns
    -------
    Alignment
        Method, heading σ, the start attitude when not gyrocompassed, the initial gyro biases.
    """
    from ldvsurvey.nav.align import earth_rate_in_body, gyrocompass_sigma, standstill_rates
    from ldvsurvey.nav.attitude import c_bn_from_euler, euler_from_c_bn
    from ldvsurvey.nav.earth import OMEGA_IE

    k = t <= still_s[1]
    dt = float(np.median(np.diff(t)))
    dth, dv = _body_increments(log, eta, k)
    w_mean, w_sig, _, w_smp = standstill_rates(dth, dv, dt)
    c_gc = coarse_align(dth, dv, lat_rad)
    pitch, roll, _ = euler_from_c_bn(c_gc)
    # the vertical gyro's bias is seen without heading: Earth's vertical rate is ω sin L whatever the heading
    up_b = c_gc[2]  # the up axis in the body frame
    b_up = abs(float(up_b @ w_mean) - OMEGA_IE * np.sin(lat_rad))
    # and a horizontal rate well beyond the Earth's (ω cos L), or well short of it, is bias too,
    # whatever the heading: |w_h − ω_h| ≥ | |w_h| − ω cos L | (gyros reading zero at rest miss it all)
    w_h = float(np.linalg.norm(w_mean - up_b * (up_b @ w_mean)))
    b_h = abs(w_h - OMEGA_IE * abs(np.cos(lat_rad)))
    seen = max(0.0, max(b_up, b_h) - 3.0 * float(np.linalg.norm(w_sig)))
    sig_gc = gyrocompass_sigma(
        lat_rad, max(noise.gyro_bias_rps, seen) if eta is None else 0.0, float(np.hypot(*w_sig[:2]))
    )
    al = Alignment("gyrocompass", sig_gc, still_s, found_by, gyrocompass_sigma_rad=sig_gc)
    if eta is None:  # not on a rotating IMU, whose indexing and encoder steps are no sensor noise
        al.gyro_arw_dprh, al.accel_vrw_ug_rthz = _random_walks(dth, dv, dt)
    given = _manifest_heading(log.manifest)
    course = None
    if given is None and sig_gc > GYROCOMPASS_MAX_SIGMA_RAD:
        course = course_heading(log, t, eta, still_s[1], (pitch, roll), w_mean, w_sig, w_smp)
    if given is not None:
        al.method, al.heading_sigma_rad = "manifest", given[1]
        al.c_bn = c_bn_from_euler(pitch, roll, given[0])
    elif course is not None and course[1] < sig_gc:
        al.method, al.heading_sigma_rad, al.course_t_s = "gnss_course", course[1], course[2]
        al.c_bn = c_bn_from_euler(pitch, roll, course[0])
    al.observable = al.heading_sigma_rad <= UNOBSERVABLE_SIGMA_RAD
    c_bn = c_gc if al.c_bn is None else al.c_bn
    h = OMEGA_IE * np.cos(lat_rad)
    if al.observable:
        al.gyro_bias_rps = w_mean - earth_rate_in_body(c_bn, lat_rad)
        al.gyro_bias_sigma_rps = np.hypot(w_sig, h * np.sin(min(al.heading_sigma_rad, np.pi / 2)))
    else:  # only Earth's vertical rate is known: the horizontal part stays in the estimate's σ
        al.gyro_bias_rps = w_mean - up_b * OMEGA_IE * np.sin(lat_rad)
        al.gyro_bias_sigma_rps = np.hypot(w_sig, h)
    return al
