"""The two raw gravity chains of the ``gravity`` pipeline: SINS/2-D LDV and SINS/GNSS (methods §4).

Both take f_U from the navigation's own mechanization step (``NavSolution.f_u_mps2``, smoothed),
with the horizontal accelerometer biases the filter estimated removed (the vertical one is not
separable from Δg without a base tie and stays).
Rows missing from the IMU log are bridged when it is read (io.imutime) and reported.

SINS/LDV: v̇_U from the LDV vertical velocity (brought to the IMU centre) differenced over
each IMU interval. Where the LDV is unusable (quality, dropouts, values far off the navigation
velocity) the velocity is bridged through the smoothed navigation velocity tied to both gap
edges, so the difference quotient telescopes and a gap costs only its own samples.

SINS/GNSS: the same f_U (the pipeline passes the SINS/LDV navigation, so the two chains differ
only in the vertical acceleration, LDV or GNSS heights), normal gravity and Eötvös terms integrated
twice (S) against the GNSS heights brought to the IMU centre with the lever arm, on the regular grid of the fixes. Where
fixes are missing (outage, lower quality, multipath) the height is bridged through S tied to
both gap edges, the height-domain twin of the LDV bridge. The second difference of S − h is δg:
both sides of the subtraction see the very same differencing, so the FIR treats them alike.
Its static δg (the stop ties' and base ties' reading, ``dg_static``) is f_U − γ alone: standing
still the vehicle neither accelerates nor moves, so the GNSS heights (only noise there) and the Eötvös
terms of the navigated velocity (its residual there) do not enter it; the SINS/LDV chain's likewise.

The navigation levels its frame to the plumb line (the SINS/LDV filter cannot tell a deflection of
the vertical from a tilt), GNSS heights are along the ellipsoidal normal: f_U then holds
ξ·a_N + η·a_E beyond the ellipsoidal vertical acceleration. The SINS/LDV chain differentiates the
LDV velocity in the same tilted frame and the term cancels; the SINS/GNSS chain keeps it (mGal on a
winding road with a DOV of tens of arcseconds). :func:`report.frame_tilt` estimates it.
"""

from __future__ import annotations

import numpy as np
from scipy.ndimage import median_filter, uniform_filter1d

from ldvsurvey.nav.attitude import c_from_q
from ldvsurvey.nav.earth import OMEGA_IE, normal_gravity, radii
from ldvsurvey.nav.gravity import Lowpass, bridge_velocity, disturbance_mps2, runs
from ldvsurvey.pipelines.stages.aids import GNSS_SIGMA, attitude_at
from ldvsurvey.pipelines.stages.ldv_mounting import accel_fwd, ldv_body_velocity

#: GNSS fixes (each side) through whose offset from the doubly integrated f_U a line is fitted to tie a gap's bridge
GNSS_EDGE_N = 10
#: passes of the outage bridge (each takes the previous pass's filtered δg as its prior)
GNSS_BRIDGE_PASSES = 4
#: LDV samples (each side) whose mean offset from the navigation velocity ties a gap's bridge
LDV_EDGE_N = 50


#: IMU samples per block of the per-sample work (attitude matrices, LDV velocity, the chains' terms): the
#: temporaries stay a few MB whatever the log's length, and every value is computed exactly as on the whole log
BLOCK = 1 << 15


def _blocks(n: int, size: int | None = None):
    """(start, stop) of consecutive blocks covering range(n) (``size`` default: :data:`BLOCK`)."""
    size = size or BLOCK
    for a in range(0, n, size):
        yield a, min(n, a + size)


def _vertical_force_block(sol, a: int, b: int) -> np.ndarray:
    """:func:`vertical_force` of the samples a..b−1 (the up row of C_s^n from the quaternions only)."""
    q = np.asarray(sol.q_sn[a:b], float)
    q = q / np.linalg.norm(q, axis=-1, keepdims=True)  # as attitude.c_from_q
    w, x, y, z = q[:, 0], q[:, 1], q[:, 2], q[:, 3]
    c_20, c_21 = 2 * (x * z - w * y), 2 * (y * z + w * x)
    f_raw = sol.f_u_mps2[a:b] + sol.f_u_bias_mps2[a:b]  # C_s^n Δv / Δt as mechanized, no bias removed
    bias = sol.accel_bias_mps2
    return f_raw - (c_20 * bias[0] + c_21 * bias[1])


