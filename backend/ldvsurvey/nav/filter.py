"""Error-state Kalman filter (15 states, optionally + LDV calibration and scale-factor states) with an
RTS smoother.

Smoothing a closed-loop filter: let e_j be the error of the post-feedback nominal at epoch j
and dx_j the correction fed back at j. The pre-update error at j is e_j + dx_j, and the
forward prediction of it from e_{j−1} = 0 is 0, so the RTS recursion becomes
x_s(j) = A_j (x_s(j+1) + dx_{j+1}), A_j = P⁺_j Φ_{j+1}ᵀ (P⁻_{j+1})⁻¹, P_s as usual.
Between epochs the smoothed error is interpolated from x_s(j−1) to x_s(j) + dx_j.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ldvsurvey.nav import kfloop
from ldvsurvey.nav.attitude import c_from_q
from ldvsurvey.nav.earth import ARCSEC, MGAL
from ldvsurvey.nav.errmodel import IX_AUG, IX_EPS, IX_NABLA, N_BASE
from ldvsurvey.units import RAD_PER_DEG

AUG_NAMES = ("scale", "pitch", "heading", "scale_up", "pitch_k")
#: the manifest's optional ``imu`` keys beyond the schema's (see :meth:`ImuNoise.from_manifest`)
EXTRA_KEYS = (
    "gyro_bias_instability_dph",
    "accel_bias_instability_ug",
    "bias_correlation_s",
    "gyro_scale_ppm",
    "accel_scale_ppm",
)


@dataclass
class ImuNoise:
    """IMU error magnitudes.

    gyro_bias_dph (deg/h), accel_bias_ug (µg), gyro_arw_dprh (deg/√h), accel_vrw_ug_rthz (µg/√Hz).
    """

    gyro_bias_dph: float = 0.01
    accel_bias_ug: float = 50.0
    gyro_arw_dprh: float = 0.001
    accel_vrw_ug_rthz: float = 10.0
    #: in-run bias instability: stationary σ of a first-order Gauss–Markov bias (deg/h, µg) and its
    #: correlation time (s); None: the biases are random constants
    gyro_bias_instability_dph: float | None = None
    accel_bias_instability_ug: float | None = None
    bias_correlation_s: float | None = None
    #: 1-σ of the gyro and accelerometer scale factors (ppm) when the manifest states them (None: the
    #: grade's default, see :func:`imu_grade`)
    gyro_scale_ppm: float | None = None
    accel_scale_ppm: float | None = None

    @classmethod
    def from_manifest(cls, imu) -> ImuNoise:
        """From the manifest's ``imu`` block, including the optional (spec-allowed extra) keys
        ``gyro_bias_instability_dph``, ``accel_bias_instability_ug``, ``bias_correlation_s``,
        ``gyro_scale_ppm`` and ``accel_scale_ppm`` (scale-factor 1-σ)."""
        from ldvsurvey.errors import ParameterError

        d = cls()
        extra = {}
        for key in EXTRA_KEYS:
            val = getattr(imu, key, None)
            if val is None:
                continue
            if (
                isinstance(val, bool)
                or not isinstance(val, (int, float))
                or not np.isfinite(val)
                or val < 0
                or (key == "bias_correlation_s" and val <= 0)
            ):
                raise ParameterError(
                    f"expected a non-negative number (positive for the correlation time), got {val!r}",
                    file="manifest.json",
                    field=f"imu.{key}",
                )
            extra[key] = float(val)
        if (
            set(extra) & {"gyro_bias_instability_dph", "accel_bias_instability_ug"}
            and "bias_correlation_s" not in extra
        ):
            raise ParameterError(
                "a bias instability needs its correlation time imu.bias_correlation_s",
                file="manifest.json",
                field="imu.bias_correlation_s",
            )
        return cls(
            gyro_bias_dph=imu.gyro_bias_dph if imu.gyro_bias_dph is not None else d.gyro_bias_dph,
            accel_bias_ug=imu.accel_bias_ug if imu.accel_bias_ug is not None else d.accel_bias_ug,
            gyro_arw_dprh=imu.gyro_arw_deg_per_rth if imu.gyro_arw_deg_per_rth is not None else d.gyro_arw_dprh,
            accel_vrw_ug_rthz=(
                imu.accel_noise_ug_per_rthz if imu.accel_noise_ug_per_rthz is not None else d.accel_vrw_ug_rthz
            ),
            **extra,
        )

    def gauss_markov(self):
        """(1/τ per bias state (6,), 1/s; driving PSD 2σ²/τ per bias state (6,)) of the instability."""
        inv = np.zeros(6)
        q = np.zeros(6)
        tau = self.bias_correlation_s
        if tau:
            sg = (self.gyro_bias_instability_dph or 0.0) * RAD_PER_DEG / 3600.0
            sa = (self.accel_bias_instability_ug or 0.0) * 9.80665e-6
            inv[:] = 1.0 / tau
            q[:3], q[3:] = 2 * sg**2 / tau, 2 * sa**2 / tau
        return inv, q

    @property
    def gyro_bias_rps(self) -> float:
        """Gyro bias 1-σ, rad/s."""
        return self.gyro_bias_dph * RAD_PER_DEG / 3600.0

    @property
    def accel_bias_mps2(self) -> float:
        """Accelerometer bias 1-σ, m/s²."""
        return self.accel_bias_ug * 9.80665e-6

    @property
    def arw_psd(self) -> float:
        """Angle random walk PSD, rad²/s."""
        return (self.gyro_arw_dprh * RAD_PER_DEG / 60.0) ** 2

    @property
    def vrw_psd(self) -> float:
        """Velocity random walk PSD, (m/s)²/s."""
        return (self.accel_vrw_ug_rthz * 9.80665e-6) ** 2


#: turn-on gyro bias 1-σ (°/h) below which an IMU is of navigation grade, and below which of tactical
#: grade (above: MEMS); ring-laser and good fibre-optic gyros sit near 0.01 °/h, tactical units at
#: 0.5–10 °/h, consumer MEMS at 100–1000 °/h
GRADE_LIMITS_DPH = (0.1, 20.0)


def imu_grade(noise: ImuNoise) -> str:
    """The IMU's grade from its stated turn-on gyro bias: ``"navigation"``, ``"tactical"`` or ``"mems"``
    (limits :data:`GRADE_LIMITS_DPH`)."""
    if noise.gyro_bias_dph < GRADE_LIMITS_DPH[0]:
        return "navigation"
    return "tactical" if noise.gyro_bias_dph < GRADE_LIMITS_DPH[1] else "mems"


@dataclass
class FilterConfig:
    """Tuning. Angles in rad, velocities in m/s, positions in m."""

    rate_hz: float = 10.0  #: filter epoch rate
    att_sigma0_rad: tuple[float, float, float] = (20 * ARCSEC, 20 * ARCSEC, 0.5 * RAD_PER_DEG)
    vel_sigma0_mps: float = 0.05
    pos_sigma0_m: float = 1.0
    zupt_sigma_mps: float = 0.003
    ldv_sigma_mps: tuple[float, float, float] = (0.02, 0.02, 0.02)  #: per LDV sample, E N U
    gate_sigma: float = 6.0  #: innovation gate (0 = off)
    gravity_noise_mgal: float = 0.0  #: unmodelled vertical gravity disturbance Δg, σ as white accel noise
    dov_noise_mgal: float = 0.0  #: unmodelled horizontal gravity (deflection of the vertical), σ
    gravity_corr_s: float = 60.0  #: their correlation time, for the PSD 2σ²τ
    bias_instability: float = 0.0  #: relative random walk of biases per √h (0 = constants)
    #: prior σ of the z-gyro scale factor state (0: no state). With a rotating IMU the turntable's
    #: turns (and the vehicle's) make it observable; unmodelled, 200 ppm × 180° is 2′ of heading
    gyro_scale_z_sigma0: float = 0.0
    #: prior σ (dimensionless) of the three gyro and three accelerometer scale factors (both 0: no such
    #: states; not with gyro_scale_z_sigma0): a MEMS or tactical unit's, see :func:`imu_grade`
    gyro_scale_sigma0: float = 0.0
    accel_scale_sigma0: float = 0.0
    #: their first-order Gauss–Markov correlation time (s), driving PSD 2σ²/τ (None: random constants)
    scale_correlation_s: float | None = None
    ldv_aug: tuple[str, ...] = ()  #: subset of AUG_NAMES to estimate
    #: initial σ of the LDV states: inverse scale s = 1/K (≈ relative scale), angles in rad,
    #: pitch compliance k_η in rad per m/s² (0.01 ≈ 5.6° per g, twice the softest car suspension)
    ldv_aug_sigma0: dict = field(
        default_factory=lambda: {
            "scale": 0.01,
            "pitch": 1 * RAD_PER_DEG,
            "heading": 1 * RAD_PER_DEG,
            "scale_up": 0.01,
            "pitch_k": 0.01,
        }
    )


@dataclass
class LdvAid:
    """LDV samples at the IMU times. nu_f/nu_u: measured speeds (m/s) along the head's forward/up axes.

    The travel direction the LDV sees is pitched by pitch_rad + pitch_k_rad_per_mps2 · accel_fwd_mps2
    (the vehicle's squat/dive under longitudinal acceleration; see :func:`forward_accel_mps2`).
    """

    ok: np.ndarray  # (N,) bool
    nu_f_mps: np.ndarray
    nu_u_mps: np.ndarray | None = None
    scale: float = 1.0
    pitch_rad: float = 0.0
    heading_rad: float = 0.0
    scale_up: float = 1.0
    lever_arm_m: tuple = (0.0, 0.0, 0.0)
    accel_fwd_mps2: np.ndarray | None = None  #: (N,) forward acceleration along the travel, m/s²
    pitch_k_rad_per_mps2: float = 0.0  #: pitch compliance k_η, rad per m/s²


@dataclass
class GnssAid:
    """GNSS antenna fixes with their 1-σ (horizontal, vertical) in m."""

    t_s: np.ndarray
    lat_rad: np.ndarray
    lon_rad: np.ndarray
    h_m: np.ndarray
    sigma_h_m: np.ndarray
    sigma_v_m: np.ndarray
    lever_arm_m: tuple = (0.0, 0.0, 0.0)


@dataclass
class ImuData:
    """The IMU's increments over the intervals ending at ``t_s``, in the sensor frame s."""

    t_s: np.ndarray  #: (N,) end times of the increments, s; the first interval as long as the second
    dtheta_rad: np.ndarray  #: (N, 3) angle increments, rad
    dvel_mps: np.ndarray  #: (N, 3) velocity increments, m/s
    #: (N, 3, 3) C_b^s per sample for a rotating IMU (None: s = b); C_b^n = C_s^n C_b^s
    c_bs: np.ndarray | None = None


@dataclass
class NavStart:
    """The navigation state at the start of the first interval."""

    q_sn: np.ndarray  #: (4,) quaternion [w, x, y, z] of C_s^n
    v_n_mps: np.ndarray  #: (3,) velocity ENU, m/s
    pos_rad_m: np.ndarray  #: (3,) lat (rad), lon (rad), h (m)
    gyro_bias_rps: np.ndarray | None = None  #: (3,) initial gyro bias estimate, rad/s (None: zero)
    accel_bias_mps2: np.ndarray | None = None  #: (3,) initial accelerometer bias estimate, m/s² (None: zero)


@dataclass
class NavSolution:
    """Navigation result at the IMU sample times (forward, or smoothed when ``smoothed``)."""

    t_s: np.ndarray
    q_sn: np.ndarray  # (N, 4)
    v_n: np.ndarray  # (N, 3)
    pos: np.ndarray  # (N, 3) lat_rad, lon_rad, h_m
    c_bs: np.ndarray | None
    smoothed: bool
    ldv_params: dict  # name -> (value, sigma)
    gyro_bias_rps: np.ndarray
    accel_bias_mps2: np.ndarray
    epoch_t_s: np.ndarray
    epoch_sigma: np.ndarray  # (M+1, n) 1-σ of all states
    normalized_innovations: np.ndarray  # (M+1, 9)
    rejected: dict
    epoch_index: np.ndarray = None  # (M+1,) sample index of each epoch (−1: before the first sample)
    epoch_bias: np.ndarray = None  # (M+1, 6) gyro (rad/s) and accel (m/s²) bias estimates
    epoch_cov: np.ndarray | None = None  # (M+1, n, n) when keep_cov
    #: up component of the specific force (m/s²) over each IMU interval (t_{k−1}, t_k], from the very
    #: mechanization step the velocity integrates (C_s^n Δv with rotation/sculling and n-frame rotation
    #: corrections, accelerometer-bias estimate removed; smoothed attitude/bias when ``smoothed``), / Δt
    f_u_mps2: np.ndarray | None = None
    #: (C_s^n b̂_a)_U, m/s²: the accelerometer-bias correction removed from f_u_mps2 (add it back for raw f_U)
    f_u_bias_mps2: np.ndarray | None = None
    #: (estimate, 1-σ) of the z-gyro scale factor (dimensionless) when it is a state
    gyro_scale_z: tuple | None = None
    #: {"gyro": (estimate (3,), 1-σ (3,)), "accel": (…)} of the sensor-axis scale factors (dimensionless,
    #: measured = (1 + s) true) when they are states, at the last (forward) or first (smoothed) epoch
    scale_factors: dict | None = None

    @property
    def f_t_s(self) -> np.ndarray:
        """Time tags of f_u_mps2: interval mid-times (t_{k−1} + t_k)/2, s (the first interval as long
        as the second)."""
        t = self.t_s
        return t - 0.5 * np.diff(t, prepend=2 * t[0] - t[1])

    def sigma_at(self, idx=slice(None)) -> np.ndarray:
        """1-σ (K, 9) at the samples ``idx`` (index, slice or mask): φ E/N/U (rad), δv (m/s),
        δp E/N/U (m), interpolated linearly in time between the filter epochs."""
        t = self.t_s[idx]
        return np.column_stack([np.interp(t, self.epoch_t_s, self.epoch_sigma[:, i]) for i in range(9)])

    @property
    def sigma(self) -> np.ndarray:
        """:meth:`sigma_at` every sample, (N, 9) (computed on each access: index with sigma_at)."""
        return self.sigma_at()

    def c_bn(self, idx=slice(None)) -> np.ndarray:
        """Body attitude C_b^n at the samples ``idx`` (all by default; C_s^n C_b^s for a rotating IMU)."""
        c = c_from_q(self.q_sn[idx])
        return c if self.c_bs is None else c @ self.c_bs[idx]


def ldv_spikes(v_mps, ok, threshold_mps: float = 0.3, half_width: int = 4) -> np.ndarray:
    """Samples flagged usable whose speed jumps away from its neighbours: |v − median of the
    2·half_width+1 usable samples around it| > threshold (0.3 m/s: a car cannot change speed by
    that much within a few LDV samples, and it is > 10σ of the LDV noise). Returns a bool mask.

    Samples below min_quality (``ok`` False) carry garbage and take no part in the median.
    """
    from scipy.ndimage import median_filter

    v = np.asarray(v_mps, float)
    ok = np.asarray(ok, bool)
    out = np.zeros(len(v), bool)
    idx = np.flatnonzero(ok & np.isfinite(v))
    if len(idx) < 2 * half_width + 1:
        return out
    med = median_filter(v[idx], size=2 * half_width + 1, mode="nearest")
    out[idx] = np.abs(v[idx] - med) > threshold_mps
    return out


def forward_accel_mps2(t_s, nu_f_mps, ok, window_s: float = 0.5) -> np.ndarray:
    """Forward acceleration (m/s²) along the travel from the LDV speed: the usable samples bridged
    linearly, a centred moving average over ``window_s``, then the central difference over ``window_s``.

    Parameters
    ----------
    t_s : (N,) s. nu_f_mps : (N,) measured forward speed, m/s. ok : (N,) usable samples.
    """
    t = np.asarray(t_s, float)
    good = np.asarray(ok, bool)
    if good.sum() < 2:
        return np.zeros(len(t))
    v = np.interp(t, t[good], np.asarray(nu_f_mps, float)[good])
    dt = float(np.median(np.diff(t)))
    w = max(1, int(round(window_s / dt)))
    c = np.concatenate([[0.0], np.cumsum(v)])
    lo = np.clip(np.arange(len(t)) - w // 2, 0, len(t))
    hi = np.clip(lo + w, 0, len(t))
    vs = (c[hi] - c[lo]) / np.maximum(hi - lo, 1)
    ia = np.clip(np.arange(len(t)) - w // 2, 0, len(t) - 1)
    ib = np.clip(np.arange(len(t)) + w // 2, 0, len(t) - 1)
    return (vs[ib] - vs[ia]) / np.maximum(t[ib] - t[ia], dt)


def _model(t, noise: ImuNoise, cfg: FilterConfig, zupt_intervals, attitude_only, specific_force):
    """The compiled filter's error model (:class:`~ldvsurvey.nav.kfloop.Model`), the state index of
    each LDV state (−1: none) and the epoch times ep_t (M+1,) s (see :func:`run_filter` for the
    arguments; ``t`` float64 contiguous)."""
    n_s = len(t)
    decim = max(1, int(round(1.0 / (cfg.rate_hz * np.median(np.diff(t))))))
    m = n_s // decim
    aug = [a for a in AUG_NAMES if a in cfg.ldv_aug]
    n = N_BASE + len(aug)
    aug_idx = np.full(len(AUG_NAMES), -1, dtype=np.int64)
    for i, a in enumerate(aug):
        aug_idx[AUG_NAMES.index(a)] = IX_AUG + i
    i_sz = i_sf = -1
    n_sf = 6 if cfg.gyro_scale_sigma0 > 0 or cfg.accel_scale_sigma0 > 0 else 0
    if n_sf:  # gyro x y z and accelerometer x y z scale factors, the last states
        if cfg.gyro_scale_z_sigma0 > 0:
            raise ValueError("the z-gyro scale-factor state and the six scale-factor states exclude each other")
        i_sf = n
        n += n_sf
    elif cfg.gyro_scale_z_sigma0 > 0:  # the z-gyro scale factor, last state
        i_sz = n
        n += 1
    # scale-factor priors never zero (a P⁻ singular for the smoother): 1 ppm at least
    s_sf = np.repeat([max(cfg.gyro_scale_sigma0, 1e-6), max(cfg.accel_scale_sigma0, 1e-6)], 3)[:n_sf]
    tau_sf = cfg.scale_correlation_s
    q_sf = 2.0 * s_sf**2 / tau_sf if tau_sf else np.full(n_sf, 1e-16)
    s_att = np.asarray(cfg.att_sigma0_rad, float)
    # bias priors never zero (a manifest may say 0): that would make P⁻ singular for the smoother
    sg = max(noise.gyro_bias_rps, 1e-4 * RAD_PER_DEG / 3600.0)
    sa = max(noise.accel_bias_mps2, 1e-6 * 9.80665)
    p0 = np.concatenate(
        [
            s_att**2,
            np.full(3, cfg.vel_sigma0_mps**2),
            np.full(3, cfg.pos_sigma0_m**2),
            np.full(3, sg**2),
            np.full(3, sa**2),
            [cfg.ldv_aug_sigma0[a] ** 2 for a in aug],
            [cfg.gyro_scale_z_sigma0**2] * (i_sz >= 0),
            s_sf**2,
        ]
    )
    q_v = 2.0 * (cfg.gravity_noise_mgal * MGAL) ** 2 * cfg.gravity_corr_s
    q_h = 2.0 * (cfg.dov_noise_mgal * MGAL) ** 2 * cfg.gravity_corr_s
    rw = (cfg.bias_instability**2) / 3600.0
    inv_gm, q_gm = noise.gauss_markov()
    qd = np.concatenate(
        [
            np.full(3, noise.arw_psd),
            noise.vrw_psd + np.array([q_h, q_h, q_v]),
            np.zeros(3),
            np.full(3, rw * sg**2) + q_gm[:3],
            np.full(3, rw * sa**2) + q_gm[3:],
            np.full(len(aug), 1e-14),
            [1e-16] * (i_sz >= 0),
            q_sf,
        ]
    )
    inv_tau = np.zeros(n)
    inv_tau[IX_EPS : IX_NABLA + 3] = inv_gm
    if n_sf and tau_sf:
        inv_tau[i_sf : i_sf + n_sf] = 1.0 / tau_sf
    ep_t = np.concatenate([[t[0] - (t[1] - t[0])], t[decim - 1 : m * decim : decim]])
    zupt = np.zeros(m + 1, dtype=np.bool_)
    for a, b in zupt_intervals:
        zupt |= (ep_t >= a) & (ep_t <= b)
    zupt[0] = False
    mdl = kfloop.Model(
        decim,
        p0,
        qd,
        inv_tau,
        zupt,
        float(cfg.zupt_sigma_mps),
        float(cfg.gate_sigma),
        i_sz,
        i_sf,
        not attitude_only,
        bool(specific_force),
    )
    return mdl, aug_idx, ep_t


def _ldv_in(ldv: LdvAid | None, cfg: FilterConfig, aug_idx, n_s: int):
    """The compiled filter's LDV input (:class:`~ldvsurvey.nav.kfloop.LdvIn`) for ``n_s`` IMU samples;
    arrays already float64 and contiguous are passed on, not copied."""
    sig_ldv = np.asarray(cfg.ldv_sigma_mps, float)
    if ldv is None:
        e = np.zeros(0)  # never read: no sample is usable
        lin = kfloop.LdvIn(
            np.zeros(n_s, dtype=np.bool_),
            e,
            e,
            np.array([1.0, 0.0, 0.0, 1.0, 0.0]),
            np.zeros(3),
            sig_ldv,
            False,
            aug_idx,
            e,
        )
    else:
        up = ldv.nu_u_mps is not None
        a_f = np.zeros(0) if ldv.accel_fwd_mps2 is None else np.ascontiguousarray(ldv.accel_fwd_mps2, float)
        if "pitch_k" in cfg.ldv_aug and len(a_f) == 0:
            raise ValueError("the pitch-compliance state needs LdvAid.accel_fwd_mps2")
        lin = kfloop.LdvIn(
            np.ascontiguousarray(ldv.ok, dtype=np.bool_),
            np.ascontiguousarray(ldv.nu_f_mps, dtype=float),
            np.ascontiguousarray(ldv.nu_u_mps, dtype=float) if up else np.zeros(0),  # 1-D: never read
            np.array(
                [1.0 / ldv.scale, ldv.pitch_rad, ldv.heading_rad, 1.0 / ldv.scale_up, ldv.pitch_k_rad_per_mps2], float
            ),
            np.asarray(ldv.lever_arm_m, float),
            sig_ldv,
            up,
            aug_idx,
            a_f,
        )
    return lin


def _gnss_in(gnss: GnssAid | None):
    """The compiled filter's GNSS input (:class:`~ldvsurvey.nav.kfloop.GnssIn`): the fixes with a
    position and a σ."""
    if gnss is None:
        gin = kfloop.GnssIn(np.zeros(0), np.zeros((0, 3)), np.zeros((0, 2)), np.zeros(3))
    else:
        ok = np.isfinite(gnss.lat_rad) & np.isfinite(gnss.sigma_h_m)
        gin = kfloop.GnssIn(
            np.ascontiguousarray(gnss.t_s[ok], dtype=float),
            np.ascontiguousarray(np.column_stack([gnss.lat_rad[ok], gnss.lon_rad[ok], gnss.h_m[ok]])),
            np.ascontiguousarray(np.column_stack([gnss.sigma_h_m[ok], gnss.sigma_v_m[ok]])),
            np.asarray(gnss.lever_arm_m, float),
        )
    return gin


def _imu_in(t, imu: ImuData, gravity):
    """The compiled filter's IMU input (:class:`~ldvsurvey.nav.kfloop.ImuIn`) at the times ``t``
    (float64, contiguous); arrays already float64 and contiguous are passed on, not copied."""
    e = np.zeros(0)
    xi, eta, dg = (e, e, e) if gravity is None else (np.ascontiguousarray(g, dtype=float) for g in gravity)
    # (1, 3, 3): a fixed IMU
    c_bs_arr = np.eye(3)[None] if imu.c_bs is None else np.ascontiguousarray(imu.c_bs, dtype=float)
    dth, dv = np.ascontiguousarray(imu.dtheta_rad, float), np.ascontiguousarray(imu.dvel_mps, float)
    return kfloop.ImuIn(t, dth, dv, c_bs_arr, xi, eta, dg)


def _start(start: NavStart):
    """The compiled filter's initial state (:class:`~ldvsurvey.nav.kfloop.Start`)."""
    b_g = np.zeros(3) if start.gyro_bias_rps is None else start.gyro_bias_rps
    b_a = np.zeros(3) if start.accel_bias_mps2 is None else start.accel_bias_mps2
    return kfloop.Start(
        np.asarray(start.q_sn, float),
        np.asarray(start.v_n_mps, float),
        np.asarray(start.pos_rad_m, float),
        np.concatenate([np.asarray(b_g, float), np.asarray(b_a, float)]),
    )


def run_filter(
    imu: ImuData,
    start: NavStart,
    noise: ImuNoise,
    cfg: FilterConfig | None = None,
    *,
    zupt_intervals=(),
    ldv: LdvAid | None = None,
    gnss: GnssAid | None = None,
    gravity=None,
    smooth: bool = True,
    keep_cov: bool = False,
    attitude_only: bool = False,
    specific_force: bool = True,
) -> NavSolution:
    """Forward closed-loop filter, then (optionally) the RTS smoother.

    Parameters
    ----------
    imu : the increments, their times and (rotating IMU) C_b^s per sample.
    start : the state at the start of the first interval.
    noise : the IMU's error magnitudes.
    cfg : the filter's tuning (None: the defaults).
    zupt_intervals : [(t_start, t_end)] in s where the vehicle stands still.
    ldv, gnss : the aids (None: not used).
    gravity : optional (xi_rad, eta_rad, dg_mps2) per sample for the gravity model.
    smooth : run the RTS smoother and correct every sample with it.
    keep_cov : keep the covariance of every epoch (``NavSolution.epoch_cov``).
    attitude_only : keep only the attitude per sample (v_n, pos, f_u_mps2, f_u_bias_mps2 come back
        empty): for a run whose use is its parameters and attitude, at 40 % of the memory.
    specific_force : False: f_u_mps2 and f_u_bias_mps2 come back empty (a navigation that will not
        serve gravity: 24 bytes per sample less).

    Returns
    -------
    NavSolution
        At the IMU sample times, smoothed when ``smooth``.
    """
    cfg = cfg or FilterConfig()
    t = np.ascontiguousarray(imu.t_s, dtype=float)
    mdl, aug_idx, ep_t = _model(t, noise, cfg, zupt_intervals, attitude_only, specific_force)
    lin = _ldv_in(ldv, cfg, aug_idx, len(t))
    fw = kfloop.forward(_imu_in(t, imu, gravity), mdl, lin, _gnss_in(gnss), _start(start))
    par0 = lin.par0
    del lin
    traj = kfloop.Trajectory(fw.q_sn, fw.v_n_mps, fw.pos_rad_m, fw.f_u_mps2, fw.f_en_mps2, fw.f_b_mps2)
    rec = kfloop.Record(fw.ck_packed, fw.upd, fw.fin, fw.dt_s, fw.dx)
    proc = kfloop.ProcessModel(mdl.qd, mdl.inv_tau, mdl.i_sz, mdl.i_sf, aug_idx, float(cfg.zupt_sigma_mps))
    # the LDV parameters are read at the first or last epoch only; the smoother's 1-σ replace the
    # forward ones, which are not held through the smoother
    par, bias, sz, sig_f = fw.ldv_par[[0, -1]], fw.bias, fw.gyro_scale_z, None if smooth else fw.sigma
    sf_ep = fw.scale
    nis, rej = fw.nis, fw.rejected
    del fw
    if smooth:
        xs, sig_ep, ps = kfloop.rts(rec, proc, keep_cov)
        kfloop.apply_corrections(t, ep_t, mdl.decim, xs, rec.dx, traj)
    else:
        xs = np.zeros_like(rec.dx)
        sig_ep = sig_f
        ps = kfloop.forward_covs(rec, proc) if keep_cov else None
    del rec
    jb = 0 if smooth else -1  # the biases and LDV parameters are read at the first or last epoch
    i_sz, i_sf = mdl.i_sz, mdl.i_sf
    sfs = None
    if i_sf >= 0:  # the estimates fed back up to the epoch, + the smoother's correction there
        est = sf_ep[jb] + xs[jb, i_sf : i_sf + 6]
        sig6 = sig_ep[jb, i_sf : i_sf + 6]
        sfs = {"gyro": (est[:3], sig6[:3]), "accel": (est[3:], sig6[3:])}
    return NavSolution(
        t_s=t,
        q_sn=traj.q_sn,
        v_n=traj.v_n_mps,
        pos=traj.pos_rad_m,
        c_bs=imu.c_bs,
        smoothed=smooth,
        ldv_params=_ldv_params(par, xs, sig_ep, aug_idx, par0, smooth, ldv is not None),
        gyro_bias_rps=bias[jb, :3] + xs[jb, IX_EPS : IX_EPS + 3],
        accel_bias_mps2=bias[jb, 3:] + xs[jb, IX_NABLA : IX_NABLA + 3],
        epoch_t_s=ep_t,
        epoch_sigma=sig_ep,
        normalized_innovations=nis,
        rejected={"zupt": int(rej[0]), "ldv": int(rej[1]), "gnss": int(rej[2])},
        epoch_index=np.arange(len(ep_t)) * mdl.decim - 1,
        epoch_bias=bias + xs[:, IX_EPS : IX_NABLA + 3],
        epoch_cov=ps if keep_cov else None,
        f_u_mps2=traj.f_u_mps2,
        f_u_bias_mps2=traj.f_b_mps2,
        gyro_scale_z=None if i_sz < 0 else (float(sz[jb] + xs[jb, i_sz]), float(sig_ep[jb, i_sz])),
        scale_factors=sfs,
    )


def _ldv_params(par, xs, sig_ep, aug_idx, par0, smooth, has_ldv) -> dict:
    """name → (value, 1-σ) of each LDV parameter (scales as K, angles in rad, k_η in rad per m/s²):
    the estimated ones from the first (smoothed) or last epoch of ``par`` (2, 5) corrected by x_s,
    the others as given (σ 0) when an LDV aids at all."""
    out = {}
    jj = 0 if smooth else -1
    for i, a in enumerate(AUG_NAMES):
        if aug_idx[i] >= 0:
            val = par[jj, i] - xs[jj, aug_idx[i]]
            sig = float(sig_ep[jj, aug_idx[i]])
            if a.startswith("scale"):  # estimated as s = 1/K
                val, sig = 1.0 / val, sig / val**2
            out[a] = (float(val), sig)
        elif has_ldv:
            v0 = par0[i]
            out[a] = (float(1.0 / v0 if a.startswith("scale") else v0), 0.0)
    return out
