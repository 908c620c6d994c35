"""Compiled loops: closed-loop forward filter (mechanization + error-state KF) and RTS smoother.

The mechanization runs at the IMU rate; the error-state covariance is propagated only at the
filter epochs, every ``decim`` IMU samples (Φ over the epoch from the mean specific force), and
the measurement updates happen there. Between epochs the LDV residual v̂_head − Ĉ_b^n V̂^b is
averaged; a GNSS fix is brought to the epoch (back-dated by v̂·Δt). Scalar sequential updates
with an innovation gate; after each epoch the estimate is fed back and the error state reset.

:func:`forward` is a short driver over one compiled routine per stage, as KF-GINS writes its
filter: per IMU sample the mechanization (:func:`mech_sample`), the LDV residual's sums
(:func:`_ldv_sample`) and the GNSS fix brought to the epoch (:func:`_gnss_sample`); per epoch the
covariance propagation (:func:`propagate_epoch`), the ZUPT, LDV and GNSS updates
(:func:`_zupt_update`, :func:`_ldv_update`, :func:`_gnss_update`), the feedback
(:func:`_feedback`) and what the smoother keeps (:func:`_checkpoint`). Its result is a
:class:`ForwardOut`, read by name.

Stored for the smoother (nothing per IMU sample): per epoch the 18 numbers Φ is built from,
Δt, the feedback dx and a record of the measurement updates (:data:`N_UPD` numbers: which rows
were taken, their H entries and variances); P⁺ itself (upper triangle) only every
:data:`CK_EVERY` epochs. The smoother redoes the covariances of each block from its checkpoint
with the same arithmetic, so the same numbers bit for bit, and runs backwards through it (see
:mod:`ldvsurvey.nav.filter` for the smoothing algebra). Memory is thus about (2n + 60)·8 bytes
per epoch whatever the IMU rate.

Inputs come grouped (:class:`ImuIn`, :class:`Model`, :class:`LdvIn`, :class:`GnssIn`,
:class:`Start`), and so do the working arrays of the stages (:class:`~ldvsurvey.nav.mech.NavState`,
:class:`Bias`, :class:`SampleWork`, :class:`CovWork`, :class:`KfWork`, :class:`LdvCal`,
:class:`GnssFix`): named tuples of arrays and scalars that numba compiles as they are. Handing
them to a stage costs nothing measurable, but reading their fields inside the per-sample loop
does (it made the forward pass twice as slow): the loop binds the arrays it touches to names once,
and the per-sample LDV stage takes plain arrays and one flat array of sums (:data:`N_LSUM`). The
work of a sample (:func:`mech_sample`), of an epoch's covariance propagation
(:func:`propagate_epoch`), the body attitude (:func:`c_bn_into`) and the feedback
(:func:`feedback_into`) are shared with the water-velocity damping filter
(:mod:`ldvsurvey.nav.damping`).

The state vector is indexed by name (:data:`~ldvsurvey.nav.errmodel.IX_PHI` … of
:mod:`ldvsurvey.nav.errmodel`). Augmented LDV states (when enabled, in this order after the 15):
δs_f, δη_L (rad), δφ_L (rad), δs_u, δk_η (rad per m/s²), where s = 1/K is the factor applied to
the measured speed (V_d = [0, s_f ν_f, s_u ν_u]) and the travel direction the LDV sees is pitched
by η_L + k_η·a_f, a_f the forward acceleration (the body's squat and dive under acceleration).
Inverse scales are estimated additively, so the feedback is linear like the smoother's algebra.
"""

from __future__ import annotations

from collections import namedtuple
from typing import NamedTuple

import numba as nb
import numpy as np

from ldvsurvey.nav.attitude import q_to_c_into
from ldvsurvey.nav.earth import radii_nb
from ldvsurvey.nav.errmodel import IX_EPS, IX_NABLA, IX_P, IX_PHI, IX_V, N_BASE, N_LDV_PAR, build_f_into, c_db
from ldvsurvey.nav.mech import NavState, mech_step_into

MAX_REJECT_RUN = 5  #: epochs of consecutive rejections after which a measurement is taken anyway
# The stages of the filter loop are compiled with inline="always": numba inlines them into the driver,
# so their struct arguments cost no call (as separate calls the forward pass took about 20 % longer)

#: the IMU: t (N,) s; dth, dvel (N, 3) sensor-frame increments (rad, m/s); c_bs (N, 3, 3) C_b^s per
#: sample, or (1, 3, 3) for a fixed IMU; xi, eta (rad), dg (m/s²) per sample for the gravity model, or empty
ImuIn = namedtuple("ImuIn", "t dth dvel c_bs xi eta dg")
#: the error model: decim (IMU samples per epoch), p0 (n,) prior variances, qd (n,) PSDs, inv_tau (n,)
#: 1/τ of Gauss–Markov states (1/s), zupt (M+1,) bool epochs standing still, zupt_sigma (m/s),
#: gate (σ, 0 = off), i_sz (index of the z-gyro scale-factor state, −1: none), i_sf (index of the first of
#: six scale-factor states, gyro x y z then accelerometer x y z, −1: none; never with i_sz), full (False:
#: keep only the attitude per sample; velocity, position and specific force come back empty), forces (with
#: full: keep the up specific force per sample too; False: it comes back empty, 16 bytes per sample less)
Model = namedtuple("Model", "decim p0 qd inv_tau zupt zupt_sigma gate i_sz i_sf full forces")
#: LDV: ok (N,) bool, nu_f, nu_u (N,) m/s, par0 (5,) [s_f, η_L, φ_L, s_u, k_η], lever (3,) m,
#: sigma (3,) m/s per sample, up (2-D LDV), aug_idx (5,) state index of each LDV state (−1: none),
#: a_fwd (N,) or empty: forward acceleration for the pitch compliance (m/s²)
LdvIn = namedtuple("LdvIn", "ok nu_f nu_u par0 lever sigma up aug_idx a_fwd")
#: GNSS: t (G,) s, pos (G, 3) lat, lon rad, h m of the antenna, sig (G, 2) 1-σ horizontal/vertical m, lever (3,) m
GnssIn = namedtuple("GnssIn", "t pos sig lever")
#: initial state: q (4,) C_s^n, v (3,) ENU m/s, pos (3,) lat, lon rad, h m, bias (6,) gyro rad/s, accel m/s²
Start = namedtuple("Start", "q v pos bias")

#: what Φ of an epoch is built from (stored per epoch): C_s^n (9), mean f^n (3), v (3), lat, h, mean ω_z,
#: mean ω^s (3) and f^s (3) in the sensor frame (written with the six scale-factor states only)
N_FIN = 24
#: offsets in a ``fin`` row: C_s^n (row-major), mean specific force in n (m/s²), v ENU (m/s),
#: latitude (rad), height (m), mean z rate (rad/s), mean rate ω^s (rad/s), mean specific force f^s (m/s²)
FIN_C, FIN_F, FIN_V, FIN_LAT, FIN_H, FIN_WZ, FIN_WS, FIN_FS = 0, 9, 12, 15, 16, 17, 18, 21
#: the scale-factor estimates a sample's mechanization removes: none, the z gyro's, all six
SF_NONE, SF_Z, SF_ALL = 0, 1, 6

#: per-epoch record of the measurement updates, enough to redo them on the covariance alone:
#: [0] ZUPT done, [1:4] its rows taken; [4] LDV done, [5:8] rows taken, [8:11] r, [11:14] v̄_l
#: (attitude columns), [14:29] LDV-state columns H[i, aug] (i·5 + a); [29] GNSS done, [30:33] rows
#: taken, [33:36] C_b^n l (attitude columns), [36:39] r
N_UPD = 39
#: offsets in an update record (see :data:`N_UPD`)
U_ZUPT, U_ZUPT_TAKEN = 0, 1
U_LDV, U_LDV_TAKEN, U_LDV_R, U_LDV_VL, U_LDV_COLS = 4, 5, 8, 11, 14
U_GNSS, U_GNSS_TAKEN, U_GNSS_LEV, U_GNSS_R = 29, 30, 33, 36
#: epochs between stored covariances: the smoother redoes the ones between (bit for bit)
CK_EVERY = 64
#: measurement kinds (rows of the rejection counters; blocks of three columns of the normalized innovations)
K_ZUPT, K_LDV, K_GNSS = 0, 1, 2


class Bias(NamedTuple):
    """The bias estimates the mechanization removes, (3,) each in the sensor frame; the feedback
    updates them in place."""

    gyro_rps: np.ndarray  #: rad/s
    accel_mps2: np.ndarray  #: m/s²


class SampleWork(NamedTuple):
    """A sample's corrected increments and mean specific force, and their sum over the epoch, (3,) each."""

    dth_rad: np.ndarray  #: the angle increment with the bias (and z scale factor) removed, rad
    dv_mps: np.ndarray  #: the velocity increment with the bias removed, m/s
    f_n_mps2: np.ndarray  #: mean specific force in n over the interval, m/s²
    fsum_n_mps: np.ndarray  #: Σ f_n dt over the epoch so far, m/s