def vertical_force(inp, sol):
    """Up specific force (N,) per IMU interval of the navigation's own mechanization step, m/s².

    ``sol.f_u_mps2`` (smoothed with the attitude) with the bias correction added back, minus the
    horizontal accelerometer biases only: the vertical bias is not separable from Δg without a
    base tie and stays (a constant offset). Rows missing from ``imu.csv`` were bridged when the
    log was read (:mod:`ldvsurvey.io.imutime`); the pipeline reports how many. Computed block by
    block (no per-sample attitude matrix is formed).
    """
    n = len(sol.t_s)
    out = np.empty(n)
    for a, b in _blocks(n):
        out[a:b] = _vertical_force_block(sol, a, b)
    return out


class _AttitudeRows:
    """C_b^n of the samples it is indexed with, from the solution's quaternions (and C_b^s of a rotating
    IMU): what :func:`attitude_at` takes for the whole log's C_b^n, formed only at the samples it reads."""

    def __init__(self, sol):
        self.sol = sol

    def __getitem__(self, k):
        c = c_from_q(self.sol.q_sn[k])
        return c if self.sol.c_bs is None else c @ self.sol.c_bs[k]


def _body_rotation(c_a, c_b) -> np.ndarray:
    """(K, 3) twice the rotation vector of C_aᵀ C_b (small angles), from its antisymmetric part, rad.

    Only the six off-diagonal terms of the product are formed (the sums in the order einsum takes them)."""

    def rel(i, j):
        return c_a[:, 0, i] * c_b[:, 0, j] + c_a[:, 1, i] * c_b[:, 1, j] + c_a[:, 2, i] * c_b[:, 2, j]

    return np.column_stack([rel(2, 1) - rel(1, 2), rel(0, 2) - rel(2, 0), rel(1, 0) - rel(0, 1)])


def _ldv_velocity_blocks(inp, sol, setup):
    """(a, b, LDV velocity (b − a, 3) ENU at the IMU centre) for consecutive blocks of samples, m/s.

    Per block: C_b^n of the block's samples (and of the sample before it, for the body rate over the
    interval that ends at the block's first sample); the arithmetic per sample is that of the whole log."""
    t = inp.t_s
    n = len(t)
    pk = getattr(setup, "pitch_k_rad_per_mps2", 0.0)
    a_f = (setup.accel_fwd_mps2 if setup.accel_fwd_mps2 is not None else accel_fwd(inp)) if pk else None
    lever = np.asarray(inp.log.manifest.ldv.lever_arm_m, float)
    nu_u = inp.nu_u_mps
    for a, b in _blocks(n):
        a0 = max(a - 1, 0)  # the interval (a − 1, a] gives sample a's body rate; sample 0 takes (0, 1]
        b0 = b + 1 if a == 0 else b
        c_bn = _AttitudeRows(sol)[a0:b0]
        v_b = ldv_body_velocity(
            inp.nu_f_mps[a:b],
            None if nu_u is None else nu_u[a:b],
            setup.scale,
            setup.pitch_rad,
            setup.heading_rad,
            setup.scale_up,
            pk,
            None if a_f is None else a_f[a:b],
        )
        c_k = c_bn[a - a0 : a - a0 + (b - a)]
        v_head = np.einsum("kij,kj->ki", c_k, v_b)
        w = _body_rotation(c_bn[:-1], c_bn[1:])
        dt = np.diff(t[a0:b0])
        if a == 0:
            w = np.vstack([w[:1], w[: b - 1]]) / (2 * np.r_[dt[:1], dt[: b - 1]])[:, None]
        else:
            w = w / (2 * dt)[:, None]
        yield a, b, v_head - np.einsum("kij,kj->ki", c_k, np.cross(w, lever))


