"""Water-velocity horizontal damping of SINS (methods §6, damping paper).

16 error states: the 15 of :mod:`ldvsurvey.nav.errmodel` plus δs, the error of the LDV's inverse
scale (V^b = C_d^b [0, s ν, 0]). Three modes over the same data, updated once per ``period``:

* ``undamped``: pure inertial (zero-velocity updates while moored, height held);
* ``conventional``: Z = v_SINS − v_LDV (E, N), which takes the water current as an error;
* ``delayed_state``: Z_k = r_k − r_{k−1} with r = v_SINS − v_LDV, which cancels a current that is
  constant between updates. The measurement involves the error state at t_{k−1}, so the filter
  carries that state as a clone (stochastic cloning, the delayed-state filter of Brown & Hwang):
  P_aug = [[P_k, Φ P_{k−1}], [P_{k−1} Φᵀ, P_{k−1}]], H_aug = [H_k, −H_{k−1}].
"""

from __future__ import annotations

from collections import namedtuple
from typing import NamedTuple

import numba as nb
import numpy as np

from ldvsurvey.nav.attitude import q_to_c_into
from ldvsurvey.nav.errmodel import IX_AUG, IX_P, IX_PHI, IX_V, N_LDV_PAR, c_db, skew_nb
from ldvsurvey.nav.kfloop import (
    N_FIN,
    Bias,
    CovWork,
    ProcessModel,
    SampleWork,
    c_bn_into,
    feedback_into,
    mech_sample,
    propagate_epoch,
)
from ldvsurvey.nav.mech import NavState

MODES = {"undamped": 0, "conventional": 1, "delayed_state": 2}
N = 16
IX_DS = IX_AUG  #: the LDV's inverse-scale error δs, after the 15 base states

#: the damping filter's settings: mode (:data:`MODES`), period_s (s between covariance epochs),
#: ds_every (epochs between the two residuals of a delayed-state measurement: the baseline),
#: gate (σ on the delayed-state velocity change), zupt_end_s (end of the moored period, s),
#: p0, qd (16,) prior variances and PSDs, h_ref (m) the water-surface height, vu_sigma (m/s) and
#: h_sigma (m) of the vertical-channel pseudo-measurements
Damping = namedtuple("Damping", "mode period_s ds_every gate zupt_end_s p0 qd h_ref vu_sigma h_sigma")
#: the water-track LDV: ok (N,) bool, nu_f (N,) forward speed (m/s), s0 the inverse scale 1/K at the
#: start, pitch, heading (rad) its mounting C_d^b, sigma (m/s) 1-σ of one sample
WaterLdv = namedtuple("WaterLdv", "ok nu_f s0 pitch heading sigma")


class WaterSums(NamedTuple):
    """The water-track residual's sums over the current period."""

    r_n_mps: np.ndarray  #: (3,) Σ v_SINS − v_LDV, m/s
    v_l_n_mps: np.ndarray  #: (3,) Σ v_LDV, m/s
    c_bn: np.ndarray  #: (3, 3) Σ C_b^n
    nu_n: np.ndarray  #: (2,) [Σ ν (m/s), the number of samples]


class DelayedState(NamedTuple):
    """The delayed-state measurement's memory: the previous residual, its H rows and the clone."""

    r_prev_n_mps: np.ndarray  #: (3,) the previous residual of the post-feedback nominal, m/s
    h_prev: np.ndarray  #: (2, N) its H rows
    P_clone: np.ndarray  #: (N, N) Cov(x_{k−1})
    P_cross: np.ndarray  #: (N, N) Cov(x_k, x_{k−1})
    cnt: np.ndarray  #: (3,) int: [a previous residual exists, epochs so far, rejected measurements]


class DampingOut(NamedTuple):
    """What :func:`run_damping` returns, per IMU sample (N) unless said."""

    q_sn: np.ndarray  #: (N, 4) C_s^n
    v_n_mps: np.ndarray  #: (N, 3) ENU
    pos_rad_m: np.ndarray  #: (N, 3) lat (rad), lon (rad), h (m)
    ldv_s: np.ndarray  #: (N,) the inverse-scale estimate 1/K
    rejected: int  #: delayed-state measurements skipped by the gate


