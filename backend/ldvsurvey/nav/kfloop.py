"""Compiled loops: closed-loop forward filter (mechanization + error-state KF) and RTS smoother.

The mechanization runs at the IMU rate; the error-state covariance is propagated only at the
filter epochs, every ``decim`` IMU samples (Φ over the epoch from the mean specific force), and
the measurement updates happen there. Between epochs the LDV residual v̂_head − Ĉ_b^n V̂^b is
averaged; a GNSS fix is brought to the epoch (back-dated by v̂·Δt). Scalar sequential updates
with an innovation gate; after each epoch the estimate is fed back and the error state reset.

Stored for the smoother (nothing per IMU sample): per epoch the 18 numbers Φ is built from,
Δt, the feedback dx and a record of the measurement updates (:data:`N_UPD` numbers: which rows
were taken, their H entries and variances); P⁺ itself (upper triangle) only every
:data:`CK_EVERY` epochs. The smoother redoes the covariances of each block from its checkpoint
with the same arithmetic, so the same numbers bit for bit, and runs backwards through it (see
:mod:`ldvsurvey.nav.filter` for the smoothing algebra). Memory is thus about (2n + 60)·8 bytes
per epoch whatever the IMU rate.

Inputs come grouped (:class:`ImuIn`, :class:`Model`, :class:`LdvIn`, :class:`GnssIn`,
:class:`Start`): named tuples of arrays and scalars that numba compiles as they are. The work of
a sample (:func:`mech_sample`), of an epoch's covariance propagation (:func:`propagate_epoch`),
the body attitude (:func:`c_bn_into`) and the feedback (:func:`feedback_into`) are shared with the
water-velocity damping filter (:mod:`ldvsurvey.nav.damping`).

Augmented LDV states (when enabled, in this order after the 15): δs_f, δη_L (rad), δφ_L (rad),
δs_u, δk_η (rad per m/s²), where s = 1/K is the factor applied to the measured speed
(V_d = [0, s_f ν_f, s_u ν_u]) and the travel direction the LDV sees is pitched by
η_L + k_η·a_f, a_f the forward acceleration (the body's squat and dive under acceleration).
Inverse scales are estimated additively, so the feedback is linear like the smoother's algebra.
"""

from __future__ import annotations

from collections import namedtuple

import numba as nb
import numpy as np

from ldvsurvey.nav.attitude import q_to_c_into
from ldvsurvey.nav.earth import radii_nb
from ldvsurvey.nav.errmodel import build_f_into, c_db
from ldvsurvey.nav.mech import mech_step_into


@nb.njit(cache=True)
def feedback_into(x, q, v, pos, v_prev, pos_prev, b_g, b_a):
    """Closed-loop reset of the 15 base states, in place: C ← (I + [φ×]) C, v ← v − δv, p ← p − δp
    (metres to lat/lon), biases += estimates; the previous velocity/position (used for mid-interval
    extrapolation) get the same correction. Shared with :mod:`ldvsurvey.nav.damping`."""
    c, s = _rv(x[0], x[1], x[2])
    a0, a1, a2, a3 = c, s * x[0], s * x[1], s * x[2]
    w, qx, qy, qz = q[0], q[1], q[2], q[3]
    n0 = a0 * w - a1 * qx - a2 * qy - a3 * qz
    n1 = a0 * qx + a1 * w + a2 * qz - a3 * qy
    n2 = a0 * qy - a1 * qz + a2 * w + a3 * qx
    n3 = a0 * qz + a1 * qy - a2 * qx + a3 * w
    nq = np.sqrt(n0 * n0 + n1 * n1 + n2 * n2 + n3 * n3)
    q[0], q[1], q[2], q[3] = n0 / nq, n1 / nq, n2 / nq, n3 / nq
    rm, rn = radii_nb(pos[0])
    d0 = x[7] / (rm + pos[2])
    d1 = x[6] / ((rn + pos[2]) * np.cos(pos[0]))
    d2 = x[8]
    for i in range(3):
        v[i] -= x[3 + i]
        v_prev[i] -= x[3 + i]
        b_g[i] += x[9 + i]
        b_a[i] += x[12 + i]
    pos[0] -= d0
    pos[1] -= d1
    pos[2] -= d2
    pos_prev[0] -= d0
    pos_prev[1] -= d1
    pos_prev[2] -= d2


MAX_REJECT_RUN = 5  #: epochs of consecutive rejections after which a measurement is taken anyway