def ldv_velocity_imu(inp, sol, setup):
    """LDV velocity (N, 3) ENU at the IMU centre (lever arm through the body rate), m/s.

    The travel direction the LDV sees includes the calibrated pitch compliance (squat/dive)."""
    out = np.empty((len(inp.t_s), 3))
    for a, b, v in _ldv_velocity_blocks(inp, sol, setup):
        out[a:b] = v
    return out


def screen_velocity(v_u, ok, v_ref, window: int = 201, k_sigma: float = 8.0, floor_mps: float = 0.05):
    """Samples of ``v_u`` far off the reference after removing the slow difference (garbage values).

    The slow part of v − v_ref (moving mean over ``window`` valid samples) is removed; what stays
    is LDV noise. Flagged: |rest| > max(k σ, floor) with σ from the median absolute deviation.
    """
    # in place where it can be: at most three per-sample float series at a time (the screen runs on the whole log)
    r = np.subtract(v_u, v_ref)
    r[~ok] = 0.0
    w = uniform_filter1d(ok.astype(float), window)
    np.maximum(w, 1e-9, out=w)
    rest = uniform_filter1d(r, window)
    rest /= w  # the slow part
    del w
    np.subtract(r, rest, out=rest)
    del r
    if ok.sum() < 10:
        return np.zeros_like(ok)
    sig = 1.4826 * np.median(np.abs(rest[ok]), overwrite_input=True)
    np.abs(rest, out=rest)
    return ok & (rest > max(k_sigma * sig, floor_mps))


def ldv_noise_estimate_mps(v_u, ok):
    """White noise σ (m/s) of a velocity series from its second differences (σ = std(Δ²v)/√6, robust)."""
    good = ok[2:] & ok[1:-1] & ok[:-2]
    d2 = np.concatenate([np.diff(v_u[a : b + 2], 2)[good[a:b]] for a, b in _blocks(len(good))])
    if len(d2) < 100:
        return None
    np.subtract(d2, np.median(d2), out=d2)
    return float(1.4826 * np.median(np.abs(d2, out=d2), overwrite_input=True) / np.sqrt(6.0))


def nominal_interval_s(t_s) -> float:
    """The IMU's nominal sampling interval (s): the mean interval (t_N − t_0)/(N − 1).

    Time-tag jitter telescopes in the mean (error ~ σ_jitter/T), whereas the median of the
    intervals is a noisy statistic of the jitter distribution: ~1e-7 s off at 100 Hz on an hour
    of tags with 50-µs jitter, i.e. a relative 1e-5 error of every f_U·Δt/Δt0, 10 mGal on g."""
    t = np.asarray(t_s, float)
    return float((t[-1] - t[0]) / (len(t) - 1))


def per_nominal_interval(f_u_mps2, t_s):
    """f_U over the nominal interval: (f_U·Δt_k/Δt0 per interval (first kept), Δt0 in s).

    f_U·Δt_k is the mechanized increment whatever the time tag says, and Δv_U belongs to the same
    interval, so time-tag jitter (tens of µs, f_U = Δv/Δt off by ‰ per sample) cancels and the
    series telescopes; Δt0 is :func:`nominal_interval_s` so that the sum of the increments over
    the drive divided by its duration is the mean specific force (no Jensen/median bias)."""
    dt = np.diff(np.asarray(t_s, float))
    dt0 = nominal_interval_s(t_s)
    return np.r_[f_u_mps2[:1], f_u_mps2[1:] * dt / dt0], dt0


#: IMU rows each side of a lost gap whose leave-out predictions measure its bridge's error
BRIDGE_WINDOW_ROWS = 300