@nb.njit(cache=True)
def _update(x, P, h, z, r):
    """Scalar Kalman update of x, P (in place) with the row h, measurement z and its variance r."""
    ph = P @ h
    s = h @ ph + r
    k = ph / s
    x += k * (z - h @ x)
    P -= np.outer(k, ph)


@nb.njit(cache=True)
def _unit_row(na, i):
    """The H row (na,) of a direct measurement of state i."""
    ha = np.zeros(na)
    ha[i] = 1.0
    return ha


@nb.njit(cache=True)
def _water_sample(ldv, k, s_ldv, cdb, c_bn, v, sums):
    """Add sample k to the period's sums: v_LDV = C_b^n C_d^b [0, s ν, 0] and the residual v − v_LDV."""
    vd = np.array([0.0, ldv.nu_f[k] * s_ldv, 0.0])
    v_l = c_bn @ (cdb @ vd)
    racc, vlacc, cacc = sums.r_n_mps, sums.v_l_n_mps, sums.c_bn
    racc += v - v_l
    vlacc += v_l
    sums.nu_n[0] += ldv.nu_f[k]
    cacc += c_bn
    sums.nu_n[1] += 1.0


@nb.njit(cache=True)
def _working_cov(cov, ds, aug):
    """The working covariance after the propagation: P alone, or [[P, Φ C], [(Φ C)ᵀ, P_clone]] with
    the delayed state (``aug``), its cross covariance C carried through Φ (written back to ``ds``)."""
    na = 2 * N if aug else N
    Pa = np.zeros((na, na))
    Pa[:N, :N] = cov.P
    if aug:
        ds.P_cross[:, :] = cov.Phi @ ds.P_cross
        Pa[:N, N:] = ds.P_cross
        Pa[N:, :N] = ds.P_cross.T
        Pa[N:, N:] = ds.P_clone
    return Pa


@nb.njit(cache=True)
def _water_rows(sums, cdb, ldv_sigma):
    """The period's mean residual r (3,) m/s, the H rows (2, N) of its E, N components and their
    variance (m/s)²."""
    nl = sums.nu_n[1]
    r = sums.r_n_mps / nl
    vl = sums.v_l_n_mps / nl
    cb = sums.c_bn / nl
    hphi = -skew_nb(vl)
    col_s = -cb @ (cdb @ np.array([0.0, sums.nu_n[0] / nl, 0.0]))
    hk = np.zeros((2, N))
    for i in range(2):
        hk[i, IX_PHI : IX_PHI + 3] = hphi[i]
        hk[i, IX_V + i] = 1.0
        hk[i, IX_DS] = col_s[i]
    rr = ldv_sigma**2 / nl
    return r, hk, rr


@nb.njit(cache=True)
def _delayed_update(xa, Pa, r, hk, rr, ds, gate):
    """The delayed-state update Z = r_k − r_{k−1}, H = [H_k, −H_{k−1}]: a change of the current
    between the two residuals breaks the method's premise, so the velocity change is gated and on
    rejection (counted in ``ds.cnt[2]``) nothing is updated and a new baseline starts here."""
    ok = True
    for i in range(2):
        ha = np.zeros(len(xa))
        ha[:N] = hk[i]
        ha[N:] = -ds.h_prev[i]
        nu = r[i] - ds.r_prev_n_mps[i] - ha @ xa
        if nu * nu > gate * gate * (ha @ Pa @ ha + 2 * rr):
            ok = False
    if ok:
        for i in range(2):
            ha = np.zeros(len(xa))
            ha[:N] = hk[i]
            ha[N:] = -ds.h_prev[i]
            _update(xa, Pa, ha, r[i] - ds.r_prev_n_mps[i], 2 * rr)
    else:
        ds.cnt[2] += 1