class ProcessModel(NamedTuple):
    """What the covariance propagation and its replay by the smoother need beyond Φ's inputs."""

    qd: np.ndarray  #: (n,) driving-noise PSDs, state unit² per s
    inv_tau_ps: np.ndarray  #: (n,) 1/τ of the Gauss–Markov states, 1/s (0: none)
    i_sz: int  #: index of the z-gyro scale-factor state, −1: none
    i_sf: int  #: index of the first of the six scale-factor states (gyro x y z, accel x y z), −1: none
    aug_idx: np.ndarray  #: (5,) state index of each LDV state, −1: none
    zupt_sigma_mps: float  #: 1-σ of a zero-velocity measurement, m/s


class CovWork(NamedTuple):
    """The covariance and the epoch's work space, (n, n) each."""

    P: np.ndarray  #: the covariance of the error state (state units²), updated in place
    P_next: np.ndarray  #: work: Φ P Φᵀ + Q T before it is copied to P
    Phi: np.ndarray  #: the epoch's transition matrix Φ
    M: np.ndarray  #: work: Φ P


class KfWork(NamedTuple):
    """The measurement update's state and work space."""

    x: np.ndarray  #: (n,) error state (φ rad, δv m/s, δp m, ε rad/s, ∇ m/s², augmented)
    P: np.ndarray  #: (n, n) its covariance (the array of :attr:`CovWork.P`)
    H: np.ndarray  #: (3, n) rows of the measurement matrix
    r: np.ndarray  #: (3,) their variances (measurement unit²)
    z: np.ndarray  #: (3,) work: a measurement
    ph: np.ndarray  #: (n,) work: P h
    nz: np.ndarray  #: (n,) int work: the non-zero columns of an H row
    run: np.ndarray  #: (3,) int: consecutive epochs with a rejection, per measurement kind
    rejected: np.ndarray  #: (3,) int: rejections per measurement kind
    u: np.ndarray  #: (3, 5) work: the LDV columns ∂V^b/∂(LDV states) in b, before C̄_b^n


#: the LDV residual's sums over the current epoch, one flat array (divided by the count at the update):
#: Σ v̂ + C_b^n (ω × l) − v_l (3, m/s), Σ v_l = C_b^n C_d^b V^d (3, m/s), Σ V^d in the head frame (3,
#: m/s), Σ measured forward and up speeds (2, m/s), Σ V^d a_f (3, m²/s³: the pitch-compliance column),
#: Σ C_b^n (9, row-major), Σ a_f (m/s²), the number of samples
L_Z, L_VL, L_VD, L_NU, L_VDA, L_C, L_A, L_N, N_LSUM = 0, 3, 6, 9, 11, 14, 23, 24, 25


class LdvCal(NamedTuple):
    """The LDV calibration as the filter currently holds it."""

    par: np.ndarray  #: (5,) [s_f, η_L (rad), φ_L (rad), s_u, k_η (rad per m/s²)], updated by the feedback
    c_db: np.ndarray  #: (3, 3) C_d^b of η_L, φ_L: rewritten at each feedback
    r_mps2: np.ndarray  #: (3,) variance of one sample's residual, (m/s)²
    use_k: bool  #: the pitch compliance enters (a state, or a non-zero k_η, with a_f given)


class GnssFix(NamedTuple):
    """The GNSS fix brought to the coming epoch."""

    z_m: np.ndarray  #: (3,) INS − GNSS at the antenna, local metres E, N, U
    c_bn: np.ndarray  #: (3, 3) C_b^n at the fix
    sig_m: np.ndarray  #: (2,) its 1-σ horizontal and vertical, m
    idx: np.ndarray  #: (2,) int: [the next fix, 1 when one is pending]


class ForwardOut(NamedTuple):
    """What :func:`forward` returns: per IMU sample (N) and per filter epoch (M+1, epoch 0 the start)."""

    q_sn: np.ndarray  #: (N, 4) C_s^n
    v_n_mps: np.ndarray  #: (N, 3) ENU, or (0, 3) for an attitude-only run
    pos_rad_m: np.ndarray  #: (N, 3) lat (rad), lon (rad), h (m), or (0, 3)
    f_u_mps2: np.ndarray  #: (N,) up specific force in n over each interval as integrated, or (0,)
    f_en_mps2: np.ndarray  #: (N, 2) float32 its E, N components (the smoother's φ × f), or (0, 2)
    f_b_mps2: np.ndarray  #: (N,) (C_s^n b̂_a)_U, or (0,)
    ck_packed: np.ndarray  #: (M // CK_EVERY + 1, n(n+1)/2) P⁺ every CK_EVERY epochs, upper triangle
    upd: np.ndarray  #: (M+1, N_UPD) the measurement-update records
    sigma: np.ndarray  #: (M+1, n) forward 1-σ of the states
    fin: np.ndarray  #: (M+1, N_FIN) what Φ of each epoch is built from
    dt_s: np.ndarray  #: (M+1,) epoch lengths, s
    dx: np.ndarray  #: (M+1, n) the error state fed back at each epoch
    ldv_par: np.ndarray  #: (M+1, 5) the LDV calibration after each epoch (see :class:`LdvCal`)
    bias: np.ndarray  #: (M+1, 6) gyro (rad/s) and accelerometer (m/s²) bias estimates
    nis: np.ndarray  #: (M+1, 9) normalized innovations: ZUPT (3), LDV (3), GNSS (3); NaN: none
    rejected: np.ndarray  #: (3,) int: rejections per measurement kind (ZUPT, LDV, GNSS)
    gyro_scale_z: np.ndarray  #: (M+1,) the z-gyro scale-factor estimate (0 when not a state)
    scale: np.ndarray  #: (M+1, 6) gyro x y z and accelerometer x y z scale-factor estimates, or (0, 6)


class Record(NamedTuple):
    """The forward pass as the smoother replays it (the fields of :class:`ForwardOut` of the same names)."""

    ck_packed: np.ndarray
    upd: np.ndarray
    fin: np.ndarray
    dt_s: np.ndarray
    dx: np.ndarray


class Trajectory(NamedTuple):
    """The per-sample results :func:`apply_corrections` corrects (the fields of :class:`ForwardOut`)."""

    q_sn: np.ndarray
    v_n_mps: np.ndarray
    pos_rad_m: np.ndarray
    f_u_mps2: np.ndarray
    f_en_mps2: np.ndarray
    f_b_mps2: np.ndarray


@nb.njit(cache=True, inline="always")
def feedback_into(x, nav, bias):
    """Closed-loop reset of the 15 base states, in place.

    C ← (I + [φ×]) C, v ← v − δv, p ← p − δp (metres to lat/lon), biases += estimates; the previous
    velocity/position (used for mid-interval extrapolation) get the same correction. Shared with
    :mod:`ldvsurvey.nav.damping`.

    Parameters
    ----------
    x : (n,) error state: φ (rad), δv (m/s), δp (m, E N U), ε (rad/s), ∇ (m/s²), …
    nav : :class:`~ldvsurvey.nav.mech.NavState`, corrected in place.
    bias : :class:`Bias`, corrected in place.
    """
    q, v, pos, v_prev, pos_prev = nav.q_sn, nav.v_n_mps, nav.pos_rad_m, nav.v_prev_n_mps, nav.pos_prev_rad_m
    b_g, b_a = bias.gyro_rps, bias.accel_mps2
    c, s = _rv(x[IX_PHI], x[IX_PHI + 1], x[IX_PHI + 2])
    a0, a1, a2, a3 = c, s * x[IX_PHI], s * x[IX_PHI + 1], s * x[IX_PHI + 2]
    w, qx, qy, qz = q[0], q[1], q[2], q[3]
    n0 = a0 * w - a1 * qx - a2 * qy - a3 * qz
    n1 = a0 * qx + a1 * w + a2 * qz - a3 * qy
    n2 = a0 * qy - a1 * qz + a2 * w + a3 * qx
    n3 = a0 * qz + a1 * qy - a2 * qx + a3 * w
    nq = np.sqrt(n0 * n0 + n1 * n1 + n2 * n2 + n3 * n3)
    q[0], q[1], q[2], q[3] = n0 / nq, n1 / nq, n2 / nq, n3 / nq
    rm, rn = radii_nb(pos[0])
    d0 = x[IX_P + 1] / (rm + pos[2])
    d1 = x[IX_P] / ((rn + pos[2]) * np.cos(pos[0]))
    d2 = x[IX_P + 2]
    for i in range(3):
        v[i] -= x[IX_V + i]
        v_prev[i] -= x[IX_V + i]
        b_g[i] += x[IX_EPS + i]
        b_a[i] += x[IX_NABLA + i]
    pos[0] -= d0
    pos[1] -= d1
    pos[2] -= d2
    pos_prev[0] -= d0
    pos_prev[1] -= d1
    pos_prev[2] -= d2