def lost_increment_sigmas(inp, sol):
    """What each run of lost IMU rows costs: [(t_s of its middle, its duration s, σ of its up velocity m/s)].

    The increments of lost rows are unknown; the reader bridged them with the best prediction the
    neighbours give (:mod:`ldvsurvey.io.imutime`: linear interpolation, which the navigation then
    integrates). The chain's f_U over the gap is that prediction, so the gap leaves one velocity
    error in f_U·Δt: an impulse in δg whose area the FIR spreads over its length. Its σ is
    measured on the data next to the gap: the same prediction of k real rows from their
    neighbours (every position within :data:`BRIDGE_WINDOW_ROWS` that touches no bridged row),
    RMS of Σ (f_U − prediction)·Δt0 over the k rows (vibration, manoeuvres and the sensor's own
    noise, which the lost rows held too). Gaps whose next row had accumulated them cost nothing
    (their sum is kept exactly) and are not listed."""
    bridges = getattr(getattr(getattr(inp, "log", None), "imu", None), "bridges", None) or []
    lost = [g for g in bridges if g.lost]
    if not lost:
        return []
    t = inp.t_s
    n = len(t)
    dt0 = nominal_interval_s(t)
    inserted = np.zeros(n, bool)
    for g in bridges:
        inserted[g.row : g.row + g.rows] = True
    out = []
    for g in lost:
        k = int(g.rows)
        a, b = max(1, g.row - BRIDGE_WINDOW_ROWS), min(n, g.row + k + BRIDGE_WINDOW_ROWS)
        # row i holds the increments of the interval (i − 1, i]: per nominal interval as in the chain
        f = _vertical_force_block(sol, a, b) * np.diff(t[a - 1 : b]) / dt0
        bad = inserted[a:b]
        c = np.r_[0.0, np.cumsum(f)]
        cb = np.r_[0, np.cumsum(bad)]
        j = np.arange(1, len(f) - k)  # rows j..j+k−1 predicted from rows j−1 and j+k (window indices)
        clean = (cb[j + k + 1] - cb[j - 1]) == 0
        j = j[clean]
        t_mid = 0.5 * (t[g.row - 1] + t[min(g.row + k, n - 1)])
        if len(j) < 20:  # too little clean data next to the gap: no measured σ (say so with NaN)
            out.append((float(t_mid), k * dt0, float("nan")))
            continue
        err = (c[j + k] - c[j] - 0.5 * k * (f[j - 1] + f[j + k])) * dt0
        out.append((float(t_mid), k * dt0, float(np.sqrt(np.mean(err**2)))))
    return out


def height_sigma_epochs(sol):
    """(t_s, σ_h m) at the filter epochs: the navigation's own 1-σ of its height (GNSS-aided where fixes
    were used), for the δg 1-σ (normal gravity at a wrong height moves δg by 0.3086 mGal/m)."""
    if getattr(sol, "epoch_sigma", None) is None:  # a solution without the filter's covariance
        return None
    return np.array(sol.epoch_t_s, float), np.array(sol.epoch_sigma[:, 8], float)


def _accel_noise_ug_rthz(log):
    """The manifest's white accelerometer noise (µg/√Hz), None when not given."""
    imu = getattr(getattr(log, "manifest", None), "imu", None)
    return getattr(imu, "accel_noise_ug_per_rthz", None)