@nb.njit(cache=True)
def _water_update(xa, Pa, sums, cdb, ldv, dmp, ds, aug):
    """The water-track measurement of the period: conventional (Z = r) or delayed-state; with the
    latter, this residual (of the post-update nominal) and its rows become the next one's delayed term."""
    r, hk, rr = _water_rows(sums, cdb, ldv.sigma)
    if dmp.mode == 1:
        for i in range(2):
            ha = np.zeros(len(xa))
            ha[:N] = hk[i]
            _update(xa, Pa, ha, r[i], rr)
    elif aug:
        _delayed_update(xa, Pa, r, hk, rr, ds, dmp.gate)
    if dmp.mode == 2:
        x_now = xa[:N]
        r_prev = ds.r_prev_n_mps
        r_prev[:] = r
        for i in range(2):  # residual of the post-feedback nominal: the next delayed term
            r_prev[i] = r[i] - hk[i] @ x_now
        ds.h_prev[:, :] = hk


@nb.njit(cache=True)
def _damping_epoch(cov, ds, sums, nav, static, dmp, ldv, cdb):
    """The updates of one covariance epoch (vertical channel; ZUPT while moored, else the water
    track) on the propagated ``cov``; returns the error state x (N,) to feed back, P updated."""
    have_prev = ds.cnt[0] != 0
    aug = dmp.mode == 2 and have_prev
    Pa = _working_cov(cov, ds, aug)
    na = Pa.shape[0]
    xa = np.zeros(na)
    v, pos = nav.v_n_mps, nav.pos_rad_m
    # vertical channel: the vessel stays on the water surface
    _update(xa, Pa, _unit_row(na, IX_V + 2), v[2], dmp.vu_sigma**2)
    _update(xa, Pa, _unit_row(na, IX_P + 2), pos[2] - dmp.h_ref, dmp.h_sigma**2)
    took_ds = False
    if static:
        for i in range(2):
            _update(xa, Pa, _unit_row(na, IX_V + i), v[i], 0.003**2)
    elif sums.nu_n[1] > 0 and dmp.mode > 0 and (dmp.mode == 1 or ds.cnt[1] % dmp.ds_every == 0 or not have_prev):
        _water_update(xa, Pa, sums, cdb, ldv, dmp, ds, aug)
        took_ds = dmp.mode == 2
    x = xa[:N].copy()
    cov.P[:, :] = 0.5 * (Pa[:N, :N] + Pa[:N, :N].T)
    if aug:
        ds.P_cross[:, :] = Pa[:N, N:]
        ds.P_clone[:, :] = Pa[N:, N:]
    if took_ds:  # this epoch's error becomes the delayed state of the next measurement
        ds.P_clone[:, :] = cov.P
        ds.P_cross[:, :] = cov.P
        ds.cnt[0] = 1
    return x


@nb.njit(cache=True)
def _reset_sums(wk, sums):
    """Zero the period's sums (specific force, water-track residual)."""
    wk.fsum_n_mps[:] = 0.0
    sums.r_n_mps[:] = 0.0
    sums.v_l_n_mps[:] = 0.0
    sums.c_bn[:, :] = 0.0
    sums.nu_n[:] = 0.0


@nb.njit(cache=True)
def _store(out, k, nav):
    """Sample k's attitude, velocity and position."""
    out.q_sn[k] = nav.q_sn
    out.v_n_mps[k] = nav.v_n_mps
    out.pos_rad_m[k] = nav.pos_rad_m