#: the IMU: t (N,) s; dth, dvel (N, 3) sensor-frame increments (rad, m/s); c_bs (N, 3, 3) C_b^s per
#: sample, or (1, 3, 3) for a fixed IMU; xi, eta (rad), dg (m/s²) per sample for the gravity model, or empty
ImuIn = namedtuple("ImuIn", "t dth dvel c_bs xi eta dg")
#: the error model: decim (IMU samples per epoch), p0 (n,) prior variances, qd (n,) PSDs, inv_tau (n,)
#: 1/τ of Gauss–Markov states (1/s), zupt (M+1,) bool epochs standing still, zupt_sigma (m/s),
#: gate (σ, 0 = off), i_sz (index of the z-gyro scale-factor state, −1: none), full (False: keep only the
#: attitude per sample; velocity, position and specific force come back empty), forces (with full: keep
#: the up specific force per sample too; False: it comes back empty, 16 bytes per sample less)
Model = namedtuple("Model", "decim p0 qd inv_tau zupt zupt_sigma gate i_sz full forces")
#: LDV: ok (N,) bool, nu_f, nu_u (N,) m/s, par0 (5,) [s_f, η_L, φ_L, s_u, k_η], lever (3,) m,
#: sigma (3,) m/s per sample, up (2-D LDV), aug_idx (5,) state index of each LDV state (−1: none),
#: a_fwd (N,) or empty: forward acceleration for the pitch compliance (m/s²)
LdvIn = namedtuple("LdvIn", "ok nu_f nu_u par0 lever sigma up aug_idx a_fwd")
#: GNSS: t (G,) s, pos (G, 3) lat, lon rad, h m of the antenna, sig (G, 2) 1-σ horizontal/vertical m, lever (3,) m
GnssIn = namedtuple("GnssIn", "t pos sig lever")
#: initial state: q (4,) C_s^n, v (3,) ENU m/s, pos (3,) lat, lon rad, h m, bias (6,) gyro rad/s, accel m/s²
Start = namedtuple("Start", "q v pos bias")

#: what Φ of an epoch is built from (stored per epoch): C_s^n (9), mean f^n (3), v (3), lat, h, mean ω_z
N_FIN = 18


@nb.njit(cache=True)
def _phi_into(fin, T, inv_tau, i_sz, Phi, A, sq):
    """Φ = I + F T + (F T)²/2 of one epoch into ``Phi`` (n×n), F from the stored ``fin`` row;
    ``A`` (n×n) and ``sq`` (n,) are work space (overwritten: no allocation per epoch).

    Rows 9.. of F (biases, LDV and scale-factor states) hold only their diagonal (−1/τ), so the
    square needs the full sum only in the first nine rows."""
    n = Phi.shape[0]
    c_sn = fin[0:9].reshape((3, 3))
    A[:, :] = 0.0
    build_f_into(A, c_sn, fin[9], fin[10], fin[11], fin[12], fin[13], fin[14], fin[15], fin[16])
    if i_sz >= 0:  # φ̇ = −C_s^n δω^s, δω^s = [0, 0, δs_z ω_z]
        for i in range(3):
            A[i, i_sz] = -c_sn[i, 2] * fin[17]
    for i in range(n):  # first-order Gauss–Markov states (bias instability): ẋ = −x/τ + w
        A[i, i] -= inv_tau[i]
    for i in range(n):
        for jj in range(n):
            A[i, jj] *= T
    for i in range(n):
        if i < 9:
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
def mech_sample(imu, k, dt, b_g, b_a, s_z, i_sz, q, v, pos, v_prev, pos_prev, dth_prev, dv_prev, a_th, a_dv, f_n, fsum):
    """Mechanize IMU sample k over ``dt`` (s) with the bias estimates b_g (rad/s), b_a (m/s²) and,
    when ``i_sz`` ≥ 0, the z-gyro scale factor s_z removed; the work of every sample of the filters
    (this module's and :mod:`ldvsurvey.nav.damping`). In place: q, v, pos, v_prev, pos_prev (see
    :func:`~ldvsurvey.nav.mech.mech_step_into`), dth_prev, dv_prev ← the corrected increments
    a_th, a_dv; f_n ← the mean specific force in n, fsum += f_n dt. Returns the corrected z-gyro
    increment (rad) for the epoch's mean ω_z."""
    gx = imu.xi[k] if len(imu.xi) > 0 else 0.0
    ge = imu.eta[k] if len(imu.xi) > 0 else 0.0
    gd = imu.dg[k] if len(imu.xi) > 0 else 0.0
    for i in range(3):
        a_th[i] = imu.dth[k, i] - b_g[i] * dt
    if i_sz >= 0:  # z-gyro scale factor: ω̃_z = (1 + s_z) ω_z
        a_th[2] -= s_z * a_th[2]
    for i in range(3):
        a_dv[i] = imu.dvel[k, i] - b_a[i] * dt
    mech_step_into(q, v, pos, v_prev, pos_prev, a_th, a_dv, dth_prev, dv_prev, dt, gx, ge, gd, f_n)
    for i in range(3):
        dth_prev[i] = a_th[i]
        dv_prev[i] = a_dv[i]
        fsum[i] += f_n[i] * dt
    return a_th[2]