def ldv_chain(inp, sol, setup):
    """Raw δg (m/s²) per IMU interval from SINS/LDV; dict of arrays at the interval mid-times.

    Per-sample work in blocks (:data:`BLOCK`): besides its own columns (time, δg, the static δg for the
    drift ties) the chain forms one per-sample series at a time (the LDV up velocity, then the bridged one),
    never an attitude matrix per sample; latitude, longitude, height and speed are
    :class:`IntervalColumn` s over the navigation's position and velocity.
    """
    t = inp.t_s
    n = len(t)
    v_u = np.empty(n)
    ok = np.array(inp.ldv_ok, bool, copy=True)
    for a, b, v in _ldv_velocity_blocks(inp, sol, setup):
        v_u[a:b] = v[:, 2]
        ok[a:b] &= np.all(np.isfinite(v), axis=1)
    v_ref = sol.v_n[:, 2]
    bad = screen_velocity(v_u, ok, v_ref)
    use = ok & ~bad
    noise = ldv_noise_estimate_mps(v_u, use)
    v_u = bridge_velocity(v_u, use, v_ref, edge_n=LDV_EDGE_N)
    del ok
    dt0 = nominal_interval_s(t)
    cols = {k: np.empty(n - 1) for k in ("dg", "dg_static")}
    # interval k (samples k, k + 1) of the chain; per block the intervals a..b−2 and the one to the next block
    for a, b in _blocks(n):
        b1 = min(b + 1, n)  # samples a..b1−1 give the intervals a..b1−2
        if b1 - a < 2:
            continue
        f_u = _vertical_force_block(sol, a + 1, b1) * np.diff(t[a:b1]) / dt0  # per_nominal_interval
        vdot_u = np.diff(v_u[a:b1]) / dt0
        v_n, pos = sol.v_n[a:b1], sol.pos[a:b1]
        v_mid = 0.5 * (v_n[1:] + v_n[:-1])
        lat = 0.5 * (pos[1:, 0] + pos[:-1, 0])
        h = 0.5 * (pos[1:, 2] + pos[:-1, 2])
        dg = disturbance_mps2(f_u, vdot_u, v_mid[:, 0], v_mid[:, 1], lat, h)
        k = slice(a, b1 - 1)
        cols["dg"][k] = dg
        # the static reading has no velocity terms: where it is read (stops) the vehicle stands, and the
        # navigated velocity's residual there would add Eötvös (0.128 mGal per cm/s east at 28.5°)
        cols["dg_static"][k] = f_u - normal_gravity(lat, h)
    del v_u  # before the third column
    bridged = ~(use[1:] & use[:-1])  # intervals touching a bridged sample
    return {
        "t_s": 0.5 * (t[1:] + t[:-1]),
        **cols,
        # formed where indexed (the lines' samples, the stops, the table's rows): no copy of the navigation
        "lat": _mid_column(sol.pos, 0),
        "lon": _mid_column(sol.pos, 1),
        "h": _mid_column(sol.pos, 2),
        "speed": _mid_speed_column(sol.v_n),
        "fs": 1.0 / dt0,
        "bridged": bridged,
        "screened": int(bad.sum()),
        "ldv_noise_mps": noise,
        "imu_bridges": lost_increment_sigmas(inp, sol),
        "h_sigma_epochs": height_sigma_epochs(sol),
        "kind": "ldv",
        # the manifest's white accelerometer noise (µg/√Hz, None when not given): the floor of a stop's σ
        "accel_noise_ug_rthz": _accel_noise_ug_rthz(inp.log),
    }


def _double_integral(t, sol, first: np.ndarray | None = None, first_static: np.ndarray | None = None) -> np.ndarray:
    """S (N,) in m: ∫∫ (f_U − γ + Eötvös) dt² at the IMU times (rectangle per interval, then trapezoid).

    In blocks of intervals; each running sum carries the previous block's last value into the first term of
    its block's cumulative sum, which is then the very sequence of additions of one sum over the whole log.
    ``first`` (N,), when given, receives the single integral W = ∫ (f_U − γ + Eötvös) dt (m/s) at the IMU
    times: exactly piecewise linear between them (the integrand is constant per interval). ``first_static``
    (N,), when given, receives ∫ (f_U − γ) dt (m/s), the same without the velocity terms (the stops' reading)."""
    n = len(t)
    s = np.empty(n)
    s[0] = 0.0
    if first is not None:
        first[0] = 0.0
    w_end = s_end = ws_end = 0.0  # ∫ (f_U − γ + Eötvös) dt, S and ∫ (f_U − γ) dt at the previous block's end
    if first_static is not None:
        first_static[0] = 0.0
    for a, b in _blocks(n):
        b1 = min(b + 1, n)  # intervals a..b1−2 (samples a..b1−1)
        if b1 - a < 2:
            continue
        pos, v_n = sol.pos[a:b1], sol.v_n[a:b1]
        lat_m = 0.5 * (pos[1:, 0] + pos[:-1, 0])
        h_m = 0.5 * (pos[1:, 2] + pos[:-1, 2])
        v_mid = 0.5 * (v_n[1:] + v_n[:-1])
        rm, rn = radii(lat_m)
        static = _vertical_force_block(sol, a + 1, b1) - normal_gravity(lat_m, h_m)
        acc = (
            static
            + (v_mid[:, 0] / (rn + h_m) + 2 * OMEGA_IE * np.cos(lat_m)) * v_mid[:, 0]
            + v_mid[:, 1] ** 2 / (rm + h_m)
        )
        dt = np.diff(t[a:b1])
        if first_static is not None:
            xs = static * dt
            xs[0] += ws_end
            first_static[a + 1 : b1] = ws = np.cumsum(xs)
            ws_end = ws[-1]
        x = acc * dt
        x[0] += w_end
        w = np.cumsum(x)  # at the samples a+1..b1−1
        y = 0.5 * (w + np.r_[w_end, w[:-1]]) * dt
        y[0] += s_end
        s[a + 1 : b1] = np.cumsum(y)
        if first is not None:
            first[a + 1 : b1] = w
        w_end, s_end = w[-1], s[b1 - 1]
    return s