@nb.njit(cache=True)
def run_damping(imu, st, ldv, dmp):
    """Forward damping filter over all samples.

    The mechanization and the biases live in the sensor frame s; the LDV is mounted on the body b,
    so its velocity is brought to n through C_b^n = C_s^n C_b^s. Covariance epochs every
    ``dmp.period_s``; the delayed-state measurement compares residuals ``dmp.ds_every`` epochs
    apart (the baseline over which the current must stay constant); a velocity change beyond
    ``dmp.gate`` σ (the current changed) is skipped and the baseline restarts there. The per-sample
    mechanization (:func:`~ldvsurvey.nav.kfloop.mech_sample`), Φ and the covariance propagation
    (:func:`~ldvsurvey.nav.kfloop.propagate_epoch`) and the feedback are the navigation filter's
    compiled functions; the measurement models are this module's.

    Parameters
    ----------
    imu : :class:`~ldvsurvey.nav.kfloop.ImuIn`; ``c_bs`` (N, 3, 3) C_b^s per sample (a rotating
        IMU) or (1, 3, 3) for a fixed one (taken as the identity, as the navigation filter does);
        xi, eta, dg empty (normal gravity) or per sample.
    st : :class:`~ldvsurvey.nav.kfloop.Start`: initial C_s^n, v (m/s), position (rad, rad, m) and
        biases (rad/s, m/s²).
    ldv : :class:`WaterLdv`.
    dmp : :class:`Damping` settings.

    Returns
    -------
    DampingOut
        q (N, 4) of C_s^n, v (N, 3) m/s, pos (N, 3), the inverse-scale estimate per sample and the
        number of skipped delayed-state measurements.
    """
    t, c_bs = imu.t, imu.c_bs
    n_s = len(t)
    out = DampingOut(np.empty((n_s, 4)), np.empty((n_s, 3)), np.empty((n_s, 3)), np.empty(n_s), 0)
    nav = NavState(
        st.q.copy(), st.v.copy(), st.pos.copy(), st.v.copy(), st.pos.copy(), imu.dth[0].copy(), imu.dvel[0].copy()
    )
    bias = Bias(st.bias[:3].copy(), st.bias[3:].copy())
    wk = SampleWork(np.empty(3), np.empty(3), np.empty(3), np.zeros(3))
    # no Gauss–Markov states; no LDV state of the navigation filter's, no ZUPT of its kind
    proc = ProcessModel(dmp.qd, np.zeros(N), -1, -1, np.full(N_LDV_PAR, -1, dtype=np.int64), 0.0)
    cov = CovWork(np.diag(dmp.p0), np.empty((N, N)), np.empty((N, N)), np.empty((N, N)))
    ds = DelayedState(np.zeros(3), np.zeros((2, N)), np.zeros((N, N)), np.zeros((N, N)), np.zeros(3, dtype=np.int64))
    sums = WaterSums(np.zeros(3), np.zeros(3), np.zeros((3, 3)), np.zeros(2))
    s_ldv = ldv.s0
    fin = np.zeros(N_FIN)  # what Φ is built from, as the navigation filter stores it per epoch
    no_sf = np.zeros(6)  # no scale-factor state: none removed, no increment sums read
    c_sn = np.empty((3, 3))
    c_bn = np.empty((3, 3))
    rotating = c_bs.shape[0] > 1
    cdb = c_db(ldv.pitch, ldv.heading)
    t_prev = t[0] - (t[1] - t[0])
    t_epoch = t_prev
    # what the per-sample path touches, under names (a struct's field read in this loop is costly)
    q, v, ldv_ok, zupt_end_s, period_s, s_out = nav.q_sn, nav.v_n_mps, ldv.ok, dmp.zupt_end_s, dmp.period_s, out.ldv_s
    for k in range(n_s):
        dt = t[k] - t_prev
        t_prev = t[k]
        mech_sample(imu, k, dt, nav, bias, no_sf, 0, wk)
        q_to_c_into(q, c_sn)
        c_bn_into(c_sn, c_bs, k, rotating, c_bn)
        if ldv_ok[k] and t[k] > zupt_end_s:
            _water_sample(ldv, k, s_ldv, cdb, c_bn, v, sums)
        _store(out, k, nav)
        s_out[k] = s_ldv
        if t[k] - t_epoch < period_s - 1e-9 and k < n_s - 1:
            continue
        T = t[k] - t_epoch
        t_epoch = t[k]
        ds.cnt[1] += 1
        propagate_epoch(fin, c_sn, wk.fsum_n_mps, no_sf, nav, T, proc, cov)
        x = _damping_epoch(cov, ds, sums, nav, t[k] <= dmp.zupt_end_s, dmp, ldv, cdb)
        feedback_into(x, nav, bias)
        s_ldv = s_ldv - x[IX_DS]
        _store(out, k, nav)
        _reset_sums(wk, sums)
    return DampingOut(out.q_sn, out.v_n_mps, out.pos_rad_m, out.ldv_s, ds.cnt[2])