@nb.njit(cache=True, inline="always")
def mech_sample(imu, k, dt, nav, bias, sf, n_sf, wk):
    """Mechanize IMU sample k with the bias (and z scale-factor) estimates removed.

    The work of every sample of the filters (this module's and :mod:`ldvsurvey.nav.damping`).

    Parameters
    ----------
    imu : :class:`ImuIn`.
    k : the sample's index.
    dt : the interval it ends, s.
    nav : :class:`~ldvsurvey.nav.mech.NavState`, advanced in place (see
        :func:`~ldvsurvey.nav.mech.mech_step_into`); its previous increments ← the corrected ones.
    bias : :class:`Bias` estimates, rad/s and m/s².
    sf : (6,) scale-factor estimates (dimensionless) of the gyros x y z and accelerometers x y z.
    n_sf : which are removed: :data:`SF_NONE`, :data:`SF_Z` (the z gyro's, ``sf[2]``), :data:`SF_ALL`.
    wk : :class:`SampleWork`: the corrected increments and f_n written, fsum += f_n dt.

    Returns
    -------
    float
        The corrected z-gyro increment, rad (for the epoch's mean ω_z).
    """
    a_th, a_dv, f_n, fsum = wk.dth_rad, wk.dv_mps, wk.f_n_mps2, wk.fsum_n_mps
    b_g, b_a, dth, dvel = bias.gyro_rps, bias.accel_mps2, imu.dth, imu.dvel
    gx = imu.xi[k] if len(imu.xi) > 0 else 0.0
    ge = imu.eta[k] if len(imu.xi) > 0 else 0.0
    gd = imu.dg[k] if len(imu.xi) > 0 else 0.0
    for i in range(3):
        a_th[i] = dth[k, i] - b_g[i] * dt
    if n_sf == SF_Z:  # z-gyro scale factor: ω̃_z = (1 + s_z) ω_z
        a_th[2] -= sf[2] * a_th[2]
    for i in range(3):
        a_dv[i] = dvel[k, i] - b_a[i] * dt
    if n_sf == SF_ALL:  # ω̃ = (1 + s_g) ω, f̃ = (1 + s_a) f per axis (to first order in s)
        for i in range(3):
            a_th[i] -= sf[i] * a_th[i]
            a_dv[i] -= sf[3 + i] * a_dv[i]
    mech_step_into(nav, a_th, a_dv, dt, gx, ge, gd, f_n)
    dth_prev, dv_prev = nav.dth_prev_rad, nav.dv_prev_mps
    for i in range(3):
        dth_prev[i] = a_th[i]
        dv_prev[i] = a_dv[i]
        fsum[i] += f_n[i] * dt
    return a_th[2]


@nb.njit(cache=True, inline="always")
def propagate_epoch(fin_j, c_sn, fsum_n_mps, ssum, nav, dt_s, proc, cov):
    """Covariance propagation over an epoch: P ← Φ P Φᵀ + diag(qd) T.

    The same for this module's filter and the damping one.

    Parameters
    ----------
    fin_j : (:data:`N_FIN`,) written: what Φ is built from (C_s^n, mean specific force
        fsum_n_mps / T, v, lat, h, mean ω_z = ssum[2] / T, mean ω^s and f^s = ssum / T).
    c_sn : (3, 3) C_s^n at the epoch.
    fsum_n_mps : (3,) Σ f_n dt over the epoch, m/s.
    ssum : (6,) Σ of the corrected sensor increments over the epoch, rad and m/s (read with scale-factor
        states: the z gyro's alone, or all six).
    nav : :class:`~ldvsurvey.nav.mech.NavState` at the epoch (v, lat, h read).
    dt_s : the epoch's length T, s.
    proc : :class:`ProcessModel`.
    cov : :class:`CovWork`: P updated in place, Φ left in ``cov.Phi``.
    """
    T = dt_s
    v, pos = nav.v_n_mps, nav.pos_rad_m
    for i in range(3):
        for jj in range(3):
            fin_j[FIN_C + 3 * i + jj] = c_sn[i, jj]
        fin_j[FIN_F + i] = fsum_n_mps[i] / T
        fin_j[FIN_V + i] = v[i]
    fin_j[FIN_LAT], fin_j[FIN_H], fin_j[FIN_WZ] = pos[0], pos[2], ssum[2] / T
    if proc.i_sf >= 0:
        for i in range(3):
            fin_j[FIN_WS + i] = ssum[i] / T
            fin_j[FIN_FS + i] = ssum[3 + i] / T
    # M and P_next: written only after Φ is complete
    _phi_into(fin_j, T, proc.inv_tau_ps, proc.i_sz, proc.i_sf, cov.Phi, cov.M, cov.P_next[0])
    _propagate(cov.P, cov.Phi, proc.qd, T, cov.M, cov.P_next)
    cov.P[:, :] = cov.P_next


@nb.njit(cache=True)
def _phi_into(fin, T, inv_tau, i_sz, i_sf, Phi, A, sq):
    """Φ = I + F T + (F T)²/2 of one epoch into ``Phi`` (n×n), F from the stored ``fin`` row;
    ``A`` (n×n) and ``sq`` (n,) are work space (overwritten: no allocation per epoch).

    Rows 9.. of F (biases, LDV and scale-factor states) hold only their diagonal (−1/τ), so the
    square needs the full sum only in the first nine rows."""
    n = Phi.shape[0]
    c_sn = fin[FIN_C : FIN_C + 9].reshape((3, 3))
    A[:, :] = 0.0
    build_f_into(A, c_sn, fin[FIN_F : FIN_F + 3], fin[FIN_V : FIN_V + 3], fin[FIN_LAT], fin[FIN_H])
    if i_sz >= 0:  # φ̇ = −C_s^n δω^s, δω^s = [0, 0, δs_z ω_z]
        for i in range(3):
            A[IX_PHI + i, i_sz] = -c_sn[i, 2] * fin[FIN_WZ]
    if i_sf >= 0:  # δω^s = diag(ω^s) δs_g, δf^s = diag(f^s) δs_a: φ̇ = −C_s^n δω^s, δv̇ = C_s^n δf^s
        for i in range(3):
            for jj in range(3):
                A[IX_PHI + i, i_sf + jj] = -c_sn[i, jj] * fin[FIN_WS + jj]
                A[IX_V + i, i_sf + 3 + jj] = c_sn[i, jj] * fin[FIN_FS + jj]
    for i in range(n):  # first-order Gauss–Markov states (bias instability): ẋ = −x/τ + w
        A[i, i] -= inv_tau[i]
    for i in range(n):
        for jj in range(n):
            A[i, jj] *= T
    for i in range(n):
        if i < IX_EPS:  # the navigation rows φ, δv, δp
            sq[:] = 0.0
            for k in range(n):  # row i of A², skipping the zeros of A (about half)
                aik = A[i, k]
                if aik != 0.0:
                    for jj in range(n):
                        sq[jj] += aik * A[k, jj]
            for jj in range(n):
                Phi[i, jj] = ((1.0 if i == jj else 0.0) + A[i, jj]) + 0.5 * sq[jj]
        else:
            for jj in range(n):
                Phi[i, jj] = 0.0
            Phi[i, i] = (1.0 + A[i, i]) + 0.5 * (A[i, i] * A[i, i])


@nb.njit(cache=True)
def _propagate(P, Phi, qd, T, M, out):
    """out = Φ P Φᵀ + diag(qd) T; M = Φ P (both n×n, written). Rows IX_EPS.. of Φ (biases and augmented
    states) are diagonal."""
    n = P.shape[0]
    for i in range(n):
        if i < IX_EPS:
            for jj in range(n):
                M[i, jj] = 0.0
            for k in range(n):
                f = Phi[i, k]
                if f != 0.0:
                    for jj in range(n):
                        M[i, jj] += f * P[k, jj]
        else:
            d = Phi[i, i]
            for jj in range(n):
                M[i, jj] = d * P[i, jj]
    for i in range(n):  # Φ P Φᵀ is symmetric: the upper triangle, mirrored
        for jj in range(i, n):
            if jj < IX_EPS:
                s = 0.0
                for k in range(n):
                    s += M[i, k] * Phi[jj, k]
            else:
                s = M[i, jj] * Phi[jj, jj]
            out[i, jj] = s
            out[jj, i] = s
        out[i, i] += qd[i] * T


@nb.njit(cache=True)
def _pack(P, row):
    """Upper triangle of P (row-major) into ``row``."""
    n = P.shape[0]
    idx = 0
    for i in range(n):
        for jj in range(i, n):
            row[idx] = P[i, jj]
            idx += 1


