"""From a parsed bundle to navigation inputs, the filter's aids and a navigation run on them.

:func:`nav_inputs` loads a log into arrays (:class:`NavInputs`: IMU increments, the usable LDV
speeds at the IMU samples, still intervals, start; the still and start detection itself lives in
:mod:`ldvsurvey.pipelines.stages.start`); :func:`usable_ldv` screens the LDV samples; :func:`gnss_aid`
and :func:`ldv_aid` build the filter's aids; :func:`run_navigation_filter` runs the filter (and
smoother) on a loaded log. Shared by the pipelines. Knows the bundle model and the numerical core,
nothing of storage.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from ldvsurvey.errors import ParameterError
from ldvsurvey.io.drivelog import DriveLog
from ldvsurvey.io.imutime import check_no_long_gaps
from ldvsurvey.nav.align import coarse_align
from ldvsurvey.nav.attitude import c_bs, c_from_q, q_from_c
from ldvsurvey.nav.filter import (
    FilterConfig,
    GnssAid,
    ImuData,
    ImuNoise,
    LdvAid,
    NavSolution,
    NavStart,
    imu_grade,
    ldv_spikes,
    run_filter,
)
from ldvsurvey.nav.localframe import local_metres  # noqa: F401  (re-exported for the stages and gravity)
from ldvsurvey.pipelines.base import note_summary, warn
from ldvsurvey.pipelines.stages.start import (
    GNSS_JUDGE_MAX_MPS,
    Alignment,
    align_at_standstill,
    body_force_and_rate,
    detect_static_start,
    first_motion,
    gnss_moving_limit,
    gnss_still_speed,
    initial_position,
    moving_start,
    still_intervals,
)
from ldvsurvey.units import G0_MPS2, RAD_PER_DEG

#: fix quality -> 1-σ (horizontal, vertical) in m assumed for a survey receiver
GNSS_SIGMA = {4: (0.03, 0.05), 5: (0.3, 0.5), 2: (1.0, 2.0), 1: (3.0, 5.0)}


@dataclass
class NavInputs:
    """Everything a navigation run needs from one bundle (SI units, radians)."""

    log: DriveLog
    t_s: np.ndarray
    dtheta_rad: np.ndarray
    dvel_mps: np.ndarray
    eta_rad: np.ndarray | None  # turntable angle per IMU sample (unwrapped)
    ldv_ok: np.ndarray  # LDV usable at each IMU sample
    nu_f_mps: np.ndarray  # measured forward speed at the IMU samples
    nu_u_mps: np.ndarray | None
    still: list[tuple[float, float]]  # intervals where the vehicle stands still
    static_end_s: float
    pos0: np.ndarray  # lat, lon (rad), h (m) of the IMU centre at the start
    noise: ImuNoise
    cache: dict = None  # solutions shared between stages of one pipeline run
    warnings: list = None  # what the preparation had to assume (for the summary)
    c_bn0: np.ndarray | None = None  # C_b^n at the start when aligned on the move (no static start)
    v0_n: np.ndarray | None = None  # velocity (ENU, m/s) at the start when aligned on the move
    #: (xi_rad, eta_rad, dg_mps2) per IMU sample for the mechanization's gravity (None: normal gravity)
    gravity: tuple | None = None
    #: why the log's LDV cannot aid (no usable sample), raised by what needs it; None: usable or absent
    ldv_unusable: ParameterError | None = None
    #: how the start attitude was found and how well (:class:`~ldvsurvey.pipelines.stages.start.Alignment`)
    alignment: Alignment | None = None

    @property
    def has_ldv(self) -> bool:
        """The log has an LDV with usable samples (else only GNSS or nothing aids)."""
        return self.log.ldv is not None and self.ldv_unusable is None

    def require_ldv(self) -> None:
        """Raise what keeps the LDV from aiding (a pipeline that needs it calls this first)."""
        if self.ldv_unusable is not None:
            raise self.ldv_unusable
        if self.log.ldv is None:
            raise ParameterError("the bundle has no LDV (no ldv.csv)", file="ldv.csv", field="ldv")

    def __post_init__(self):
        if self.cache is None:
            self.cache = {}
        if self.warnings is None:
            self.warnings = []


def usable_ldv(log: DriveLog) -> np.ndarray:
    """Which of the LDV's own samples may be used: the filter's input screen.

    Parameters
    ----------
    log : DriveLog
        A parsed bundle with an LDV.

    Returns
    -------
    ndarray
        (M,) bool per ``ldv.csv`` sample: its quality is at least the manifest's ``ldv.min_quality``
        (every sample when either is absent) and it is not a spike flagged good
        (:func:`ldvsurvey.nav.filter.ldv_spikes`).
    """
    ldv = log.ldv
    ok = np.ones(len(ldv.t_s), bool)
    mq = log.manifest.ldv.min_quality
    if ldv.quality is not None and mq is not None:
        ok = ldv.quality >= mq
    return ok & ~ldv_spikes(ldv.v_fwd_mps, ok)


def _interp_ldv(log: DriveLog, t_imu: np.ndarray):
    """The usable LDV speeds (:func:`usable_ldv`) at the IMU samples (m/s) and where they are usable."""
    ldv = log.ldv
    t = ldv.t_s
    ok_l = usable_ldv(log)
    tg, vf = t[ok_l], ldv.v_fwd_mps[ok_l]
    if len(tg) < 2:
        raise ParameterError("the LDV has fewer than two samples above min_quality", field="ldv.csv")
    nu_f = np.interp(t_imu, tg, vf)
    nu_u = np.interp(t_imu, tg, ldv.v_up_mps[ok_l]) if ldv.v_up_mps is not None else None
    # usable where the nearest good samples on both sides are close
    rate = log.manifest.ldv.rate_hz
    j = np.clip(np.searchsorted(tg, t_imu), 1, len(tg) - 1)
    gap = tg[j] - tg[j - 1]
    ok = (t_imu >= tg[0]) & (t_imu <= tg[-1]) & (gap <= 3.0 / rate + 1e-6)
    return ok, nu_f, nu_u


def _gnss_speed_at(log: DriveLog, t_imu: np.ndarray):
    """Where the vehicle's speed is known from GNSS and that speed, at the IMU samples (a log without
    an LDV finds its stops from it): the horizontal speed of the fixes over a 2-epoch baseline,
    usable where the fixes on both sides are at most 2.5 GNSS intervals apart (and up to one interval
    before the first fix and after the last, the speed held)."""
    from ldvsurvey.io.logfacts import gnss_speed

    g = log.gnss
    n = len(t_imu)
    if g is None:
        return np.zeros(n, bool), np.zeros(n)
    k = (g.fix > 0) & np.isfinite(g.lat_deg) & np.isfinite(g.lon_deg)
    if np.count_nonzero(k) < 3:
        return np.zeros(n, bool), np.zeros(n)
    tg = g.t_s[k]
    sp = gnss_speed(tg, g.lat_deg[k], g.lon_deg[k], baseline=1)
    speed = np.interp(t_imu, tg, sp)
    j = np.clip(np.searchsorted(tg, t_imu), 1, len(tg) - 1)
    step = float(np.median(np.diff(tg)))
    ok = tg[j] - tg[j - 1] <= 2.5 * step
    # up to one GNSS interval beyond the first and last fixes the speed is held (a log's first IMU
    # samples come before its first fix: the moving start takes the speed of the first second there)
    ok &= (t_imu >= tg[0] - step) & (t_imu <= tg[-1] + step)
    return ok, speed


def nav_inputs(log: DriveLog) -> NavInputs:
    """Prepare the navigation inputs of a bundle (detects still periods, finds the start position).

    The stops are where the LDV (or, on a log without an LDV, the GNSS track) shows no speed and the
    IMU neither accelerates nor turns.

    Parameters
    ----------
    log : DriveLog
        The parsed bundle.

    Returns
    -------
    NavInputs
        The IMU increments (rad, m/s), the LDV speeds at the IMU samples (m/s) and where usable, the
        still intervals and the end of the static period (s), the start position (rad, m), the IMU
        noise, and for a log that starts on the move the start attitude and velocity (m/s).
    """
    imu = log.imu
    check_no_long_gaps(imu.long_gaps)  # never integrate across a gap
    t = imu.t_s
    m = log.manifest
    eta = np.unwrap(np.radians(imu.turntable_deg)) if imu.turntable_deg is not None else None
    sp = _speeds(log, t)
    f_b, w_z = body_force_and_rate(t, imu.dtheta_rad, imu.dvel_mps, eta)
    still = still_intervals(t, sp.judge_v / sp.limit, sp.judge_ok, thresh=1.0, f_b=f_b, w_z=w_z)
    static_s = m.initial.static_s
    start = None
    warnings = []
    found_by = "manifest initial.static_s"
    if static_s is None or static_s == 0:  # not given: detect; 0: the log starts on the move
        static_end = float(t[0])
        if static_s is None:
            static_end = detect_static_start(t, f_b, w_z, sp.judge_v, sp.moving_ok, thresh=sp.moving_limit)
            found_by = _found_by(sp.by, sp.judge_ok, t, static_end)
        if static_end - t[0] < 30.0:  # no static start: align on the move (or say what is missing)
            start = moving_start(log, t, eta, sp.speed, sp.speed_ok)
            static_end = float(t[0])
            warnings += _moving_start_warnings(m, t, sp.by)
    else:
        static_end = float(t[0] + static_s)
        if static_s < 30.0:
            raise ParameterError(
                "the static period is shorter than 30 s: too short to align",
                file="manifest.json",
                field="initial.static_s",
            )
        # a water-track LDV measures the water flowing past a moored vessel, not its motion
        water = sp.from_ldv and m.ldv.kind == "water"
        moved = None if water else first_motion(t, sp.judge_v, sp.moving_ok, sp.moving_limit)
        if moved is not None and moved < static_end:  # an override, but not a silent one
            warnings.append(
                f"manifest initial.static_s={static_s:g} s, but {sp.by}'s speed shows motion from t={moved:.1f} s: "
                "zero-velocity updates on a moving vehicle corrupt the start (check initial.static_s, or "
                "leave it out to find the standstill in the data)"
            )
    still = [(a, b) for a, b in still if b > static_end + 1.0 or a > static_end]
    noise = ImuNoise.from_manifest(m.imu)
    if start is None:
        still = [(float(t[0]), static_end)] + [(max(a, static_end), b) for a, b in still]
        pos0 = initial_position(log, t, static_end, eta, warnings)
        alignment = align_at_standstill(log, t, eta, (float(t[0]), static_end), found_by, float(pos0[0]), noise)
        if alignment.c_bn is not None:  # the lever arm turned with the heading found
            pos0 = initial_position(log, t, static_end, eta, [], c_bn=alignment.c_bn)
        warnings += _alignment_warnings(alignment)
    else:
        pos0 = initial_position(log, t, static_end, eta, warnings, moving=start)
        alignment = Alignment(
            "moving_start", MOVING_ATT_SIGMA0_RAD[2], None, "no standstill at the start", c_bn=start[0]
        )
    for w in warnings:
        warn(w)
    note_summary(alignment.summary())
    return NavInputs(
        log=log,
        t_s=t,
        dtheta_rad=imu.dtheta_rad,
        dvel_mps=imu.dvel_mps,
        eta_rad=eta,
        ldv_ok=sp.ok,
        nu_f_mps=sp.nu_f,
        nu_u_mps=sp.nu_u,
        still=still,
        static_end_s=static_end,
        pos0=pos0,
        noise=noise,
        warnings=warnings,
        c_bn0=None if start is None else start[0],
        v0_n=None if start is None else start[1],
        ldv_unusable=sp.unusable,
        alignment=alignment,
    )


#: still: the LDV speed below this (m/s)
STILL_LDV_MPS = 0.03


class _Speeds(NamedTuple):
    """The speeds a log is judged with at the IMU samples (see :func:`_speeds`)."""

    ok: np.ndarray  #: where the LDV aids (none without a usable LDV)
    nu_f: np.ndarray  #: the LDV's forward speed (m/s)
    nu_u: np.ndarray | None  #: the LDV's up speed (m/s)
    speed_ok: np.ndarray  #: where the speed a moving start takes is usable
    speed: np.ndarray  #: that speed (m/s)
    by: str  #: its source, as the messages name it
    unusable: ParameterError | None  #: why the log's LDV cannot aid
    judge_ok: np.ndarray  #: where the still test's speed can call a standstill
    judge_v: np.ndarray  #: the still test's speed (m/s)
    limit: np.ndarray  #: below it the vehicle stands (m/s)
    moving_ok: np.ndarray  #: where that speed can show motion
    moving_limit: np.ndarray  #: above it the vehicle moves (m/s)
    from_ldv: bool  #: the speeds are the LDV's


def _speeds(log: DriveLog, t: np.ndarray) -> _Speeds:
    """The speeds a log is judged with at the IMU samples ``t``: the LDV's (usable flags, forward and
    up m/s) as the aid; the speed a moving start takes (usable, m/s) and its source; the LDV's
    unusability (a ParameterError or None); and the still test's (usable, speed m/s, limit m/s) with
    where and above what speed (m/s) it shows motion (single-point fixes: motion, never a standstill)."""
    unusable = None
    if log.ldv is not None:
        try:
            ok, nu_f, nu_u = _interp_ldv(log, t)
            lim = np.full(len(t), STILL_LDV_MPS)
            return _Speeds(ok, nu_f, nu_u, ok, nu_f, "the LDV", None, ok, nu_f, lim, ok, lim, True)
        except ParameterError as exc:  # an LDV that failed all day: GNSS-only work still goes on
            unusable = exc
    # no LDV: never an aid; stops and a moving start from GNSS
    ok, nu_f = np.zeros(len(t), bool), np.zeros(len(t))
    speed_ok, speed = _gnss_speed_at(log, t)
    # the still test: the speed over 2 s against its own noise (4-Hz RTK fixes differenced epoch to
    # epoch read a few cm/s at rest); single-point fixes cannot call a standstill but still
    # show a vehicle driving well beyond their limit
    moving_ok, judge_v, limit = gnss_still_speed(log, t, judge_max_mps=np.inf)
    judge_ok = moving_ok & (limit <= GNSS_JUDGE_MAX_MPS)
    moving_limit = gnss_moving_limit(judge_ok, limit)
    return _Speeds(
        ok, nu_f, None, speed_ok, speed, "the GNSS track", unusable, judge_ok, judge_v, limit, moving_ok,
        moving_limit, False,
    )  # fmt: skip


def _moving_start_warnings(m, t, by: str) -> list[str]:
    """What a log that starts on the move must say (``by``: the speed's source)."""
    out = [
        f"no static period at the start (the IMU or {by} shows motion from "
        f"t={t[0]:.2f} s): coarse alignment on the move from the GNSS course and {by}'s "
        "speed, then the filter; expect the first minutes to be less accurate"
    ]
    if getattr(m.initial, "heading_deg", None) is not None:
        out.append(
            "manifest initial.heading_deg is not used: the log starts on the move, its heading comes "
            "from the GNSS course"
        )
    return out


def _found_by(by: str, judge_ok, t, static_end: float) -> str:
    """How the standstill at the start was found (for the summary)."""
    k = t <= static_end
    share = float(np.mean(judge_ok[k])) if k.any() else 0.0
    if share >= 0.5:
        return f"{by}'s speed below its noise limit and the IMU's 1-s mean specific force and turn rate steady"
    return "the IMU's 1-s mean specific force and turn rate steady (no speed that can tell)"


def _alignment_warnings(al: Alignment) -> list[str]:
    """What the summary must say about a weak alignment."""
    from ldvsurvey.units import DEG_PER_RAD

    gc = al.gyrocompass_sigma_rad * DEG_PER_RAD
    if al.method == "gyrocompass" and al.observable and gc <= 1.0:
        return []
    if al.method == "gnss_course":
        return [
            f"the gyros cannot find north (gyrocompass heading σ {gc:.0f}°): heading from the GNSS course at "
            f"move-off (t={al.course_t_s:.1f} s) carried back by the gyros, σ "
            f"{al.heading_sigma_rad * DEG_PER_RAD:.2f}°"
        ]
    if al.method == "manifest":
        return []
    if not al.observable:
        return [
            f"heading not observable: the gyros cannot find north (gyrocompass heading σ {gc:.0f}°) and the "
            "log has no GNSS course to take it from (give manifest initial.heading_deg); the heading and "
            "everything that depends on it are unreliable"
        ]
    return [f"heading from gyrocompassing with σ {gc:.1f}°: no GNSS course to sharpen it"]


def c_bs_of(inp: NavInputs, alpha_rad: float = 0.0, beta_rad: float = 0.0):
    """C_b^s(η, α, β) per sample for a rotating IMU (None for a fixed one)."""
    if inp.eta_rad is None:
        return None
    return np.ascontiguousarray(c_bs(inp.eta_rad, alpha_rad, beta_rad))


def initial_attitude(inp: NavInputs, cbs) -> np.ndarray:
    """Coarse alignment over the static period (or on the move): C_s^n at the start of the log.

    Kept in ``inp.cache`` for the last ``cbs`` asked (the calibration and the navigation of a run
    align with the same one)."""
    hit = inp.cache.get("initial_attitude")
    if hit is not None and hit[0] is cbs:
        return hit[1].copy()
    c0 = _initial_attitude(inp, cbs)
    inp.cache["initial_attitude"] = (cbs, c0)
    return c0.copy()


def _initial_attitude(inp: NavInputs, cbs) -> np.ndarray:
    c_bn = inp.c_bn0
    if c_bn is None and inp.alignment is not None:  # a standstill whose heading came from elsewhere
        c_bn = inp.alignment.c_bn
    if c_bn is not None:
        return c_bn if cbs is None else c_bn @ cbs[0].T
    k = inp.t_s <= inp.static_end_s
    if k.sum() < 100:
        raise ParameterError("the static period holds fewer than 100 IMU samples", field="initial.static_s")
    c_bn = coarse_align(
        inp.dtheta_rad[k],
        inp.dvel_mps[k],
        inp.pos0[0],
        c_bs=None if cbs is None else cbs[k],
        turntable_rad=None if inp.eta_rad is None else inp.eta_rad[k],
    )
    return c_bn if cbs is None else c_bn @ cbs[0].T  # C_s^n = C_b^n (C_b^s)ᵀ


#: the fix qualities a navigation takes: RTK fixed, differential, RTK float, single point
NAV_FIXES = (4, 2, 5, 1)


def gnss_aid(log: DriveLog, fixes=NAV_FIXES, window=None) -> GnssAid | None:
    """GNSS antenna fixes of the accepted qualities for the filter.

    Parameters
    ----------
    log : DriveLog
        The parsed bundle.
    fixes : tuple of int
        The fix qualities taken (default: RTK fixed, differential, RTK float, single point).
    window : (float, float) or None
        ``t0, t1`` (s): only the fixes within it.

    Returns
    -------
    GnssAid or None
        Times (s), latitude, longitude (rad), ellipsoidal height (m), 1-σ horizontal and vertical
        (m) by quality (:data:`GNSS_SIGMA`) and the antenna lever arm (m, body RFU); None without a fix.
    """
    g = log.gnss
    if g is None:
        return None
    keep = np.isin(g.fix, fixes) & np.isfinite(g.lat_deg)
    if window is not None:
        keep &= (g.t_s >= window[0]) & (g.t_s <= window[1])
    if not keep.any():
        return None
    sig = np.array([GNSS_SIGMA.get(int(f), (np.nan, np.nan)) for f in g.fix[keep]])
    return GnssAid(
        g.t_s[keep],
        g.lat_deg[keep] * RAD_PER_DEG,
        g.lon_deg[keep] * RAD_PER_DEG,
        g.h_m[keep],
        sig[:, 0],
        sig[:, 1],
        tuple(log.manifest.gnss.lever_arm_m),
    )


def ldv_aid(inp: NavInputs, scale=None, pitch_rad=None, heading_rad=None, scale_up=1.0) -> LdvAid:
    """The filter's LDV aid at the IMU samples with the given (or the manifest's nominal) mounting and scale.

    Parameters
    ----------
    inp : NavInputs
        The loaded log.
    scale : float or None
        Scale factor K (dimensionless; None: nominal).
    pitch_rad, heading_rad : float or None
        Mounting pitch η_L and heading φ_L (rad; None: nominal).
    scale_up : float
        Scale of the up channel K_u (dimensionless).

    Returns
    -------
    LdvAid
        The usable flags, speeds (m/s), mounting, scales and the LDV lever arm (m, body RFU).
    """
    nom = inp.log.manifest.ldv.nominal
    return LdvAid(
        inp.ldv_ok,
        inp.nu_f_mps,
        inp.nu_u_mps,
        scale=nom.scale if scale is None else scale,
        pitch_rad=nom.pitch_deg * RAD_PER_DEG if pitch_rad is None else pitch_rad,
        heading_rad=nom.heading_deg * RAD_PER_DEG if heading_rad is None else heading_rad,
        scale_up=scale_up,
        lever_arm_m=tuple(inp.log.manifest.ldv.lever_arm_m),
    )


#: unmodelled gravity in the pipelines' filters: the vertical disturbance Δg (mGal) and the
#: horizontal deflection (mGal-equivalent), as accelerometer noise correlated over ~60 s (1 km at 15 m/s).
#: Without the vertical term, a few mGal of Δg bias the LDV pitch calibration by tens of arcseconds.
GRAVITY_NOISE_MGAL = 10.0
DOV_NOISE_MGAL = 1.0
#: prior σ of the z-gyro scale factor the pipelines estimate (300 ppm, the top of tactical-grade specs)
GYRO_SCALE_Z_SIGMA = 3e-4


#: initial σ of an alignment on the move: level from the specific force less the LDV acceleration
#: (Coriolis and mounting neglected), heading from a GNSS course over 1 s; velocity from the LDV
MOVING_ATT_SIGMA0_RAD = (0.3 * RAD_PER_DEG, 0.3 * RAD_PER_DEG, 3.0 * RAD_PER_DEG)
MOVING_VEL_SIGMA0_MPS = 0.3
MOVING_POS_SIGMA0_M = 3.0  #: a single-point fix carried back along the road


#: scale-factor 1-σ (ppm) of the gyros and accelerometers by grade when the manifest states none:
#: tactical units' datasheets give 100–500 ppm, consumer MEMS ±1–3 % sensitivity tolerance
GRADE_SCALE_PPM = {"tactical": 300.0, "mems": 10000.0}
#: correlation time (s) of the biases and scale factors of a MEMS or tactical unit whose manifest
#: gives none (as KF-GINS's configurations: one hour)
GRADE_CORRELATION_S = 3600.0


def standstill_velocity_scatter(inp: NavInputs, rate_hz: float) -> float:
    """How much the IMU's own velocity moves within one filter epoch while the vehicle stands:
    the RMS over the still intervals and axes of the running sum of the velocity increments (their
    mean over the interval removed) from each epoch's start, m/s. An idling engine's vibration shows
    here; white sensor noise gives σ_VRW·√(T/2). 0 without a still interval."""
    dv, t = inp.dvel_mps, inp.t_s
    decim = max(1, int(round(1.0 / (rate_hz * np.median(np.diff(t))))))
    sq, cnt = 0.0, 0
    for a, b in inp.still:
        seg = dv[(t >= a) & (t <= b)]
        m = len(seg) // decim
        if m < 2:
            continue
        d = (seg[: m * decim] - seg.mean(axis=0)).reshape(m, decim, 3)
        v = np.cumsum(d, axis=1)
        sq += float(np.sum(v**2))
        cnt += v.size
    return float(np.sqrt(sq / cnt)) if cnt else 0.0


def standstill_white_noise(inp: NavInputs) -> tuple[float, float]:
    """The white noise the IMU shows while the vehicle stands, vibration included: the largest axis's
    sample scatter of the angle and velocity increments (each still interval's mean removed) as an
    angle random walk (°/√h) and a velocity random walk (µg/√Hz), σ_increment/√Δt. (0, 0) without a
    still interval of 10 samples."""
    t = inp.t_s
    dt = float(np.median(np.diff(t)))
    sq_g, sq_a, cnt = np.zeros(3), np.zeros(3), 0
    for a, b in inp.still:
        k = (t >= a) & (t <= b)
        if k.sum() < 10:
            continue
        sq_g += np.sum((inp.dtheta_rad[k] - inp.dtheta_rad[k].mean(axis=0)) ** 2, axis=0)
        sq_a += np.sum((inp.dvel_mps[k] - inp.dvel_mps[k].mean(axis=0)) ** 2, axis=0)
        cnt += int(k.sum())
    if not cnt:
        return 0.0, 0.0
    s_g, s_a = np.sqrt(sq_g.max() / cnt), np.sqrt(sq_a.max() / cnt)
    return float(s_g / np.sqrt(dt) / RAD_PER_DEG * 60.0), float(s_a / np.sqrt(dt) / (G0_MPS2 * 1e-6))


def grade_error_model(
    inp: NavInputs, cfg: FilterConfig, noise: ImuNoise | None = None
) -> tuple[ImuNoise, FilterConfig]:
    """The IMU noise and filter configuration a log's IMU grade (:func:`~ldvsurvey.nav.filter.imu_grade`)
    needs. Navigation grade: as given. Tactical and MEMS: the three gyro and three accelerometer scale
    factors as Gauss–Markov states (σ from the manifest's ``gyro_scale_ppm``/``accel_scale_ppm`` or
    :data:`GRADE_SCALE_PPM`, correlation time the manifest's ``bias_correlation_s`` or
    :data:`GRADE_CORRELATION_S`) in place of the z-gyro one; biases Gauss–Markov with the manifest's
    instability, or with the turn-on σ itself over :data:`GRADE_CORRELATION_S` when it states none; the
    ZUPT's σ no tighter than the standstill's own velocity scatter
    (:func:`standstill_velocity_scatter`) and the ARW and VRW no smaller than the white noise the
    standstill shows (:func:`standstill_white_noise`: an engine's vibration, which a rate-sampling
    MEMS unit aliases into noise, is what the filter meets on the road, not the datasheet's figure).

    ``noise`` is the noise the run would otherwise take (None: the manifest's, ``inp.noise``; a start
    stage may have narrowed its gyro-bias prior to a standstill estimate); the grade and the
    defaults come from the manifest's figures."""
    man = inp.noise
    noise = man if noise is None else noise
    grade = imu_grade(man)
    if grade != "navigation":
        tau = man.bias_correlation_s or GRADE_CORRELATION_S
        arw, vrw = standstill_white_noise(inp)
        noise = dataclasses.replace(
            noise, gyro_arw_dprh=max(noise.gyro_arw_dprh, arw), accel_vrw_ug_rthz=max(noise.accel_vrw_ug_rthz, vrw)
        )
        if man.bias_correlation_s is None:
            noise = dataclasses.replace(
                noise,
                gyro_bias_instability_dph=man.gyro_bias_dph,
                accel_bias_instability_ug=man.accel_bias_ug,
                bias_correlation_s=tau,
            )
        cfg = dataclasses.replace(
            cfg,
            gyro_scale_z_sigma0=0.0,
            gyro_scale_sigma0=(man.gyro_scale_ppm or GRADE_SCALE_PPM[grade]) * 1e-6,
            accel_scale_sigma0=(man.accel_scale_ppm or GRADE_SCALE_PPM[grade]) * 1e-6,
            scale_correlation_s=tau,
            zupt_sigma_mps=max(cfg.zupt_sigma_mps, standstill_velocity_scatter(inp, cfg.rate_hz)),
        )
    return noise, cfg


def pipeline_cfg(**kw) -> FilterConfig:
    """The filter configuration the pipelines use (coarse-alignment σ, unmodelled gravity)."""
    base = dict(
        att_sigma0_rad=(0.05 * RAD_PER_DEG, 0.05 * RAD_PER_DEG, 2.0 * RAD_PER_DEG),
        gravity_noise_mgal=GRAVITY_NOISE_MGAL,
        dov_noise_mgal=DOV_NOISE_MGAL,
        gyro_scale_z_sigma0=GYRO_SCALE_Z_SIGMA,
    )
    base.update(kw)
    return FilterConfig(**base)


def run_navigation_filter(
    inp: NavInputs,
    *,
    cbs=None,
    ldv: LdvAid | None = None,
    gnss: GnssAid | None = None,
    cfg: FilterConfig | None = None,
    smooth: bool = True,
    zupt: bool = True,
    attitude_only: bool = False,
    specific_force: bool = True,
) -> NavSolution:
    """Coarse alignment (or the alignment on the move) then the filter and smoother on a loaded log,
    with the error model of the IMU's grade (:func:`grade_error_model`).

    Parameters
    ----------
    inp : NavInputs
        The loaded log (its ``gravity``, when set, enters the mechanization).
    cbs : ndarray or None
        (N, 3, 3) C_b^s of a rotating IMU, None for a fixed one.
    ldv, gnss : LdvAid, GnssAid or None
        The aids.
    cfg : FilterConfig or None
        The filter configuration (default: :func:`pipeline_cfg`).
    smooth : bool
        Run the RTS smoother after the forward filter.
    zupt : bool
        Zero-velocity updates in the still intervals.
    attitude_only, specific_force : bool
        What the solution keeps (see :func:`ldvsurvey.nav.filter.run_filter`).

    Returns
    -------
    NavSolution
        Attitude, velocity (m/s), position (rad, m), sensor biases and their 1-σ per sample.
    """
    c0 = initial_attitude(inp, cbs)
    if inp.gravity is not None and inp.v0_n is None:  # a static alignment levels to the plumb line
        from ldvsurvey.nav.attitude import skew
        from ldvsurvey.nav.dov import initial_misalignment

        c0 = (np.eye(3) + skew(initial_misalignment(inp.gravity[0][0], inp.gravity[1][0], inp.pos0[0]))) @ c0
    cfg = cfg or pipeline_cfg()
    v0 = np.zeros(3)
    noise, bias0 = _start_bias(inp, cfg)
    al = inp.alignment
    if al is not None and inp.v0_n is None and al.heading_sigma_rad > cfg.att_sigma0_rad[2]:
        # a heading from the course (or weaker): the prior carries its σ
        s_att = cfg.att_sigma0_rad
        cfg = dataclasses.replace(cfg, att_sigma0_rad=(s_att[0], s_att[1], min(al.heading_sigma_rad, np.pi)))
    noise, cfg = grade_error_model(inp, cfg, noise)
    if inp.v0_n is not None:  # aligned on the move: a coarser start
        v0 = inp.v0_n
        cfg = dataclasses.replace(
            cfg,
            att_sigma0_rad=MOVING_ATT_SIGMA0_RAD,
            vel_sigma0_mps=MOVING_VEL_SIGMA0_MPS,
            pos_sigma0_m=max(cfg.pos_sigma0_m, MOVING_POS_SIGMA0_M),
        )
    return run_filter(
        ImuData(inp.t_s, inp.dtheta_rad, inp.dvel_mps, cbs),
        NavStart(q_from_c(c0), v0, inp.pos0, gyro_bias_rps=bias0),
        noise,
        cfg,
        zupt_intervals=inp.still if zupt else [],
        ldv=ldv,
        gnss=gnss,
        smooth=smooth,
        gravity=inp.gravity,
        attitude_only=attitude_only,
        specific_force=specific_force,
    )


def _start_bias(inp: NavInputs, cfg: FilterConfig):
    """The IMU noise and initial gyro bias (rad/s) a run starts from.

    A start the gyros could not gyrocompass (a heading from the course, the manifest, or none: a
    gyrocompass that is not observable) starts from the standstill's gyro-bias estimate, and the
    filter's gyro-bias prior is that estimate's σ (never below the manifest's bias instability, nor
    below 5 % of its bias: the turn-on bias may move on moving off). A gyrocompassed start keeps the
    manifest's prior and a zero bias (the estimate there is the gyrocompass's own residual)."""
    al = inp.alignment
    if (
        al is None
        or al.method == "moving_start"
        or (al.method == "gyrocompass" and al.observable)
        or al.gyro_bias_rps is None
        or inp.eta_rad is not None
    ):
        return inp.noise, None
    if cfg.bias_instability > 0:  # a relative random walk scales with the prior: keep the manifest's
        return inp.noise, al.gyro_bias_rps
    from ldvsurvey.units import DPH_PER_RPS

    n = inp.noise
    floor = max(n.gyro_bias_instability_dph or 0.0, 0.05 * n.gyro_bias_dph)
    est = float(np.max(al.gyro_bias_sigma_rps)) * DPH_PER_RPS
    return dataclasses.replace(n, gyro_bias_dph=min(n.gyro_bias_dph, max(est, floor))), al.gyro_bias_rps


def gnss_ins(inp: NavInputs, cbs=None) -> NavSolution:
    """The GNSS-aided INS (every fix weighted by its quality, no LDV), computed once per run."""
    key = ("gnss_ins", None if cbs is None else id(cbs))
    if key not in inp.cache:
        inp.cache[key] = run_navigation_filter(inp, cbs=cbs, gnss=gnss_aid(inp.log))
    return inp.cache[key]


def antenna_to_imu_h(log: DriveLog, c_bn_at_fix: np.ndarray) -> np.ndarray:
    """Ellipsoidal heights of the GNSS fixes brought from the antenna to the IMU centre (m)."""
    lever = np.asarray(log.manifest.gnss.lever_arm_m, float)
    return log.gnss.h_m - (c_bn_at_fix @ lever)[:, 2]


def attitude_at(sol: NavSolution, t_s: np.ndarray, c_bn_all: np.ndarray | None = None) -> np.ndarray:
    """C_b^n at arbitrary times: the quaternions of the two samples around each time (the second
    one's sign made continuous with the first) interpolated linearly, then normalised (times
    outside the solution take its first or last sample).

    Parameters
    ----------
    sol : NavSolution
        The navigation.
    t_s : ndarray
        (M,) times (s).
    c_bn_all : ndarray or None
        The solution's C_b^n at every sample when already at hand (else computed at the
        neighbouring samples only).

    Returns
    -------
    ndarray
        (M, 3, 3) C_b^n at ``t_s``.
    """
    t = sol.t_s
    ts = np.asarray(t_s, float)
    k = np.clip(np.searchsorted(t, ts, side="right") - 1, 0, len(t) - 2)
    ca = sol.c_bn(k) if c_bn_all is None else c_bn_all[k]
    cb = sol.c_bn(k + 1) if c_bn_all is None else c_bn_all[k + 1]
    qa, qb = q_from_c(ca), q_from_c(cb)
    qb *= np.where(np.sum(qa * qb, axis=1) < 0, -1.0, 1.0)[:, None]
    w = np.clip((ts - t[k]) / (t[k + 1] - t[k]), 0.0, 1.0)[:, None]
    return c_from_q(qa + w * (qb - qa))
