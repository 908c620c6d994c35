"""How a log starts and where it stands still: still intervals, the static period at the start,
the start position, and the coarse alignment on the move when the log has no static start.

Shared by the pipelines through :func:`ldvsurvey.pipelines.stages.aids.nav_inputs`.
"""

from __future__ import annotations

import numpy as np

from ldvsurvey.errors import ParameterError
from ldvsurvey.io.drivelog import DriveLog
from ldvsurvey.nav.align import coarse_align
from ldvsurvey.nav.attitude import c_bs
from ldvsurvey.nav.earth import radii
from ldvsurvey.nav.running import all_ahead, running_mean, running_median_within
from ldvsurvey.units import RAD_PER_DEG

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


def _quiet(f_b, w_z, ref_idx, f_all=None, w_all=None):
    """Samples whose body specific force and turn rate stay at the still values at ``ref_idx``
    (indices into ``f_all``/``w_all``, by default the same arrays)."""
    f_all = f_b if f_all is None else f_all
    w_all = w_z if w_all is None else w_all
    f_ref = np.median(f_all[ref_idx], axis=0)
    w_ref = np.median(w_all[ref_idx])
    return (np.linalg.norm(f_b - f_ref, axis=1) < STILL_ACCEL_MPS2) & (np.abs(w_z - w_ref) < STILL_RATE_RPS)


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


def detect_static_start(t, f_b, w_z, speed, ok, min_moving_s: float = 1.0) -> float:
    """End (s) of the static period at the start of the log: the IMU stays at its initial specific
    force and turn rate, and the usable LDV shows no speed for ``min_moving_s`` in a row.

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

    Returns
    -------
    float
        The end of the static period (s), 2 s before the first motion.
    """
    n0 = max(10, int(round(2.0 / np.median(np.diff(t)))))
    quiet = _quiet(f_b, w_z, np.arange(min(n0, len(t))))
    k_imu = int(np.argmin(quiet)) if not quiet.all() else len(t)
    mv = ok & (np.abs(speed) >= STILL_SPEED_MPS)
    run = max(1, int(round(min_moving_s / np.median(np.diff(t)))))
    sustained = all_ahead(mv, run)
    k_ldv = int(np.argmax(sustained)) if sustained.any() else len(t)
    k = min(k_imu, k_ldv)
    # both tests fire about a second into a smooth start (0.1 m/s², 0.03 m/s): keep 2 s off it
    return float(t[max(0, k - 1)]) - 2.0


#: fix qualities from best to worst for the start position
FIX_RANK = (4, 5, 2, 1)


def initial_position(log: DriveLog, t, static_end, eta=None, warnings=None, moving=None) -> np.ndarray:
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
    if np.count_nonzero(ks) >= 100:
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