@nb.njit(cache=True)
def _unpack(row, P):
    """P (n×n, symmetric) from its upper triangle ``row`` (row-major), the inverse of :func:`_pack`."""
    n = P.shape[0]
    idx = 0
    for i in range(n):
        for jj in range(i, n):
            P[i, jj] = row[idx]
            P[jj, i] = row[idx]
            idx += 1


@nb.njit(cache=True)
def _cov_row(P, H, row, r, ph, nz):
    """P h and s = hᵀ P h + r for row ``row`` of H (its non-zeros only); ph (n,) written. Returns s."""
    n = P.shape[0]
    n_nz = 0  # H rows are sparse (a few attitude, velocity or position and LDV columns)
    for jj in range(n):
        if H[row, jj] != 0.0:
            nz[n_nz] = jj
            n_nz += 1
    for i in range(n):
        ph[i] = 0.0
    for a in range(n_nz):  # column by column: each ph[i] still summed over the non-zeros in order
        c = nz[a]
        h = H[row, c]
        for i in range(n):
            ph[i] += P[i, c] * h
    hph = 0.0
    for a in range(n_nz):
        hph += H[row, nz[a]] * ph[nz[a]]
    return hph + r


@nb.njit(cache=True)
def _cov_apply(P, ph, s):
    """P ← P − k (P h)ᵀ with k = P h / s (in place)."""
    n = P.shape[0]
    for i in range(n):
        k_i = ph[i] / s
        for jj in range(n):
            P[i, jj] -= k_i * ph[jj]


@nb.njit(cache=True, inline="always")
def _update_rows(kf, z, gate, kind, nis_row, taken):
    """Scalar updates for the rows of one measurement type (H, r in ``kf``) with the innovation gate
    and its lock-out protection: after MAX_REJECT_RUN epochs with a rejection the gate is lifted.

    ``kind`` indexes ``kf.run``/``kf.rejected``; normalized innovations go to ``nis_row``, 1/0 (taken
    or rejected) to ``taken``. In place, no allocation."""
    x, P, H, r, ph, nz, run, rejected = kf.x, kf.P, kf.H, kf.r, kf.ph, kf.nz, kf.run, kf.rejected
    n = P.shape[0]
    g_eff = gate if run[kind] < MAX_REJECT_RUN else 0.0
    any_rej = False
    for row in range(H.shape[0]):
        s = _cov_row(P, H, row, r[row], ph, nz)
        hx = 0.0
        for i in range(n):
            hx += H[row, i] * x[i]
        nu = z[row] - hx
        nis_row[row] = nu / np.sqrt(s)
        if g_eff > 0 and nu * nu > g_eff * g_eff * s:
            rejected[kind] += 1
            any_rej = True
            taken[row] = 0.0
            continue
        taken[row] = 1.0
        for i in range(n):
            x[i] += ph[i] / s * nu
        _cov_apply(P, ph, s)
    run[kind] = run[kind] + 1 if any_rej else 0


@nb.njit(cache=True, inline="always")
def _h_att_cross(H, a0, a1, a2):
    """The attitude columns of H's three rows ← [a×]."""
    H[0, IX_PHI + 1], H[0, IX_PHI + 2] = -a2, a1
    H[1, IX_PHI], H[1, IX_PHI + 2] = a2, -a0
    H[2, IX_PHI], H[2, IX_PHI + 1] = -a1, a0


@nb.njit(cache=True, inline="always")
def _h_att_neg_cross(H, a0, a1, a2):
    """The attitude columns of H's three rows ← −[a×]."""
    H[0, IX_PHI + 1], H[0, IX_PHI + 2] = a2, -a1
    H[1, IX_PHI], H[1, IX_PHI + 2] = -a2, a0
    H[2, IX_PHI], H[2, IX_PHI + 1] = a1, -a0


@nb.njit(cache=True, inline="always")
def _zupt_update(kf, v_n_mps, zupt_r, gate, rec, nis_j):
    """The zero-velocity update of an epoch standing still: z = v̂ (m/s), variance ``zupt_r`` (m/s)²;
    recorded in ``rec`` (an :data:`N_UPD` row), normalized innovations in ``nis_j`` (9,)."""
    H, r = kf.H, kf.r
    H[:, :] = 0.0
    for i in range(3):
        H[i, IX_V + i] = 1.0
        r[i] = zupt_r
    rec[U_ZUPT] = 1.0
    _update_rows(kf, v_n_mps, gate, K_ZUPT, nis_j[0:3], rec[U_ZUPT_TAKEN : U_ZUPT_TAKEN + 3])


@nb.njit(cache=True, inline="always")
def _ldv_update(kf, aug_idx, lsum, cal, gate, rec, nis_j):
    """The LDV velocity update from the epoch's mean residual (``lsum``, :data:`N_LSUM`): H =
    [−[v̄_l×], I, 0, LDV columns]; recorded in ``rec`` (an :data:`N_UPD` row), normalized
    innovations in ``nis_j`` (9,)."""
    H, r3, zl, ub, par, cdb = kf.H, kf.r, kf.z, kf.u, cal.par, cal.c_db
    lz, lvl, lvd, lnu = lsum[L_Z : L_Z + 3], lsum[L_VL : L_VL + 3], lsum[L_VD : L_VD + 3], lsum[L_NU : L_NU + 2]
    lvda, lc = lsum[L_VDA : L_VDA + 3], lsum[L_C : L_C + 9].reshape((3, 3))
    la, ln = lsum[L_A], lsum[L_N]
    for i in range(3):
        zl[i] = lz[i] / ln
        r3[i] = cal.r_mps2[i] / ln
    v_l0, v_l1, v_l2 = lvl[0] / ln, lvl[1] / ln, lvl[2] / ln
    vd1, vd2 = lvd[1] / ln, lvd[2] / ln
    ch = c_db(par[1] + par[4] * la / ln, par[2]) if cal.use_k else cdb
    # the LDV columns, each −C̄_b^n (C_d^b u): u = ∂V^d/∂(s_f, η_L, φ_L, s_u, k_η) in the frames below
    #   s_f: [0, ν̄_f, 0] (d); η_L: e_1 × V̄^d = [0, −vd2, vd1] (d); φ_L: e_3 × (C_d^b V̄^d) (b);
    #   s_u: [0, 0, ν̄_u] (d); k_η: e_1 × mean(V^d a_f) = [0, −Σvd2 a/n, Σvd1 a/n] (d)
    nu0, nu1 = lnu[0] / ln, lnu[1] / ln
    w0 = ch[0, 1] * vd1 + ch[0, 2] * vd2
    w1 = ch[1, 1] * vd1 + ch[1, 2] * vd2
    ka, kb = -lvda[2] / ln, lvda[1] / ln
    for r in range(3):
        ub[r, 0] = ch[r, 1] * nu0
        ub[r, 1] = ch[r, 1] * (-vd2) + ch[r, 2] * vd1
        ub[r, 3] = ch[r, 2] * nu1
        ub[r, 4] = ch[r, 1] * ka + ch[r, 2] * kb
    ub[0, 2], ub[1, 2], ub[2, 2] = -w1, w0, 0.0
    H[:, :] = 0.0
    for i in range(3):
        for a in range(N_LDV_PAR):
            if aug_idx[a] >= 0:
                H[i, aug_idx[a]] = -(
                    (lc[i, 0] / ln) * ub[0, a] + (lc[i, 1] / ln) * ub[1, a] + (lc[i, 2] / ln) * ub[2, a]
                )
        H[i, IX_V + i] = 1.0
    _h_att_neg_cross(H, v_l0, v_l1, v_l2)  # attitude: −[v̄_l ×]
    rec[U_LDV] = 1.0
    for i in range(3):
        rec[U_LDV_R + i] = r3[i]
        for a in range(N_LDV_PAR):
            if aug_idx[a] >= 0:
                rec[U_LDV_COLS + N_LDV_PAR * i + a] = H[i, aug_idx[a]]
    rec[U_LDV_VL], rec[U_LDV_VL + 1], rec[U_LDV_VL + 2] = v_l0, v_l1, v_l2
    _update_rows(kf, zl, gate, K_LDV, nis_j[3:6], rec[U_LDV_TAKEN : U_LDV_TAKEN + 3])