class IntervalColumn:
    """A per-interval column of a chain (e.g. latitude at the interval mid-times) formed from the navigation's
    per-sample arrays only where it is indexed, so the chain holds no copy of them.

    ``fn(k)`` gives the values of the intervals ``k`` (int array). ``col[idx]`` (indices, mask or slice)
    and ``np.asarray(col)`` equal the materialized column's values bit for bit.
    """

    def __init__(self, n: int, fn):
        self._n, self._fn = int(n), fn

    def __len__(self) -> int:
        return self._n

    @property
    def shape(self):
        """(n,): the shape of the materialized column."""
        return (self._n,)

    def __getitem__(self, idx):
        if isinstance(idx, slice):
            return self._fn(np.arange(*idx.indices(self._n)))
        k = np.asarray(idx)
        if k.dtype == bool:
            if k.shape != (self._n,):
                raise IndexError(f"boolean index of shape {k.shape} for a column of {self._n}")
            return self._fn(np.flatnonzero(k))
        if k.ndim == 0:
            j = int(k) + self._n if int(k) < 0 else int(k)
            if not 0 <= j < self._n:
                raise IndexError(f"index {int(k)} out of range for a column of {self._n}")
            return self._fn(np.array([j]))[0]
        return self._fn(np.where(k < 0, k + self._n, k))

    def __array__(self, dtype=None, copy=None):
        out = self[:]
        return out if dtype is None else out.astype(dtype)


def _mid_column(x, i: int) -> IntervalColumn:
    """0.5 (x[k, i] + x[k + 1, i]) for the intervals k of the samples of x (N, m)."""
    return IntervalColumn(len(x) - 1, lambda k: 0.5 * (x[k + 1, i] + x[k, i]))


def _mid_speed_column(v_n) -> IntervalColumn:
    """Horizontal speed from the interval-mean velocity, per interval of the samples of v_n (N, 3)."""
    return IntervalColumn(
        len(v_n) - 1, lambda k: np.hypot(0.5 * (v_n[k + 1, 0] + v_n[k, 0]), 0.5 * (v_n[k + 1, 1] + v_n[k, 1]))
    )


def multipath_screen(t_s, d_m, fix, *, window_s: float, k_sigma: float) -> np.ndarray:
    """Which GNSS height residuals to keep: multipath (height jumps of decimetres for seconds to a minute
    in fixed solutions) departs from the residuals' running median.

    Parameters
    ----------
    t_s, d_m : ndarray
        The fixes' times (s) and height residuals against a reference (m).
    fix : ndarray of int
        Their fix qualities (``GNSS_SIGMA`` gives each one's vertical 1-σ).
    window_s : float
        Length of the running median (s).
    k_sigma : float
        How many robust σ (MAD) a residual may depart from the median; never fewer than 3 σ of its
        fix quality.

    Returns
    -------
    ndarray of bool
        True for a fix kept.
    """
    step = float(np.median(np.diff(t_s))) if len(t_s) > 1 else 1.0
    win = max(3, int(round(window_s / step)) | 1)
    rest = d_m - median_filter(d_m, size=win, mode="nearest")
    mad = 1.4826 * np.median(np.abs(rest - np.median(rest)))
    sig_v = np.array([GNSS_SIGMA.get(int(f), (np.nan, 5.0))[1] for f in fix])
    return np.abs(rest) <= np.maximum(k_sigma * mad, 3.0 * sig_v)


