"""From a parsed bundle to navigation inputs: aids, static periods, alignment, navigation runs.

Shared by the pipelines. Knows the bundle model and the numerical core, nothing of storage.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ldvsurvey.errors import ParameterError
from ldvsurvey.io.drivelog import DriveLog
from ldvsurvey.io.imutime import check_no_long_gaps
from ldvsurvey.nav.align import coarse_align
from ldvsurvey.nav.attitude import c_bs, c_from_q, q_from_c
from ldvsurvey.nav.earth import radii
from ldvsurvey.nav.filter import FilterConfig, GnssAid, ImuNoise, LdvAid, NavSolution, run_filter

RAD = np.pi / 180.0
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

    def __post_init__(self):
        if self.cache is None:
            self.cache = {}
        if self.warnings is None:
            self.warnings = []


def _interp_ldv(log: DriveLog, t_imu: np.ndarray):
    ldv = log.ldv
    t = ldv.t_s
    ok_l = np.ones(len(t), bool)
    mq = log.manifest.ldv.min_quality
    if ldv.quality is not None and mq is not None:
        ok_l = ldv.quality >= mq
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


#: still: LDV speed below this (m/s)
STILL_SPEED_MPS = 0.03
#: still: the 1-s mean specific force in the body frame stays this close to its still value (m/s²)
#: and the body turns slower than this (rad/s); a vehicle cannot move off without either
STILL_ACCEL_MPS2 = 0.1
STILL_RATE_RPS = 0.01


def _body_signals(t, dtheta, dvel, eta, window_s: float = 1.0):
    """1-s running means of the specific force in the body frame (m/s², turntable angle removed
    with α = β = 0) and of the body turn rate about the turntable axis (rad/s)."""
    from scipy.ndimage import uniform_filter1d

    dt = np.diff(t, prepend=t[0] - (t[1] - t[0]))
    f = dvel / dt[:, None]
    wz = dtheta[:, 2] / dt
    if eta is not None:
        c, s = np.cos(eta), np.sin(eta)
        f = np.column_stack([c * f[:, 0] - s * f[:, 1], s * f[:, 0] + c * f[:, 1], f[:, 2]])
        wz = wz - np.diff(eta, prepend=eta[0]) / dt
    w = max(1, int(round(window_s / np.median(dt))))
    return uniform_filter1d(f, w, axis=0, mode="nearest"), uniform_filter1d(wz, w, mode="nearest")


def _quiet(f_b, w_z, ref_idx, f_all=None, w_all=None):
    """Samples whose body specific force and turn rate stay at the still values at ``ref_idx``
    (indices into ``f_all``/``w_all``, by default the same arrays)."""
    f_all = f_b if f_all is None else f_all
    w_all = w_z if w_all is None else w_all
    f_ref = np.median(f_all[ref_idx], axis=0)
    w_ref = np.median(w_all[ref_idx])
    return (np.linalg.norm(f_b - f_ref, axis=1) < STILL_ACCEL_MPS2) & (np.abs(w_z - w_ref) < STILL_RATE_RPS)


def _still_intervals(t, speed, ok, min_len_s=3.0, thresh=STILL_SPEED_MPS, f_b=None, w_z=None):
    """Intervals (s) where the vehicle stands still for at least ``min_len_s``.

    Still where the usable LDV speed (1-s running mean) is below ``thresh``. Stretches where the LDV is unusable
    (samples below min_quality carry garbage, not zero) do not end a stop: a stretch next to a
    still LDV sample counts as still when the IMU shows neither acceleration nor turning in it
    (``f_b``, ``w_z`` from :func:`_body_signals`), since a vehicle cannot start or stop without.
    """
    from scipy.ndimage import uniform_filter1d

    # the 1-s running mean: LDV noise of a few cm/s must not chop a stop into slivers
    w = max(1, int(round(1.0 / np.median(np.diff(t)))))
    still = ok & (np.abs(uniform_filter1d(speed, w, mode="nearest")) < thresh)
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
    force and turn rate, and the usable LDV shows no speed for ``min_moving_s`` in a row."""
    n0 = max(10, int(round(2.0 / np.median(np.diff(t)))))
    quiet = _quiet(f_b, w_z, np.arange(min(n0, len(t))))
    k_imu = int(np.argmin(quiet)) if not quiet.all() else len(t)
    mv = ok & (np.abs(speed) >= STILL_SPEED_MPS)
    run = max(1, int(round(min_moving_s / np.median(np.diff(t)))))
    from scipy.ndimage import minimum_filter1d

    sustained = minimum_filter1d(mv.astype(np.uint8), run, mode="constant", cval=0, origin=-(run // 2)) > 0
    k_ldv = int(np.argmax(sustained)) if sustained.any() else len(t)
    k = min(k_imu, k_ldv)
    # both tests fire about a second into a smooth start (0.1 m/s², 0.03 m/s): keep 2 s off it
    return float(t[max(0, k - 1)]) - 2.0


def nav_inputs(log: DriveLog) -> NavInputs:
    """Prepare the navigation inputs of a bundle (detects still periods, finds the start position)."""
    imu = log.imu
    check_no_long_gaps(imu.long_gaps)  # never integrate across a gap
    t = imu.t_s
    m = log.manifest
    eta = np.unwrap(np.radians(imu.turntable_deg)) if imu.turntable_deg is not None else None
    ok, nu_f, nu_u = _interp_ldv(log, t)
    f_b, w_z = _body_signals(t, imu.dtheta_rad, imu.dvel_mps, eta)
    still = _still_intervals(t, nu_f, ok, f_b=f_b, w_z=w_z)
    static_s = m.initial.static_s
    if static_s is None:
        static_end = detect_static_start(t, f_b, w_z, nu_f, ok)
        if static_end - t[0] < 30.0:
            raise ParameterError(f"no static period of at least 30 s at the start: the IMU or the LDV shows motion "
                                 f"from t={static_end + 2.0:.2f} s (log start {t[0]:.2f} s); the alignment needs the "
                                 "vehicle standing still first (manifest initial.static_s not given)",
                                 file="imu.csv", field="initial.static_s")
    else:
        static_end = float(t[0] + static_s)
        if static_s < 30.0:
            raise ParameterError("the static period is shorter than 30 s: too short to align",
                                 file="manifest.json", field="initial.static_s")
    still = [(a, b) for a, b in still if b > static_end + 1.0 or a > static_end]
    still = [(float(t[0]), static_end)] + [(max(a, static_end), b) for a, b in still]
    warnings = []
    pos0 = initial_position(log, t, static_end, eta, warnings)
    return NavInputs(log=log, t_s=t, dtheta_rad=imu.dtheta_rad, dvel_mps=imu.dvel_mps, eta_rad=eta,
                     ldv_ok=ok, nu_f_mps=nu_f, nu_u_mps=nu_u, still=still, static_end_s=static_end,
                     pos0=pos0, noise=ImuNoise.from_manifest(m.imu))


#: fix qualities from best to worst for the start position
FIX_RANK = (4, 5, 2, 1)


def initial_position(log: DriveLog, t, static_end, eta=None, warnings=None) -> np.ndarray:
    """Start position of the IMU centre: lat, lon (rad), h (m).

    The manifest's ``initial`` position when given (authoritative). Otherwise the GNSS fixes of
    the static period at the start, of the best fix quality present there (4, 5, 2, 1 in this
    order), averaged, brought from the antenna to the IMU centre through the lever arm
    (``gnss.lever_arm_m``, body RFU) and the coarse-aligned attitude of the static period.
    Without a fix in the static period, the first fix of the best quality in the log is used with
    a warning (the vehicle may have moved by then).
    """
    m = log.manifest
    if m.initial.lat_deg is not None and m.initial.lon_deg is not None and m.initial.h_m is not None:
        return np.array([m.initial.lat_deg * RAD, m.initial.lon_deg * RAD, m.initial.h_m])
    g = log.gnss
    good = None if g is None else (g.fix > 0) & np.isfinite(g.lat_deg)
    if g is None or not good.any():
        raise ParameterError("no start position: give manifest initial.lat_deg/lon_deg/h_m or a GNSS fix",
                             file="manifest.json", field="initial")
    in_static = good & (g.t_s >= t[0] - 0.5) & (g.t_s <= static_end)
    pool = in_static if in_static.any() else good
    best = next(q for q in FIX_RANK + tuple(np.unique(g.fix[pool])) if np.any(pool & (g.fix == q)))
    k = np.flatnonzero(pool & (g.fix == best))
    if not in_static.any():
        k = k[:1]
        if warnings is not None:
            warnings.append(f"no GNSS fix during the static period: the start position is the first fix of "
                            f"quality {best} at t={g.t_s[k[0]]:.1f} s")
    lat = float(np.mean(g.lat_deg[k])) * RAD
    lon = float(np.mean(g.lon_deg[k])) * RAD
    h = float(np.mean(g.h_m[k]))
    lever = np.asarray(m.gnss.lever_arm_m, float)
    ks = t <= static_end
    if np.count_nonzero(ks) >= 100:
        imu = log.imu
        cbs = None if eta is None else c_bs(eta[ks])
        c_bn = coarse_align(imu.dtheta_rad[ks], imu.dvel_mps[ks], lat, c_bs=cbs,
                            turntable_rad=None if eta is None else eta[ks])
        lev_n = c_bn @ lever  # ENU
    else:
        lev_n = np.array([0.0, 0.0, lever[2]])
    rm, rn = radii(lat)
    return np.array([lat - lev_n[1] / (rm + h), lon - lev_n[0] / ((rn + h) * np.cos(lat)), h - lev_n[2]])


def c_bs_of(inp: NavInputs, alpha_rad: float = 0.0, beta_rad: float = 0.0):
    """C_b^s(η, α, β) per sample for a rotating IMU (None for a fixed one)."""
    if inp.eta_rad is None:
        return None
    return np.ascontiguousarray(c_bs(inp.eta_rad, alpha_rad, beta_rad))


def initial_attitude(inp: NavInputs, cbs) -> np.ndarray:
    """Coarse alignment over the static period: C_s^n at the start of the log."""
    k = inp.t_s <= inp.static_end_s
    if k.sum() < 100:
        raise ParameterError("the static period holds fewer than 100 IMU samples", field="initial.static_s")
    c_bn = coarse_align(inp.dtheta_rad[k], inp.dvel_mps[k], inp.pos0[0],
                        c_bs=None if cbs is None else cbs[k],
                        turntable_rad=None if inp.eta_rad is None else inp.eta_rad[k])
    return c_bn if cbs is None else c_bn @ cbs[0].T  # C_s^n = C_b^n (C_b^s)ᵀ


def gnss_aid(log: DriveLog, fixes=(4, 2, 5, 1), window=None) -> GnssAid | None:
    """GNSS antenna fixes of the accepted qualities (optionally within a time window)."""
    g = log.gnss
    if g is None:
        return None
    keep = np.isin(g.fix, fixes) & np.isfinite(g.lat_deg)
    if window is not None:
        keep &= (g.t_s >= window[0]) & (g.t_s <= window[1])
    if not keep.any():
        return None
    sig = np.array([GNSS_SIGMA.get(int(f), (np.nan, np.nan)) for f in g.fix[keep]])
    return GnssAid(g.t_s[keep], g.lat_deg[keep] * RAD, g.lon_deg[keep] * RAD, g.h_m[keep], sig[:, 0], sig[:, 1],
                   tuple(log.manifest.gnss.lever_arm_m))


def ldv_aid(inp: NavInputs, scale=None, pitch_rad=None, heading_rad=None, scale_up=1.0) -> LdvAid:
    """LDV aid with the given (or the manifest's nominal) mounting and scale."""
    nom = inp.log.manifest.ldv.nominal
    return LdvAid(inp.ldv_ok, inp.nu_f_mps, inp.nu_u_mps,
                  scale=nom.scale if scale is None else scale,
                  pitch_rad=nom.pitch_deg * RAD if pitch_rad is None else pitch_rad,
                  heading_rad=nom.heading_deg * RAD if heading_rad is None else heading_rad,
                  scale_up=scale_up, lever_arm_m=tuple(inp.log.manifest.ldv.lever_arm_m))


#: unmodelled gravity in the pipelines' filters: the vertical disturbance Δg (mGal) and the
#: horizontal deflection (mGal-equivalent), as accelerometer noise correlated over ~60 s (1 km at 15 m/s).
#: Without the vertical term, a few mGal of Δg bias the LDV pitch calibration by tens of arcseconds.
GRAVITY_NOISE_MGAL = 10.0
DOV_NOISE_MGAL = 1.0


def pipeline_cfg(**kw) -> FilterConfig:
    """The filter configuration the pipelines use (coarse-alignment σ, unmodelled gravity)."""
    base = dict(att_sigma0_rad=(0.05 * RAD, 0.05 * RAD, 2.0 * RAD), gravity_noise_mgal=GRAVITY_NOISE_MGAL,
                dov_noise_mgal=DOV_NOISE_MGAL)
    base.update(kw)
    return FilterConfig(**base)


def navigate(inp: NavInputs, *, cbs=None, ldv: LdvAid | None = None, gnss: GnssAid | None = None,
             cfg: FilterConfig | None = None, smooth: bool = True, zupt: bool = True) -> NavSolution:
    """Coarse alignment then the filter (ZUPT in still periods) with the given aids."""
    q0 = q_from_c(initial_attitude(inp, cbs))
    cfg = cfg or pipeline_cfg()
    return run_filter(inp.t_s, inp.dtheta_rad, inp.dvel_mps, q0, np.zeros(3), inp.pos0, inp.noise, cfg,
                      c_bs=cbs, zupt_intervals=inp.still if zupt else [], ldv=ldv, gnss=gnss, smooth=smooth)


def gnss_ins(inp: NavInputs, cbs=None) -> NavSolution:
    """The GNSS-aided INS (every fix weighted by its quality, no LDV), computed once per run."""
    key = ("gnss_ins", None if cbs is None else id(cbs))
    if key not in inp.cache:
        inp.cache[key] = navigate(inp, cbs=cbs, gnss=gnss_aid(inp.log))
    return inp.cache[key]


def antenna_to_imu_h(log: DriveLog, c_bn_at_fix: np.ndarray) -> np.ndarray:
    """Ellipsoidal heights of the GNSS fixes brought from the antenna to the IMU centre (m)."""
    lever = np.asarray(log.manifest.gnss.lever_arm_m, float)
    return log.gnss.h_m - (c_bn_at_fix @ lever)[:, 2]


def attitude_at(sol: NavSolution, t_s: np.ndarray, c_bn_all: np.ndarray | None = None) -> np.ndarray:
    """C_b^n at arbitrary times (nearest-neighbour quaternion interpolation, then normalised mix)."""
    c_all = sol.c_bn() if c_bn_all is None else c_bn_all
    q = q_from_c(c_all)
    # keep the quaternion sign continuous before interpolating
    flip = np.cumprod(np.where(np.sum(q[1:] * q[:-1], axis=1) < 0, -1.0, 1.0))
    q[1:] *= flip[:, None]
    qi = np.column_stack([np.interp(t_s, sol.t_s, q[:, i]) for i in range(4)])
    return c_from_q(qi)


def local_metres(lat0, lon0, lat, lon):
    """Small-area East/North offsets (m) from a reference (rad)."""
    rm, rn = radii(lat0)
    return (lon - lon0) * rn * np.cos(lat0), (lat - lat0) * rm