@nb.njit(cache=True, inline="always")
def _gnss_update(kf, fix, lever_m, gate, rec, nis_j):
    """The GNSS position update from the pending fix: H = [[(C_b^n l)×], 0, I]; recorded in ``rec``
    (an :data:`N_UPD` row), normalized innovations in ``nis_j`` (9,); the fix is then consumed."""
    gc, l_gnss, gsig, r3 = fix.c_bn, lever_m, fix.sig_m, kf.r
    la0 = gc[0, 0] * l_gnss[0] + gc[0, 1] * l_gnss[1] + gc[0, 2] * l_gnss[2]
    la1 = gc[1, 0] * l_gnss[0] + gc[1, 1] * l_gnss[1] + gc[1, 2] * l_gnss[2]
    la2 = gc[2, 0] * l_gnss[0] + gc[2, 1] * l_gnss[1] + gc[2, 2] * l_gnss[2]
    H = kf.H
    H[:, :] = 0.0
    _h_att_cross(H, la0, la1, la2)  # [(C_b^n l) ×]
    for i in range(3):
        H[i, IX_P + i] = 1.0
    r3[0], r3[1], r3[2] = gsig[0] ** 2, gsig[0] ** 2, gsig[1] ** 2
    rec[U_GNSS] = 1.0
    rec[U_GNSS_LEV], rec[U_GNSS_LEV + 1], rec[U_GNSS_LEV + 2] = la0, la1, la2
    rec[U_GNSS_R], rec[U_GNSS_R + 1], rec[U_GNSS_R + 2] = r3[0], r3[1], r3[2]
    _update_rows(kf, fix.z_m, gate, K_GNSS, nis_j[6:9], rec[U_GNSS_TAKEN : U_GNSS_TAKEN + 3])
    fix.idx[1] = 0


@nb.njit(cache=True)
def _redo_updates(P, rec, aug_idx, zupt_r, H, ph, nz):
    """The measurement updates of one epoch on the covariance alone, from its record."""
    if rec[U_ZUPT] != 0.0:
        H[:, :] = 0.0
        for i in range(3):
            H[i, IX_V + i] = 1.0
        for row in range(3):
            if rec[U_ZUPT_TAKEN + row] != 0.0:
                s = _cov_row(P, H, row, zupt_r, ph, nz)
                _cov_apply(P, ph, s)
    if rec[U_LDV] != 0.0:
        H[:, :] = 0.0
        for i in range(3):
            for a in range(N_LDV_PAR):
                if aug_idx[a] >= 0:
                    H[i, aug_idx[a]] = rec[U_LDV_COLS + N_LDV_PAR * i + a]
            H[i, IX_V + i] = 1.0
        _h_att_neg_cross(H, rec[U_LDV_VL], rec[U_LDV_VL + 1], rec[U_LDV_VL + 2])
        for row in range(3):
            if rec[U_LDV_TAKEN + row] != 0.0:
                s = _cov_row(P, H, row, rec[U_LDV_R + row], ph, nz)
                _cov_apply(P, ph, s)
    if rec[U_GNSS] != 0.0:
        H[:, :] = 0.0
        _h_att_cross(H, rec[U_GNSS_LEV], rec[U_GNSS_LEV + 1], rec[U_GNSS_LEV + 2])
        for i in range(3):
            H[i, IX_P + i] = 1.0
        for row in range(3):
            if rec[U_GNSS_TAKEN + row] != 0.0:
                s = _cov_row(P, H, row, rec[U_GNSS_R + row], ph, nz)
                _cov_apply(P, ph, s)
    _symmetrize(P)


@nb.njit(cache=True)
def _symmetrize(P):
    """P ← (P + Pᵀ)/2 in place."""
    n = P.shape[0]
    for i in range(n):
        for jj in range(i + 1, n):
            a = 0.5 * (P[i, jj] + P[jj, i])
            P[i, jj] = a
            P[jj, i] = a


@nb.njit(cache=True, inline="always")
def _ldv_sample(meas, par, cdb, lever, c_bn, c_bn_prev, v, lsum):
    """Add an LDV sample to the epoch's sums ``lsum`` (:data:`N_LSUM`).

    V^b = C_d^b [0, s_f ν_f, s_u ν_u] (pitched by k_η a_f with the compliance), v_l = C_b^n V^b and
    the residual v̂ + C_b^n (ω × l) − v_l, the body rate ω from the attitude change c_bn_prev → c_bn.
    ``meas`` = (dt (s), ν_f, ν_u (m/s, 0 for a 1-D LDV), a_f (m/s²), 2-D LDV, compliance used);
    ``par`` the LDV calibration (5,), ``cdb`` C_d^b, ``lever`` (3,) m, ``v`` v̂ (3,) m/s. Arrays and
    scalars only (a struct's fields cost several times this arithmetic in the per-sample path) and
    no small-array allocation."""
    dt, nu_f, nu_u, ak, up, use_k = meas
    vd1 = nu_f * par[0]
    vd2 = (nu_u * par[3]) if up else 0.0
    if use_k:  # C_d^b(η_L + k a, φ_L): forward and up columns
        ee = par[1] + par[4] * ak
        ce, se = np.cos(ee), np.sin(ee)
        cp, sp = cdb[0, 0], cdb[1, 0]  # cos φ_L, sin φ_L: computed once per epoch, in C_d^b
        vb0 = -sp * ce * vd1 + sp * se * vd2
        vb1 = cp * ce * vd1 - cp * se * vd2
        vb2 = se * vd1 + ce * vd2
        lsum[L_VDA + 1] += vd1 * ak
        lsum[L_VDA + 2] += vd2 * ak
        lsum[L_A] += ak
    else:
        vb0 = cdb[0, 1] * vd1 + cdb[0, 2] * vd2
        vb1 = cdb[1, 1] * vd1 + cdb[1, 2] * vd2
        vb2 = cdb[2, 1] * vd1 + cdb[2, 2] * vd2
    # body rate from the attitude change: antisymmetric part of C_prevᵀ C
    r21 = r12 = r02 = r20 = r10 = r01 = 0.0
    for i in range(3):
        r21 += c_bn_prev[i, 2] * c_bn[i, 1]
        r12 += c_bn_prev[i, 1] * c_bn[i, 2]
        r02 += c_bn_prev[i, 0] * c_bn[i, 2]
        r20 += c_bn_prev[i, 2] * c_bn[i, 0]
        r10 += c_bn_prev[i, 1] * c_bn[i, 0]
        r01 += c_bn_prev[i, 0] * c_bn[i, 1]
    w0 = (r21 - r12) / (2.0 * dt)
    w1 = (r02 - r20) / (2.0 * dt)
    w2 = (r10 - r01) / (2.0 * dt)
    a0 = w1 * lever[2] - w2 * lever[1]
    a1 = w2 * lever[0] - w0 * lever[2]
    a2 = w0 * lever[1] - w1 * lever[0]
    for i in range(3):
        vl_i = c_bn[i, 0] * vb0 + c_bn[i, 1] * vb1 + c_bn[i, 2] * vb2
        lsum[L_Z + i] += v[i] + c_bn[i, 0] * a0 + c_bn[i, 1] * a1 + c_bn[i, 2] * a2 - vl_i
        lsum[L_VL + i] += vl_i
        for jj in range(3):
            lsum[L_C + 3 * i + jj] += c_bn[i, jj]
    lsum[L_VD + 1] += vd1
    lsum[L_VD + 2] += vd2
    lsum[L_NU] += nu_f
    lsum[L_NU + 1] += nu_u if up else 0.0
    lsum[L_N] += 1.0


@nb.njit(cache=True, inline="always")
def _gnss_sample(gnss, t_k, nav, c_bn, fix):
    """Bring the GNSS fixes in (t_{k−1}, t_k] to the coming epoch: INS − GNSS at the antenna in
    local metres, back-dated by v̂ (t_k − t_fix); the last one is kept in ``fix``, marked pending."""
    g_t, g_pos, g_sig, l_gnss = gnss.t, gnss.pos, gnss.sig, gnss.lever
    pos, v, gz = nav.pos_rad_m, nav.v_n_mps, fix.z_m
    gi = fix.idx[0]
    while gi < len(g_t) and g_t[gi] <= t_k:
        rm, rn = radii_nb(pos[0])
        back = t_k - g_t[gi]
        lev0 = c_bn[0, 0] * l_gnss[0] + c_bn[0, 1] * l_gnss[1] + c_bn[0, 2] * l_gnss[2]
        lev1 = c_bn[1, 0] * l_gnss[0] + c_bn[1, 1] * l_gnss[1] + c_bn[1, 2] * l_gnss[2]
        lev2 = c_bn[2, 0] * l_gnss[0] + c_bn[2, 1] * l_gnss[1] + c_bn[2, 2] * l_gnss[2]
        gz[0] = (pos[1] - g_pos[gi, 1]) * (rn + pos[2]) * np.cos(pos[0]) + lev0 - v[0] * back
        gz[1] = (pos[0] - g_pos[gi, 0]) * (rm + pos[2]) + lev1 - v[1] * back
        gz[2] = pos[2] - g_pos[gi, 2] + lev2 - v[2] * back
        fix.c_bn[:, :] = c_bn
        fix.sig_m[0], fix.sig_m[1] = g_sig[gi, 0], g_sig[gi, 1]
        fix.idx[1] = 1
        gi += 1
    fix.idx[0] = gi