def _screened_fixes(log, inp, sol, fixes, *, ref, fir_s: float, k_sigma: float):
    """The fixes of the qualities ``fixes`` at the IMU (times s, heights m, their height 1-σ m) with
    multipath screened against ``ref`` (see :func:`gnss_chain`), and the mask of those kept."""
    g = log.gnss
    t = inp.t_s
    keep = np.isin(g.fix, fixes) & np.isfinite(g.lat_deg) & np.isfinite(g.h_m) & (g.t_s > t[2]) & (g.t_s < t[-1])
    if keep.sum() < 20:
        raise ValueError(f"fewer than 20 GNSS fixes of quality {'/'.join(map(str, fixes))}")
    tg = g.t_s[keep]
    lever = np.asarray(log.manifest.gnss.lever_arm_m, float)
    h_g = g.h_m[keep] - (attitude_at(sol, tg, _AttitudeRows(sol)) @ lever)[:, 2]
    sig_v = np.array([GNSS_SIGMA.get(int(f), (np.nan, 5.0))[1] for f in g.fix[keep]])
    ref = sol if ref is None else ref
    good = multipath_screen(tg, h_g - np.interp(tg, t, ref.pos[:, 2]), g.fix[keep], window_s=fir_s, k_sigma=k_sigma)
    tg, h_g, sig_v = tg[good], h_g[good], sig_v[good]
    if len(tg) < 20:
        raise ValueError("fewer than 20 GNSS fixes agree with the navigation solution")
    return tg, h_g, sig_v, good


def _box_means(t, w_int, tc, step: float):
    """Mean over each grid time's own step (s) of the quantity whose running integral is ``w_int`` on
    ``t``: the difference of the integral across the box, NaN where the box leaves the record."""
    half = 0.5 * step
    out = (np.interp(tc + half, t, w_int) - np.interp(tc - half, t, w_int)) / step
    out[(tc - half < t[0]) | (tc + half > t[-1])] = np.nan
    return out