@nb.njit(cache=True)
def propagate_epoch(fj, c_sn, fsum, v, pos, wz_sum, T, inv_tau, i_sz, qd, P, Phi, M, out):
    """Covariance propagation over an epoch of T s: ``fj`` (:data:`N_FIN`) ← what Φ is built from
    (C_s^n, mean specific force fsum/T, v, lat, h, mean ω_z = wz_sum/T), Φ (into ``Phi``), and
    out = Φ P Φᵀ + diag(qd) T (M: work space; ``out`` must not be P). The same for this module's filter
    and the damping one."""
    for i in range(3):
        for jj in range(3):
            fj[3 * i + jj] = c_sn[i, jj]
        fj[9 + i] = fsum[i] / T
        fj[12 + i] = v[i]
    fj[15], fj[16], fj[17] = pos[0], pos[2], wz_sum / T
    _phi_into(fj, T, inv_tau, i_sz, Phi, M, out[0])  # M and out: written only after Φ is complete
    _propagate(P, Phi, qd, T, M, out)


@nb.njit(cache=True)
def _propagate(P, Phi, qd, T, M, out):
    """out = Φ P Φᵀ + diag(qd) T; M = Φ P (both n×n, written). Rows 9.. of Φ are diagonal."""
    n = P.shape[0]
    for i in range(n):
        if i < 9:
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
            if jj < 9:
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


@nb.njit(cache=True)
def _update_rows(x, P, H, z, r, gate, kind, run, rejected, nis_row, ph, nz, taken):
    """Scalar updates for the rows of one measurement type with the innovation gate and its
    lock-out protection: after MAX_REJECT_RUN epochs with a rejection the gate is lifted.
    ``kind`` indexes ``run``/``rejected``; normalized innovations go to ``nis_row``, 1/0 (taken or
    rejected) to ``taken``; ``ph`` (n,) float and ``nz`` (n,) int are work space. In place, no allocation."""
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


#: per-epoch record of the measurement updates, enough to redo them on the covariance alone:
#: [0] ZUPT done, [1:4] its rows taken; [4] LDV done, [5:8] rows taken, [8:11] r, [11:14] v̄_l
#: (attitude columns), [14:29] LDV-state columns H[i, aug] (i·5 + a); [29] GNSS done, [30:33] rows
#: taken, [33:36] C_b^n l (attitude columns), [36:39] r
N_UPD = 39
#: epochs between stored covariances: the smoother redoes the ones between (bit for bit)
CK_EVERY = 64


@nb.njit(cache=True)
def _redo_updates(P, rec, aug_idx, zupt_r, H, ph, nz):
    """The measurement updates of one epoch on the covariance alone, from its record."""
    if rec[0] != 0.0:
        H[:, :] = 0.0
        for i in range(3):
            H[i, 3 + i] = 1.0
        for row in range(3):
            if rec[1 + row] != 0.0:
                s = _cov_row(P, H, row, zupt_r, ph, nz)
                _cov_apply(P, ph, s)
    if rec[4] != 0.0:
        H[:, :] = 0.0
        for i in range(3):
            for a in range(5):
                if aug_idx[a] >= 0:
                    H[i, aug_idx[a]] = rec[14 + 5 * i + a]
            H[i, 3 + i] = 1.0
        v_l0, v_l1, v_l2 = rec[11], rec[12], rec[13]
        H[0, 1], H[0, 2] = v_l2, -v_l1
        H[1, 0], H[1, 2] = -v_l2, v_l0
        H[2, 0], H[2, 1] = v_l1, -v_l0
        for row in range(3):
            if rec[5 + row] != 0.0:
                s = _cov_row(P, H, row, rec[8 + row], ph, nz)
                _cov_apply(P, ph, s)
    if rec[29] != 0.0:
        la0, la1, la2 = rec[33], rec[34], rec[35]
        H[:, :] = 0.0
        H[0, 1], H[0, 2] = -la2, la1
        H[1, 0], H[1, 2] = la2, -la0
        H[2, 0], H[2, 1] = -la1, la0
        for i in range(3):
            H[i, 6 + i] = 1.0
        for row in range(3):
            if rec[30 + row] != 0.0:
                s = _cov_row(P, H, row, rec[36 + row], ph, nz)
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