@nb.njit(cache=True, inline="always")
def _feedback(x, nav, bias, cal, aug_idx):
    """Feed the epoch's estimate back: the 15 base states (:func:`feedback_into`) and the LDV
    calibration (its inverse scales and angles − their errors, C_d^b rebuilt)."""
    feedback_into(x, nav, bias)
    for a in range(N_LDV_PAR):
        if aug_idx[a] >= 0:
            cal.par[a] -= x[aug_idx[a]]
    cal.c_db[:, :] = c_db(cal.par[1], cal.par[2])


@nb.njit(cache=True, inline="always")
def _checkpoint(out, j, x, P, par, bias):
    """What epoch j keeps for the smoother and the results: the fed-back dx, P⁺ (packed, every
    :data:`CK_EVERY` epochs), the 1-σ, the LDV calibration and the biases."""
    out.dx[j] = x
    if j % CK_EVERY == 0:
        _pack(P, out.ck_packed[j // CK_EVERY])
    sig = out.sigma
    for i in range(P.shape[0]):
        sig[j, i] = np.sqrt(max(P[i, i], 0.0))
    out.ldv_par[j] = par
    out.bias[j, :3], out.bias[j, 3:] = bias.gyro_rps, bias.accel_mps2


@nb.njit(cache=True, inline="always")
def _store_sample(q_out, v_out, p_out, k, q, v, pos, full):
    """Sample k of the results: the attitude, and velocity and position unless attitude only."""
    for i in range(4):
        q_out[k, i] = q[i]
    for i in range(3):
        if full:
            v_out[k, i] = v[i]
            p_out[k, i] = pos[i]


@nb.njit(cache=True, inline="always")
def _store_forces(fu_out, fen_out, fb_out, k, f_n, c_sn, b_a):
    """Sample k's specific force in n as integrated (up; E, N as float32) and (C_s^n b̂_a)_U."""
    fu_out[k] = f_n[2]
    fen_out[k, 0] = f_n[0]
    fen_out[k, 1] = f_n[1]
    fb_out[k] = c_sn[2, 0] * b_a[0] + c_sn[2, 1] * b_a[1] + c_sn[2, 2] * b_a[2]


@nb.njit(cache=True, inline="always")
def _reset_sums(wk, lsum):
    """Zero the epoch's sums (specific force, LDV residual) after its update."""
    wk.fsum_n_mps[:] = 0.0
    lsum[:] = 0.0


@nb.njit(cache=True)
def _alloc_out(n_s, m, n, mdl):
    """The :class:`ForwardOut` of n_s samples, m epochs (+ the start) and n states, to be filled."""
    n_o = n_s if mdl.full else 0  # attitude only: no per-sample velocity, position or specific force
    n_f = n_s if mdl.full and mdl.forces else 0
    return ForwardOut(
        np.empty((n_s, 4)),
        np.empty((n_o, 3)),
        np.empty((n_o, 3)),
        np.empty(n_f),
        np.empty((n_f, 2), dtype=np.float32),
        np.empty(n_f),
        np.empty((m // CK_EVERY + 1, n * (n + 1) // 2)),
        np.zeros((m + 1, N_UPD)),
        np.empty((m + 1, n)),
        np.zeros((m + 1, N_FIN)),
        np.zeros(m + 1),
        np.zeros((m + 1, n)),
        np.empty((m + 1, N_LDV_PAR)),
        np.empty((m + 1, 6)),
        np.full((m + 1, 9), np.nan),
        np.zeros(3, dtype=np.int64),
        np.zeros(m + 1),
        np.zeros((m + 1 if mdl.i_sf >= 0 else 0, 6)),
    )


@nb.njit(cache=True)
def _is_rotating(c_bs, n_s):
    """Whether C_b^s ((n_s, 3, 3), or (1, 3, 3): fixed) differs from the identity (sampled at 50
    places): a fixed IMU's identity skips the products."""
    if c_bs.shape[0] > 1:
        for kk in range(0, n_s, max(1, n_s // 50)):
            if np.abs(c_bs[kk] - np.eye(3)).max() > 0.0:
                return True
    return False


@nb.njit(cache=True)
def forward(imu, mdl, ldv, gnss, st):
    """Run the forward filter. See the Python wrapper :func:`ldvsurvey.nav.filter.run_filter`.

    Parameters
    ----------
    imu : :class:`ImuIn`, the increments and the gravity model per sample.
    mdl : :class:`Model`, the error model and what to keep.
    ldv : :class:`LdvIn` (no usable sample: no LDV update).
    gnss : :class:`GnssIn` (no fix: no GNSS update).
    st : :class:`Start`, the state at the start of the first interval.

    Returns
    -------
    ForwardOut
        Per IMU sample the attitude, velocity, position and specific force; per epoch what the
        smoother replays, the 1-σ, LDV calibration, biases and normalized innovations.
    """
    t, c_bs, decim, i_sz, i_sf, gate = imu.t, imu.c_bs, mdl.decim, mdl.i_sz, mdl.i_sf, mdl.gate
    n_s, n = len(t), len(mdl.p0)
    out = _alloc_out(n_s, n_s // decim, n, mdl)
    full, forces = mdl.full, mdl.full and mdl.forces
    nav = NavState(
        st.q.copy(), st.v.copy(), st.pos.copy(), st.v.copy(), st.pos.copy(), imu.dth[0].copy(), imu.dvel[0].copy()
    )
    bias = Bias(st.bias[:3].copy(), st.bias[3:].copy())
    wk = SampleWork(np.empty(3), np.empty(3), np.empty(3), np.zeros(3))
    proc = ProcessModel(mdl.qd, mdl.inv_tau, i_sz, i_sf, ldv.aug_idx, mdl.zupt_sigma)
    cov = CovWork(np.diag(mdl.p0), np.empty((n, n)), np.empty((n, n)), np.empty((n, n)))
    kf = KfWork(
        np.zeros(n),
        cov.P,
        np.zeros((3, n)),
        np.empty(3),
        np.empty(3),
        np.empty(n),
        np.empty(n, dtype=np.int64),
        np.zeros(3, dtype=np.int64),
        out.rejected,
        np.empty((3, N_LDV_PAR)),
    )
    lsum = np.zeros(N_LSUM)
    par = ldv.par0.copy()  # s_f, η_L, φ_L, s_u, k_η
    use_k = len(ldv.a_fwd) > 0 and (ldv.aug_idx[4] >= 0 or par[4] != 0.0)
    cal = LdvCal(par, c_db(par[1], par[2]), ldv.sigma**2, use_k)  # C_d^b changes only at feedback
    zupt_r = mdl.zupt_sigma**2
    _checkpoint(out, 0, kf.x, cov.P, par, bias)
    t_prev = t[0] - (t[1] - t[0])
    t_epoch = t_prev
    fix = GnssFix(np.zeros(3), np.eye(3), np.zeros(2), np.zeros(2, dtype=np.int64))
    while fix.idx[0] < len(gnss.t) and gnss.t[fix.idx[0]] <= t_prev:  # fixes before the start: never used
        fix.idx[0] += 1
    rotating = _is_rotating(c_bs, n_s)
    c_sn = np.empty((3, 3))
    c_bn = np.empty((3, 3))
    c_bn_prev = np.empty((3, 3))
    q_to_c_into(nav.q_sn, c_sn)
    c_bn_into(c_sn, c_bs, 0, rotating, c_bn_prev)
    j = 0
    # scale-factor estimates (gyro x y z, accel x y z): the z gyro's (state i_sz) or all six (from i_sf)
    sf = np.zeros(6)
    n_sf = SF_ALL if i_sf >= 0 else (SF_Z if i_sz >= 0 else SF_NONE)
    ssum = np.zeros(6)  # Σ of the corrected sensor increments over the epoch, read with scale-factor states
    # what the per-sample path touches, under names: read through its struct in this loop, a field
    # costs as much as the mechanization itself (measured); stages are handed the structs
    q, v, pos, f_n, b_a = nav.q_sn, nav.v_n_mps, nav.pos_rad_m, wk.f_n_mps2, bias.accel_mps2
    a_th, a_dv = wk.dth_rad, wk.dv_mps
    ldv_ok, nu_f, nu_u, a_fwd, up, g_t, fix_idx = ldv.ok, ldv.nu_f, ldv.nu_u, ldv.a_fwd, ldv.up, gnss.t, fix.idx
    cdb, lever = cal.c_db, ldv.lever
    q_out, v_out, p_out = out.q_sn, out.v_n_mps, out.pos_rad_m
    fu_out, fen_out, fb_out = out.f_u_mps2, out.f_en_mps2, out.f_b_mps2
    for k in range(n_s):
        # ---- IMU sample: mechanization, the LDV residual's sums, GNSS fixes brought to the epoch ----
        dt = t[k] - t_prev
        t_prev = t[k]
        dwz = mech_sample(imu, k, dt, nav, bias, sf, n_sf, wk)
        if n_sf == SF_Z:
            ssum[2] += dwz
        elif n_sf == SF_ALL:
            for i in range(3):
                ssum[i] += a_th[i]
                ssum[3 + i] += a_dv[i]
        q_to_c_into(q, c_sn)
        if forces:
            _store_forces(fu_out, fen_out, fb_out, k, f_n, c_sn, b_a)
        c_bn_into(c_sn, c_bs, k, rotating, c_bn)
        if ldv_ok[k]:
            meas = (dt, nu_f[k], nu_u[k] if up else 0.0, a_fwd[k] if use_k else 0.0, up, use_k)
            _ldv_sample(meas, par, cdb, lever, c_bn, c_bn_prev, v, lsum)
        if fix_idx[0] < len(g_t) and g_t[fix_idx[0]] <= t[k]:  # a GNSS fix in (t_{k−1}, t_k]
            _gnss_sample(gnss, t[k], nav, c_bn, fix)
        c_bn, c_bn_prev = c_bn_prev, c_bn  # this sample's body attitude is the next one's previous
        if (k + 1) % decim != 0:
            _store_sample(q_out, v_out, p_out, k, q, v, pos, full)
            continue
        # ---- filter epoch: propagation, updates, feedback, what the smoother keeps ----
        j += 1
        T = t[k] - t_epoch
        t_epoch = t[k]
        propagate_epoch(out.fin[j], c_sn, wk.fsum_n_mps, ssum, nav, T, proc, cov)
        out.dt_s[j] = T
        kf.x[:] = 0.0
        if mdl.zupt[j]:
            _zupt_update(kf, nav.v_n_mps, zupt_r, gate, out.upd[j], out.nis[j])
        if lsum[L_N] > 0:
            _ldv_update(kf, ldv.aug_idx, lsum, cal, gate, out.upd[j], out.nis[j])
        if fix.idx[1] != 0:
            _gnss_update(kf, fix, gnss.lever, gate, out.upd[j], out.nis[j])
        _symmetrize(cov.P)
        _feedback(kf.x, nav, bias, cal, ldv.aug_idx)
        q_to_c_into(nav.q_sn, c_sn)
        c_bn_into(c_sn, c_bs, k, rotating, c_bn_prev)
        _checkpoint(out, j, kf.x, cov.P, cal.par, bias)
        if i_sz >= 0:
            sf[2] += kf.x[i_sz]
            out.gyro_scale_z[j] = sf[2]
        if i_sf >= 0:
            for i in range(6):
                sf[i] += kf.x[i_sf + i]
                out.scale[j, i] = sf[i]
        ssum[:] = 0.0
        _reset_sums(wk, lsum)
        _store_sample(q_out, v_out, p_out, k, q, v, pos, full)
    return out


@nb.njit(cache=True, inline="always")
def c_bn_into(c_sn, c_bs, k, rotating, out):
    """out = C_b^n = C_s^n C_b^s[k] (a copy of C_s^n for a fixed IMU, ``rotating`` False).
    Shared with :mod:`ldvsurvey.nav.damping`."""
    if rotating:
        cb = c_bs[k]
        for i in range(3):
            for jj in range(3):
                out[i, jj] = c_sn[i, 0] * cb[0, jj] + c_sn[i, 1] * cb[1, jj] + c_sn[i, 2] * cb[2, jj]
    else:
        for i in range(3):
            for jj in range(3):
                out[i, jj] = c_sn[i, jj]


@nb.njit(cache=True)
def _block_covs(rec, proc, b, blk, ws, blk_m, blk_pm):
    """P⁺ of the epochs b·CK_EVERY … into ``blk`` (K, n, n), redone from the checkpoint of block b
    (``rec`` a :class:`Record`, ``proc`` its :class:`ProcessModel`); with Φ_e P⁺_{e−1} into
    ``blk_m`` and P⁻_e into ``blk_pm`` (index e − b·CK_EVERY; both (K, n, n), or (0, n, n): not
    kept). Returns the number of epochs filled. ``ws``: (3, n, n) work space."""
    ck, upd, fin, dts = rec.ck_packed, rec.upd, rec.fin, rec.dt_s
    qd, inv_tau, i_sz, i_sf, aug_idx = proc.qd, proc.inv_tau_ps, proc.i_sz, proc.i_sf, proc.aug_idx
    zupt_r = proc.zupt_sigma_mps**2
    keep = blk_m.shape[0] > 0
    m1 = dts.shape[0]
    n = blk.shape[1]
    j0 = b * CK_EVERY
    j1 = min(j0 + CK_EVERY, m1)
    _unpack(ck[b], blk[0])
    Phi, M, A = ws[0], ws[1], ws[2]
    H = np.zeros((3, n))
    ph = np.empty(n)
    nz = np.empty(n, dtype=np.int64)
    for e in range(j0 + 1, j1):
        _phi_into(fin[e], dts[e], inv_tau, i_sz, i_sf, Phi, A, ph)
        P = blk[e - j0]
        # what the smoother's step j = e − 1 needs, when kept: Φ P⁺_j (written in place) and P⁻_{j+1}
        _propagate(blk[e - j0 - 1], Phi, qd, dts[e], blk_m[e - j0] if keep else M, P)
        if keep:
            blk_pm[e - j0] = P
        _redo_updates(P, upd[e], aug_idx, zupt_r, H, ph, nz)
    return j1 - j0


@nb.njit(cache=True)
def forward_covs(rec, proc):
    """The forward P⁺ of every epoch, redone from the checkpoints.

    Parameters
    ----------
    rec : :class:`Record` of the forward pass.
    proc : :class:`ProcessModel` it ran with.

    Returns
    -------
    ndarray
        (M+1, n, n) P⁺ in state units² (φ rad, δv m/s, δp m, ε rad/s, ∇ m/s², …).
    """
    m1 = rec.dt_s.shape[0]
    n = len(proc.qd)
    out = np.empty((m1, n, n))
    blk = np.empty((CK_EVERY, n, n))
    ws = np.empty((3, n, n))
    none = np.empty((0, n, n))
    for b in range(rec.ck_packed.shape[0]):
        cnt = _block_covs(rec, proc, b, blk, ws, none, none)
        out[b * CK_EVERY : b * CK_EVERY + cnt] = blk[:cnt]
    return out


@nb.njit(cache=True)
def rts(rec, proc, keep_cov):
    """Rauch-Tung-Striebel smoother over the stored closed-loop forward pass.

    Works backwards block by block: the forward P⁺ of a block's epochs is redone from its
    checkpoint and the epochs' update records (the same arithmetic as the forward pass, so the same
    numbers), Φ_{j+1} is rebuilt from ``fin`` and P⁻_{j+1} = Φ P⁺_j Φᵀ + Q T recomputed.

    Parameters
    ----------
    rec : :class:`Record` of the forward pass.
    proc : :class:`ProcessModel` it ran with.
    keep_cov : keep P_s of every epoch.

    Returns
    -------
    xs : (M+1, n) smoothed error of the post-feedback nominal at each epoch (state units).
    sig : (M+1, n) the 1-σ of P_s.
    ps : (M+1, n, n) P_s when ``keep_cov``, else an empty (0, n, n).
    """
    fin, dts, dxs = rec.fin, rec.dt_s, rec.dx
    inv_tau, i_sz, i_sf, qd = proc.inv_tau_ps, proc.i_sz, proc.i_sf, proc.qd
    m1 = dts.shape[0]
    n = dxs.shape[1]
    xs = np.zeros((m1, n))
    sig = np.empty((m1, n))
    ps_all = np.empty((m1 if keep_cov else 0, n, n))
    blk = np.empty((CK_EVERY, n, n))
    ws = np.empty((3, n, n))
    Ps = np.empty((n, n))
    Phi = np.empty((n, n))
    M = np.empty((n, n))
    pm = np.empty((n, n))
    D = np.empty((n, n))
    L = np.empty((n, n))
    at = np.empty((n, n))
    E = np.empty((n, n))
    a_ = np.empty((n, n))
    tmp = np.empty(n)
    blk_m = np.empty((CK_EVERY, n, n))
    blk_pm = np.empty((CK_EVERY, n, n))
    n_blk = rec.ck_packed.shape[0]
    for b in range(n_blk - 1, -1, -1):
        cnt = _block_covs(rec, proc, b, blk, ws, blk_m, blk_pm)
        j0 = b * CK_EVERY
        for j in range(j0 + cnt - 1, j0 - 1, -1):
            Pp = blk[j - j0]
            if j == m1 - 1:
                Ps[:, :] = Pp
                for i in range(n):
                    sig[j, i] = np.sqrt(max(Ps[i, i], 0.0))
                if keep_cov:
                    ps_all[j] = Ps
                continue
            if j + 1 < j0 + cnt:  # redone with the block
                Mj = blk_m[j + 1 - j0]
                pmj = blk_pm[j + 1 - j0]
            else:  # epoch j + 1 opens the next block
                _phi_into(fin[j + 1], dts[j + 1], inv_tau, i_sz, i_sf, Phi, M, tmp)
                _propagate(Pp, Phi, qd, dts[j + 1], M, pm)
                Mj = M
                pmj = pm
            # A = P⁺_j Φᵀ (P⁻_{j+1})⁻¹  ⇒  Aᵀ = (P⁻)⁻¹ Φ P⁺_j, by Cholesky (P⁻ is symmetric positive definite)
            _chol_solve(pmj, Mj, L, at)
            for i in range(n):
                tmp[i] = xs[j + 1, i] + dxs[j + 1, i]
            for i in range(n):  # x_s(j) = A tmp, all rows at once (each summed over k in order)
                xs[j, i] = 0.0
            for k in range(n):
                tk = tmp[k]
                for i in range(n):
                    xs[j, i] += at[k, i] * tk
            # P_s(j) = P⁺_j + A (P_s(j+1) − P⁻_{j+1}) Aᵀ, with D = P_s(j+1) − P⁻ and E = D Aᵀ
            for i in range(n):
                for k in range(n):
                    D[i, k] = Ps[i, k] - pmj[i, k]
            np.dot(D, at, E)  # BLAS: at n ≈ 20 twice as fast as loops
            for i in range(n):
                for k in range(n):
                    a_[i, k] = at[k, i]
            np.dot(a_, E, Ps)
            for i in range(n):
                for k in range(n):
                    Ps[i, k] += Pp[i, k]
            for i in range(n):
                sig[j, i] = np.sqrt(max(Ps[i, i], 0.0))
            if keep_cov:
                ps_all[j] = Ps
    return xs, sig, ps_all


@nb.njit(cache=True)
def _chol_solve(S, B, L, X):
    """X = S⁻¹ B for symmetric positive definite S (n×n) and B (n×m), through S = L Lᵀ (L written).

    Falls back to LU (numpy's solve) when S is not numerically positive definite."""
    n = S.shape[0]
    for jj in range(n):
        d = S[jj, jj]
        for k in range(jj):
            d -= L[jj, k] * L[jj, k]
        if not d > 0.0:
            X[:, :] = np.linalg.solve(S, B)
            return
        d = np.sqrt(d)
        L[jj, jj] = d
        for i in range(jj + 1, n):
            s = S[i, jj]
            for k in range(jj):
                s -= L[i, k] * L[jj, k]
            L[i, jj] = s / d
    m = B.shape[1]
    # the substitutions take four rows of X per pass over the columns, X[i] ← (((X[i] − l₀X[k]) − l₁X[k+1])
    # − l₂X[k+2]) − l₃X[k+3]: the same operations in the same order as one row at a time, so the same
    # numbers, with a quarter of the passes and of the loads and stores of X[i]
    for i in range(n):  # L Y = B, row by row (all columns at once)
        for c in range(m):
            X[i, c] = B[i, c]
        k = 0
        while k + 4 <= i:
            l0, l1, l2, l3 = L[i, k], L[i, k + 1], L[i, k + 2], L[i, k + 3]
            for c in range(m):
                X[i, c] = (((X[i, c] - l0 * X[k, c]) - l1 * X[k + 1, c]) - l2 * X[k + 2, c]) - l3 * X[k + 3, c]
            k += 4
        while k < i:
            lik = L[i, k]
            for c in range(m):
                X[i, c] -= lik * X[k, c]
            k += 1
        d = L[i, i]
        for c in range(m):
            X[i, c] /= d
    for i in range(n - 1, -1, -1):  # Lᵀ X = Y
        k = i + 1
        while k + 4 <= n:
            l0, l1, l2, l3 = L[k, i], L[k + 1, i], L[k + 2, i], L[k + 3, i]
            for c in range(m):
                X[i, c] = (((X[i, c] - l0 * X[k, c]) - l1 * X[k + 1, c]) - l2 * X[k + 2, c]) - l3 * X[k + 3, c]
            k += 4
        while k < n:
            lki = L[k, i]
            for c in range(m):
                X[i, c] -= lki * X[k, c]
            k += 1
        d = L[i, i]
        for c in range(m):
            X[i, c] /= d


@nb.njit(cache=True)
def apply_corrections(t, ep_t, decim, xs, dxs, traj):
    """Correct the forward nominal at every sample, in place, with the smoothed error interpolated
    in time from x_s(j−1) to x_s(j) + dx_j (the post-update sample of epoch j takes x_s(j)).

    The up specific force f_U (n frame, per interval) gets the same attitude correction,
    f ← (I + [φ×]) f (with the E, N components ``fen``), and the smoothed accelerometer-bias
    correction, f ← f − C_s^n δ∇; ``fb`` (the up component of C_s^n b̂_a) gets + (C_s^n δ∇)_U.
    Empty v, p, f (an attitude-only run): only q is corrected; empty f alone: q, v, p.

    Parameters
    ----------
    t : (N,) sample times, s.
    ep_t : (M+1,) epoch times, s.
    decim : IMU samples per epoch.
    xs : (M+1, n) smoothed errors (:func:`rts`).
    dxs : (M+1, n) the forward pass's feedback (:attr:`Record.dx`).
    traj : :class:`Trajectory`, corrected in place.
    """
    q, v, p, fu, fen, fb = traj.q_sn, traj.v_n_mps, traj.pos_rad_m, traj.f_u_mps2, traj.f_en_mps2, traj.f_b_mps2
    m = xs.shape[0] - 1
    n_s = len(t)
    full = len(v) == n_s
    forces = len(fu) == n_s
    x = np.zeros(N_BASE)
    for k in range(n_s):
        if k < m * decim:
            j = k // decim + 1
            if (k + 1) % decim == 0:
                for i in range(N_BASE):
                    x[i] = xs[j, i]
            else:
                ta, tb = ep_t[j - 1], ep_t[j]
                w = (t[k] - ta) / (tb - ta) if tb > ta else 1.0
                for i in range(N_BASE):
                    x[i] = (1.0 - w) * xs[j - 1, i] + w * (xs[j, i] + dxs[j, i])
        else:
            for i in range(N_BASE):
                x[i] = xs[m, i]
        cc, ss = _rv(x[IX_PHI], x[IX_PHI + 1], x[IX_PHI + 2])
        a0, a1, a2, a3 = cc, ss * x[IX_PHI], ss * x[IX_PHI + 1], ss * x[IX_PHI + 2]
        w_, x_, y_, z_ = q[k, 0], q[k, 1], q[k, 2], q[k, 3]
        n0 = a0 * w_ - a1 * x_ - a2 * y_ - a3 * z_
        n1 = a0 * x_ + a1 * w_ + a2 * z_ - a3 * y_
        n2 = a0 * y_ - a1 * z_ + a2 * w_ + a3 * x_
        n3 = a0 * z_ + a1 * y_ - a2 * x_ + a3 * w_
        nq = np.sqrt(n0 * n0 + n1 * n1 + n2 * n2 + n3 * n3)
        n0, n1, n2, n3 = n0 / nq, n1 / nq, n2 / nq, n3 / nq
        q[k, 0], q[k, 1], q[k, 2], q[k, 3] = n0, n1, n2, n3
        if not full:
            continue
        for i in range(3):
            v[k, i] -= x[IX_V + i]
        rm, rn = radii_nb(p[k, 0])
        p0, p2 = p[k, 0], p[k, 2]
        p[k, 0] = p0 - x[IX_P + 1] / (rm + p2)
        p[k, 1] = p[k, 1] - x[IX_P] / ((rn + p2) * np.cos(p0))
        p[k, 2] = p2 - x[IX_P + 2]
        if not forces:
            continue
        # (C_s^n δ∇)_U with the corrected attitude: its third row
        c20 = 2 * (n1 * n3 - n0 * n2)
        c21 = 2 * (n2 * n3 + n0 * n1)
        c22 = 1 - 2 * (n1 * n1 + n2 * n2)
        da = c20 * x[IX_NABLA] + c21 * x[IX_NABLA + 1] + c22 * x[IX_NABLA + 2]
        fu[k] = fu[k] + (x[IX_PHI] * np.float64(fen[k, 1]) - x[IX_PHI + 1] * np.float64(fen[k, 0])) - da
        fb[k] = fb[k] + da


@nb.njit(cache=True, inline="always")
def _rv(a0, a1, a2):
    """(c, s) of the quaternion [c, s a] of rotation vector a (as :func:`attitude.q_rotvec`)."""
    n2 = a0 * a0 + a1 * a1 + a2 * a2
    if n2 < 1e-16:
        return 1.0 - n2 / 8.0, 0.5 - n2 / 48.0
    a = np.sqrt(n2)
    return np.cos(a / 2), np.sin(a / 2) / a