def gnss_chain(log, inp, sol, lowpass: Lowpass, fixes=(4,), ref=None, k_sigma: float = 4.0):
    """Raw δg (m/s²) on a regular grid at the GNSS rate from SINS/GNSS; dict like :func:`ldv_chain`.

    ``lowpass``: the gravity filter, for the first pass that carries the disturbance across outages
    (its length L: ``fir_s`` below).
    Uses the fixes of the given qualities. Multipath (height jumps of decimetres for seconds to a
    minute in fixed solutions) is screened against ``ref`` (a solution without GNSS, e.g. the
    SINS/LDV one; default ``sol``): a fix whose height residual departs from the residual's
    running median (over ``fir_s``) by more than ``k_sigma`` robust σ (at least 3 σ of its fix
    quality) is dropped and bridged. Raises ValueError when fewer than 20 fixes remain.
    """
    t = inp.t_s
    fir_s = lowpass.length_s
    tg, h_g, sig_v, good = _screened_fixes(log, inp, sol, fixes, ref=ref, fir_s=fir_s, k_sigma=k_sigma)
    w_int = np.empty(len(t))  # the static reading's integral: no velocity terms (the vehicle stands there)
    s = _double_integral(t, sol, first_static=w_int)
    # the fixes on a regular grid; the heights bridged through S tied to the gap edges
    step = float(np.median(np.diff(tg)))
    grid = tg[0] + step * np.arange(int(np.floor((tg[-1] - tg[0]) / step + 1e-6)) + 1)
    j = np.rint((tg - tg[0]) / step).astype(int)
    on = np.abs(tg - grid[j]) < 0.05 * step
    h_grid = np.full(len(grid), np.nan)
    h_grid[j[on]] = h_g[on] + (np.interp(grid[j[on]], t, s) - np.interp(tg[on], t, s))  # to the grid time
    ok = np.isfinite(h_grid)
    s_grid = np.interp(grid, t, s)
    tc = grid[1:-1]
    bridged = ~(ok[2:] & ok[1:-1] & ok[:-2])
    # Bridge the heights through S minus a prior δg integrated twice (G), so that a gap keeps its
    # share of the disturbance where it was instead of at its edges. The prior is the filtered
    # result of the previous pass (first pass: none); a few passes make it self-consistent.
    g_prior = np.zeros(len(tc))
    for _ in range(GNSS_BRIDGE_PASSES):
        gg = np.zeros(len(grid))
        gg[2:] = np.cumsum(np.cumsum(g_prior) * step) * step
        d = s_grid - bridge_velocity(h_grid, ok, s_grid - gg, edge_n=GNSS_EDGE_N, edge_fit="line")
        dg = (d[2:] - 2 * d[1:-1] + d[:-2]) / step**2
        if not bridged.any():
            break
        g_prior = lowpass.at(1.0 / step).apply(dg)
        # inside outages longer than the filter nothing constrains the prior: take it straight
        # across from the filtered values half a filter length outside the outage
        for a, b in runs(bridged):
            if (b - a) * step > fir_s:
                g_prior[max(0, a - int(fir_s / 2 / step)) : min(len(tc), b + int(fir_s / 2 / step))] = np.nan
        fin = np.isfinite(g_prior)
        g_prior = np.interp(tc, tc[fin], g_prior[fin])
    # An outage longer than half the filter is a break, not a bridge: a tie across it would put
    # the prior's error times its length onto its edges. The samples stay NaN (the FIR treats the
    # break like a line end, and the values near it are withheld as unsupported).
    for a, b in runs(bridged):
        if (b - a) * step > 0.5 * fir_s:
            dg[max(0, a - 1) : b + 1] = np.nan
    # δg where the vehicle stands (drift and base ties): with v = 0 and v̇ = 0 the accelerometer reads
    # f_U = g_U, so δg = f_U − γ with no height and no velocity term at all (a navigated velocity's
    # residual would add its Eötvös, 0.128 mGal per cm/s east at 28.5°). The GNSS
    # heights' second difference, which carries the chain's noise, is only noise there and is left out;
    # each grid time takes the mean over its own step (box, W's difference), so the samples do not
    # overlap and their scatter is the stop's white noise (drift.stop_sigma).
    dg_static = _box_means(t, w_int, tc, step)
    del w_int
    # horizontal accelerations (navigation frame) over the same three-epoch stencil, for the frame tilt
    v_g = np.column_stack([np.interp(grid, t, sol.v_n[:, i]) for i in (0, 1)])
    a_en = (v_g[2:] - v_g[:-2]) / (2 * step)
    return {
        "t_s": tc,
        "dg": dg,
        "dg_static": dg_static,
        "lat": np.interp(tc, t, sol.pos[:, 0]),
        "lon": np.interp(tc, t, sol.pos[:, 1]),
        "a_e": a_en[:, 0],
        "a_n": a_en[:, 1],
        "h": np.interp(tc, t, sol.pos[:, 2]),
        "speed": np.interp(tc, t, np.hypot(sol.v_n[:, 0], sol.v_n[:, 1])),
        "fs": 1.0 / step,
        "bridged": bridged,
        "screened": int((~good).sum()),
        "height_sigma_m": float(np.sqrt(np.mean(sig_v**2))),
        "fixes": tuple(fixes),
        # the lost IMU rows' velocity error enters S (and its second difference) as in the LDV chain
        "imu_bridges": lost_increment_sigmas(inp, sol),
        "h_sigma_epochs": height_sigma_epochs(sol),
        "kind": "gnss",
        "accel_noise_ug_rthz": _accel_noise_ug_rthz(log),
    }