@nb.njit(cache=True)
def forward(imu, mdl, ldv, gnss, st):
    """Run the forward filter. See the Python wrapper :func:`ldvsurvey.nav.filter.run_filter`.

    Returns, per IMU sample: q (N, 4), v (N, 3), pos (N, 3), f_U (N,) the up specific force as
    integrated, f_EN (N, 2) float32 its horizontal components (only for the smoother's attitude
    correction of f_U), fb (N,) (C_s^n b̂_a)_U; per epoch (M+1): packed P⁺, Φ inputs, Δt, dx, LDV
    parameters, biases, normalized innovations (M+1, 9); rejections (3,); z-gyro scale (M+1,)."""
    t, dth, dvel, c_bs = imu.t, imu.dth, imu.dvel, imu.c_bs
    decim, qd, inv_tau, i_sz, gate = mdl.decim, mdl.qd, mdl.inv_tau, mdl.i_sz, mdl.gate
    nu_f, nu_u, ldv_ok, l_ldv, aug_idx, a_fwd = ldv.nu_f, ldv.nu_u, ldv.ok, ldv.lever, ldv.aug_idx, ldv.a_fwd
    ldv_up = ldv.up
    g_t, g_pos, g_sig, l_gnss = gnss.t, gnss.pos, gnss.sig, gnss.lever
    n_s = len(t)
    n = len(mdl.p0)
    m = n_s // decim
    q_out = np.empty((n_s, 4))
    n_o = n_s if mdl.full else 0  # attitude only: no per-sample velocity, position or specific force
    v_out = np.empty((n_o, 3))
    p_out = np.empty((n_o, 3))
    full = mdl.full
    forces = mdl.full and mdl.forces
    n_f = n_s if forces else 0
    fu_out = np.empty(n_f)  # up specific force in n over each interval, as integrated
    fen_out = np.empty((n_f, 2), dtype=np.float32)  # its E, N components (for the smoother's φ × f)
    fb_out = np.empty(n_f)  # up component of the accelerometer-bias correction (C_s^n b̂_a)_U
    ck = np.empty((m // CK_EVERY + 1, n * (n + 1) // 2))  # P⁺ every CK_EVERY epochs (packed)
    upd = np.zeros((m + 1, N_UPD))
    sig_f = np.empty((m + 1, n))  # forward 1-σ
    fin = np.zeros((m + 1, N_FIN))
    dts = np.zeros(m + 1)
    dxs = np.zeros((m + 1, n))
    par_out = np.empty((m + 1, 5))
    bias_out = np.empty((m + 1, 6))
    nis = np.full((m + 1, 9), np.nan)  # normalized innovations: zupt(3), ldv(3), gnss(3)
    rejected = np.zeros(3, dtype=np.int64)
    run = np.zeros(3, dtype=np.int64)  # consecutive epochs with a rejection, per measurement type

    q, v, pos = st.q.copy(), st.v.copy(), st.pos.copy()
    v_prev, pos_prev = v.copy(), pos.copy()
    dth_prev, dv_prev = dth[0].copy(), dvel[0].copy()
    a_th = np.empty(3)
    a_dv = np.empty(3)
    f_n = np.empty(3)
    b_g, b_a = st.bias[:3].copy(), st.bias[3:].copy()
    s_z = 0.0  # z-gyro scale-factor estimate (state i_sz when ≥ 0)
    wz_sum = 0.0
    sz_out = np.zeros(m + 1)
    par = ldv.par0.copy()  # K_f, eta_L, phi_L, K_u
    P = np.diag(mdl.p0)
    Pm = np.empty((n, n))
    Phi = np.empty((n, n))
    M = np.empty((n, n))
    ph = np.empty(n)
    nz = np.empty(n, dtype=np.int64)
    x = np.zeros(n)
    H = np.zeros((3, n))
    r3 = np.empty(3)
    zl = np.empty(3)
    ub = np.empty((3, 5))
    zupt_r = mdl.zupt_sigma**2
    ldv_r = ldv.sigma**2
    _pack(P, ck[0])
    for i in range(n):
        sig_f[0, i] = np.sqrt(max(P[i, i], 0.0))
    par_out[0] = par
    bias_out[0, :3], bias_out[0, 3:] = b_g, b_a
    t_prev = t[0] - (t[1] - t[0])
    t_epoch = t_prev
    # accumulators over the current epoch
    fsum = np.zeros(3)
    lz = np.zeros(3)
    lvl = np.zeros(3)
    lvd = np.zeros(3)
    lnu = np.zeros(2)
    lvda = np.zeros(3)  # Σ V^d a_f (the pitch-compliance column)
    la = 0.0  # Σ a_f
    lc = np.zeros((3, 3))
    use_k = len(a_fwd) > 0 and (aug_idx[4] >= 0 or par[4] != 0.0)
    ln = 0
    gi = 0
    n_g = len(g_t)
    while gi < n_g and g_t[gi] <= t_prev:
        gi += 1
    g_pending = False
    gz = np.zeros(3)
    gc = np.eye(3)
    gsig = np.zeros(2)
    rotating = False
    if c_bs.shape[0] > 1:
        for kk in range(0, n_s, max(1, n_s // 50)):  # identity C_b^s (fixed IMU): skip the products
            if np.abs(c_bs[kk] - np.eye(3)).max() > 0.0:
                rotating = True
                break
    cdb = c_db(par[1], par[2])  # LDV mounting; changes only at feedback
    c_sn = np.empty((3, 3))
    c_bn = np.empty((3, 3))
    c_bn_prev = np.empty((3, 3))
    q_to_c_into(q, c_sn)
    c_bn_into(c_sn, c_bs, 0, rotating, c_bn_prev)
    j = 0
    for k in range(n_s):
        dt = t[k] - t_prev
        t_prev = t[k]
        dwz = mech_sample(
            imu, k, dt, b_g, b_a, s_z, i_sz, q, v, pos, v_prev, pos_prev, dth_prev, dv_prev, a_th, a_dv, f_n, fsum
        )
        if i_sz >= 0:
            wz_sum += dwz
        q_to_c_into(q, c_sn)
        if forces:
            fu_out[k] = f_n[2]
            fen_out[k, 0] = f_n[0]
            fen_out[k, 1] = f_n[1]
            fb_out[k] = c_sn[2, 0] * b_a[0] + c_sn[2, 1] * b_a[1] + c_sn[2, 2] * b_a[2]
        c_bn_into(c_sn, c_bs, k, rotating, c_bn)
        if ldv_ok[k]:
            vd1 = nu_f[k] * par[0]
            vd2 = (nu_u[k] * par[3]) if ldv_up else 0.0
            # V^b = C_d^b [0, vd1, vd2]; v_l = C_b^n V^b (scalars: no small-array allocations)
            if use_k:  # C_d^b(η_L + k a, φ_L): forward and up columns
                ak = a_fwd[k]
                ee = par[1] + par[4] * ak
                ce, se = np.cos(ee), np.sin(ee)
                cp, sp = cdb[0, 0], cdb[1, 0]  # cos φ_L, sin φ_L: computed once per epoch, in C_d^b
                vb0 = -sp * ce * vd1 + sp * se * vd2
                vb1 = cp * ce * vd1 - cp * se * vd2
                vb2 = se * vd1 + ce * vd2
                lvda[1] += vd1 * ak
                lvda[2] += vd2 * ak
                la += ak
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
            a0 = w1 * l_ldv[2] - w2 * l_ldv[1]
            a1 = w2 * l_ldv[0] - w0 * l_ldv[2]
            a2 = w0 * l_ldv[1] - w1 * l_ldv[0]
            for i in range(3):
                vl_i = c_bn[i, 0] * vb0 + c_bn[i, 1] * vb1 + c_bn[i, 2] * vb2
                lz[i] += v[i] + c_bn[i, 0] * a0 + c_bn[i, 1] * a1 + c_bn[i, 2] * a2 - vl_i
                lvl[i] += vl_i
                for jj in range(3):
                    lc[i, jj] += c_bn[i, jj]
            lvd[1] += vd1
            lvd[2] += vd2
            lnu[0] += nu_f[k]
            lnu[1] += nu_u[k] if ldv_up else 0.0
            ln += 1
        while gi < n_g and g_t[gi] <= t[k]:
            # GNSS fix at g_t[gi] in (t[k-1], t[k]]: residual INS − GNSS at the antenna, local metres
            rm, rn = radii_nb(pos[0])
            back = t[k] - g_t[gi]
            lev0 = c_bn[0, 0] * l_gnss[0] + c_bn[0, 1] * l_gnss[1] + c_bn[0, 2] * l_gnss[2]
            lev1 = c_bn[1, 0] * l_gnss[0] + c_bn[1, 1] * l_gnss[1] + c_bn[1, 2] * l_gnss[2]
            lev2 = c_bn[2, 0] * l_gnss[0] + c_bn[2, 1] * l_gnss[1] + c_bn[2, 2] * l_gnss[2]
            gz[0] = (pos[1] - g_pos[gi, 1]) * (rn + pos[2]) * np.cos(pos[0]) + lev0 - v[0] * back
            gz[1] = (pos[0] - g_pos[gi, 0]) * (rm + pos[2]) + lev1 - v[1] * back
            gz[2] = pos[2] - g_pos[gi, 2] + lev2 - v[2] * back
            gc[:, :] = c_bn
            gsig[0], gsig[1] = g_sig[gi, 0], g_sig[gi, 1]
            g_pending = True
            gi += 1
        c_bn, c_bn_prev = c_bn_prev, c_bn  # this sample's body attitude is the next one's previous
        if (k + 1) % decim != 0:
            for i in range(4):
                q_out[k, i] = q[i]
            for i in range(3):
                if full:
                    v_out[k, i] = v[i]
                    p_out[k, i] = pos[i]
            continue
        # ---- filter epoch ----
        j += 1
        T = t[k] - t_epoch
        t_epoch = t[k]
        propagate_epoch(fin[j], c_sn, fsum, v, pos, wz_sum, T, inv_tau, i_sz, qd, P, Phi, M, Pm)
        P, Pm = Pm, P
        dts[j] = T
        x[:] = 0.0
        if mdl.zupt[j]:
            H[:, :] = 0.0
            for i in range(3):
                H[i, 3 + i] = 1.0
                r3[i] = zupt_r
            rec = upd[j]
            rec[0] = 1.0
            _update_rows(x, P, H, v, r3, gate, 0, run, rejected, nis[j, 0:3], ph, nz, rec[1:4])
        if ln > 0:
            for i in range(3):
                zl[i] = lz[i] / ln
                r3[i] = ldv_r[i] / ln
            v_l0, v_l1, v_l2 = lvl[0] / ln, lvl[1] / ln, lvl[2] / ln
            vd1, vd2 = lvd[1] / ln, lvd[2] / ln
            ch = c_db(par[1] + par[4] * la / ln, par[2]) if use_k else cdb
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
                for a in range(5):
                    if aug_idx[a] >= 0:
                        H[i, aug_idx[a]] = -(
                            (lc[i, 0] / ln) * ub[0, a] + (lc[i, 1] / ln) * ub[1, a] + (lc[i, 2] / ln) * ub[2, a]
                        )
                H[i, 3 + i] = 1.0
            # attitude: −[v̄_l ×]
            H[0, 1], H[0, 2] = v_l2, -v_l1
            H[1, 0], H[1, 2] = -v_l2, v_l0
            H[2, 0], H[2, 1] = v_l1, -v_l0
            rec = upd[j]
            rec[4] = 1.0
            for i in range(3):
                rec[8 + i] = r3[i]
                for a in range(5):
                    if aug_idx[a] >= 0:
                        rec[14 + 5 * i + a] = H[i, aug_idx[a]]
            rec[11], rec[12], rec[13] = v_l0, v_l1, v_l2
            _update_rows(x, P, H, zl, r3, gate, 1, run, rejected, nis[j, 3:6], ph, nz, rec[5:8])
        if g_pending:
            la0 = gc[0, 0] * l_gnss[0] + gc[0, 1] * l_gnss[1] + gc[0, 2] * l_gnss[2]
            la1 = gc[1, 0] * l_gnss[0] + gc[1, 1] * l_gnss[1] + gc[1, 2] * l_gnss[2]
            la2 = gc[2, 0] * l_gnss[0] + gc[2, 1] * l_gnss[1] + gc[2, 2] * l_gnss[2]
            H[:, :] = 0.0
            H[0, 1], H[0, 2] = -la2, la1  # [(C_b^n l) ×]
            H[1, 0], H[1, 2] = la2, -la0
            H[2, 0], H[2, 1] = -la1, la0
            for i in range(3):
                H[i, 6 + i] = 1.0
            r3[0], r3[1], r3[2] = gsig[0] ** 2, gsig[0] ** 2, gsig[1] ** 2
            rec = upd[j]
            rec[29] = 1.0
            rec[33], rec[34], rec[35] = la0, la1, la2
            rec[36], rec[37], rec[38] = r3[0], r3[1], r3[2]
            _update_rows(x, P, H, gz, r3, gate, 2, run, rejected, nis[j, 6:9], ph, nz, rec[30:33])
            g_pending = False
        _symmetrize(P)
        # ---- feedback ----
        feedback_into(x, q, v, pos, v_prev, pos_prev, b_g, b_a)
        for a in range(5):
            if aug_idx[a] >= 0:
                par[a] -= x[aug_idx[a]]
        cdb = c_db(par[1], par[2])
        q_to_c_into(q, c_sn)
        c_bn_into(c_sn, c_bs, k, rotating, c_bn_prev)
        dxs[j] = x
        if j % CK_EVERY == 0:
            _pack(P, ck[j // CK_EVERY])
        for i in range(n):
            sig_f[j, i] = np.sqrt(max(P[i, i], 0.0))
        par_out[j] = par
        bias_out[j, :3], bias_out[j, 3:] = b_g, b_a
        fsum[:] = 0.0
        wz_sum = 0.0
        if i_sz >= 0:
            s_z += x[i_sz]
            sz_out[j] = s_z
        lz[:] = 0.0
        lvl[:] = 0.0
        lvd[:] = 0.0
        lnu[:] = 0.0
        lvda[:] = 0.0
        la = 0.0
        lc[:, :] = 0.0
        ln = 0
        for i in range(4):
            q_out[k, i] = q[i]
        for i in range(3):
            if full:
                v_out[k, i] = v[i]
                p_out[k, i] = pos[i]
    return (
        q_out,
        v_out,
        p_out,
        fu_out,
        fen_out,
        fb_out,
        ck,
        upd,
        sig_f,
        fin,
        dts,
        dxs,
        par_out,
        bias_out,
        nis,
        rejected,
        sz_out,
    )


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
def _block_covs(ck, upd, fin, dts, b, qd, inv_tau, i_sz, aug_idx, zupt_r, blk, ws, blk_m, blk_pm):
    """P⁺ of the epochs b·CK_EVERY … into ``blk`` (K, n, n), redone from the checkpoint of block b;
    with Φ_e P⁺_{e−1} into ``blk_m`` and P⁻_e into ``blk_pm`` (index e − b·CK_EVERY; both (K, n, n),
    or (0, n, n): not kept). Returns the number of epochs filled. ``ws``: (3, n, n) work space."""
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
        _phi_into(fin[e], dts[e], inv_tau, i_sz, Phi, A, ph)
        P = blk[e - j0]
        # what the smoother's step j = e − 1 needs, when kept: Φ P⁺_j (written in place) and P⁻_{j+1}
        _propagate(blk[e - j0 - 1], Phi, qd, dts[e], blk_m[e - j0] if keep else M, P)
        if keep:
            blk_pm[e - j0] = P
        _redo_updates(P, upd[e], aug_idx, zupt_r, H, ph, nz)
    return j1 - j0


@nb.njit(cache=True)
def forward_covs(ck, upd, fin, dts, qd, inv_tau, i_sz, aug_idx, zupt_sigma):
    """The forward P⁺ (M+1, n, n) of every epoch, redone from the checkpoints."""
    zupt_r = zupt_sigma**2
    m1 = dts.shape[0]
    n = len(qd)
    out = np.empty((m1, n, n))
    blk = np.empty((CK_EVERY, n, n))
    ws = np.empty((3, n, n))
    none = np.empty((0, n, n))
    for b in range(ck.shape[0]):
        cnt = _block_covs(ck, upd, fin, dts, b, qd, inv_tau, i_sz, aug_idx, zupt_r, blk, ws, none, none)
        out[b * CK_EVERY : b * CK_EVERY + cnt] = blk[:cnt]
    return out


@nb.njit(cache=True)
def rts(ck, upd, fin, dts, dxs, qd, inv_tau, i_sz, aug_idx, zupt_sigma, keep_cov):
    """Rauch-Tung-Striebel smoother over the stored closed-loop forward pass.

    Works backwards block by block: the forward P⁺ of a block's epochs is redone from its
    checkpoint and the epochs' update records (the same arithmetic as the forward pass, so the same
    numbers), Φ_{j+1} is rebuilt from ``fin`` and P⁻_{j+1} = Φ P⁺_j Φᵀ + Q T recomputed.
    Returns x_s (M+1, n): smoothed error of the post-feedback nominal at each epoch; the 1-σ
    (M+1, n) of P_s; and P_s (M+1, n, n) when ``keep_cov`` (else an empty (0, n, n)).
    """
    zupt_r = zupt_sigma**2
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
    n_blk = ck.shape[0]
    for b in range(n_blk - 1, -1, -1):
        cnt = _block_covs(ck, upd, fin, dts, b, qd, inv_tau, i_sz, aug_idx, zupt_r, blk, ws, blk_m, blk_pm)
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
                _phi_into(fin[j + 1], dts[j + 1], inv_tau, i_sz, Phi, M, tmp)
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
def apply_corrections(t, ep_t, decim, m, xs, dxs, q, v, p, fu, fen, fb):
    """Correct the forward nominal at every sample, in place, with the smoothed error interpolated
    in time from x_s(j−1) to x_s(j) + dx_j (the post-update sample of epoch j takes x_s(j)).

    The up specific force f_U (n frame, per interval) gets the same attitude correction,
    f ← (I + [φ×]) f (with the E, N components ``fen``), and the smoothed accelerometer-bias
    correction, f ← f − C_s^n δ∇; ``fb`` (the up component of C_s^n b̂_a) gets + (C_s^n δ∇)_U.
    Empty v, p, f (an attitude-only run): only q is corrected; empty f alone: q, v, p."""
    n_s = len(t)
    full = len(v) == n_s
    forces = len(fu) == n_s
    x = np.zeros(15)
    for k in range(n_s):
        if k < m * decim:
            j = k // decim + 1
            if (k + 1) % decim == 0:
                for i in range(15):
                    x[i] = xs[j, i]
            else:
                ta, tb = ep_t[j - 1], ep_t[j]
                w = (t[k] - ta) / (tb - ta) if tb > ta else 1.0
                for i in range(15):
                    x[i] = (1.0 - w) * xs[j - 1, i] + w * (xs[j, i] + dxs[j, i])
        else:
            for i in range(15):
                x[i] = xs[m, i]
        cc, ss = _rv(x[0], x[1], x[2])
        a0, a1, a2, a3 = cc, ss * x[0], ss * x[1], ss * x[2]
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
            v[k, i] -= x[3 + i]
        rm, rn = radii_nb(p[k, 0])
        p0, p2 = p[k, 0], p[k, 2]
        p[k, 0] = p0 - x[7] / (rm + p2)
        p[k, 1] = p[k, 1] - x[6] / ((rn + p2) * np.cos(p0))
        p[k, 2] = p2 - x[8]
        if not forces:
            continue
        # (C_s^n δ∇)_U with the corrected attitude: its third row
        c20 = 2 * (n1 * n3 - n0 * n2)
        c21 = 2 * (n2 * n3 + n0 * n1)
        c22 = 1 - 2 * (n1 * n1 + n2 * n2)
        da = c20 * x[12] + c21 * x[13] + c22 * x[14]
        fu[k] = fu[k] + (x[0] * np.float64(fen[k, 1]) - x[1] * np.float64(fen[k, 0])) - da
        fb[k] = fb[k] + da


@nb.njit(cache=True, inline="always")
def _rv(a0, a1, a2):
    """(c, s) of the quaternion [c, s a] of rotation vector a (as :func:`attitude.q_rotvec`)."""
    n2 = a0 * a0 + a1 * a1 + a2 * a2
    if n2 < 1e-16:
        return 1.0 - n2 / 8.0, 0.5 - n2 / 48.0
    a = np.sqrt(n2)
    return np.cos(a / 2), np.sin(a / 2) / a
