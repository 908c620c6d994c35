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

import numba as nb
import numpy as np

from ldvsurvey.nav.attitude import q_to_c_into
from ldvsurvey.nav.errmodel import c_db, skew_nb
from ldvsurvey.nav.kfloop import N_FIN, c_bn_into, feedback_into, mech_sample, propagate_epoch

MODES = {"undamped": 0, "conventional": 1, "delayed_state": 2}
N = 16

#: the damping filter's settings: mode (:data:`MODES`), period_s (s between covariance epochs),
#: ds_every (epochs between the two residuals of a delayed-state measurement: the baseline),
#: gate (σ on the delayed-state velocity change), zupt_end_s (end of the moored period, s),
#: p0, qd (16,) prior variances and PSDs, h_ref (m) the water-surface height, vu_sigma (m/s) and
#: h_sigma (m) of the vertical-channel pseudo-measurements
Damping = namedtuple("Damping", "mode period_s ds_every gate zupt_end_s p0 qd h_ref vu_sigma h_sigma")
#: the water-track LDV: ok (N,) bool, nu_f (N,) forward speed (m/s), s0 the inverse scale 1/K at the
#: start, pitch, heading (rad) its mounting C_d^b, sigma (m/s) 1-σ of one sample
WaterLdv = namedtuple("WaterLdv", "ok nu_f s0 pitch heading sigma")


@nb.njit(cache=True)
def _update(x, P, h, z, r):
    ph = P @ h
    s = h @ ph + r
    k = ph / s
    x += k * (z - h @ x)
    P -= np.outer(k, ph)


@nb.njit(cache=True)
def run_damping(imu, st, ldv, dmp):
    """Forward filter; returns q (N,4) of C_s^n, v (N,3), pos (N,3), inverse scale estimate per
    sample, and the number of skipped delayed-state measurements.

    ``imu`` (:class:`~ldvsurvey.nav.kfloop.ImuIn`): ``c_bs`` (N, 3, 3) C_b^s per sample (a
    rotating IMU) or (1, 3, 3) for a fixed one (taken as the identity, as the navigation filter
    does); xi, eta, dg empty (normal gravity) or per sample. ``st``
    (:class:`~ldvsurvey.nav.kfloop.Start`): initial C_s^n, v, position and biases. The
    mechanization and the biases live in the sensor frame s; the LDV (:class:`WaterLdv`) is mounted
    on the body b, so its velocity is brought to n through C_b^n = C_s^n C_b^s.

    Covariance epochs every ``dmp.period_s``; the delayed-state measurement compares residuals
    ``dmp.ds_every`` epochs apart (the baseline over which the current must stay constant); a
    velocity change beyond ``dmp.gate`` σ (the current changed) is skipped and the baseline
    restarts there. The per-sample mechanization (:func:`~ldvsurvey.nav.kfloop.mech_sample`),
    Φ and the covariance propagation (:func:`~ldvsurvey.nav.kfloop.propagate_epoch`) and the
    feedback are the navigation filter's compiled functions; the measurement models are this
    module's.
    """
    t, dth, dvel, c_bs = imu.t, imu.dth, imu.dvel, imu.c_bs
    mode, period_s, zupt_end, ds_every, gate = dmp.mode, dmp.period_s, dmp.zupt_end_s, dmp.ds_every, dmp.gate
    qd, h_ref, vu_sigma, h_sigma = dmp.qd, dmp.h_ref, dmp.vu_sigma, dmp.h_sigma
    ldv_ok, nu_f, ldv_sigma = ldv.ok, ldv.nu_f, ldv.sigma
    n_s = len(t)
    q_out = np.empty((n_s, 4))
    v_out = np.empty((n_s, 3))
    p_out = np.empty((n_s, 3))
    s_out = np.empty(n_s)
    q, v, pos = st.q.copy(), st.v.copy(), st.pos.copy()
    v_prev, pos_prev = v.copy(), pos.copy()
    dth_prev, dv_prev = dth[0].copy(), dvel[0].copy()
    a_th = np.empty(3)
    a_dv = np.empty(3)
    f_n = np.empty(3)
    b_g, b_a = st.bias[:3].copy(), st.bias[3:].copy()
    s_ldv = ldv.s0
    P = np.diag(dmp.p0)
    Pm = np.empty((N, N))
    Phi = np.empty((N, N))
    M = np.empty((N, N))
    fin = np.zeros(N_FIN)  # what Φ is built from, as the navigation filter stores it per epoch
    no_tau = np.zeros(N)  # no Gauss–Markov states
    c_sn = np.empty((3, 3))
    c_bn = np.empty((3, 3))
    rotating = c_bs.shape[0] > 1
    cdb = c_db(ldv.pitch, ldv.heading)
    fsum = np.zeros(3)
    racc = np.zeros(3)  # residual v_SINS − v_LDV summed over the period
    vlacc = np.zeros(3)
    nuacc = 0.0
    cacc = np.zeros((3, 3))
    nl = 0
    t_prev = t[0] - (t[1] - t[0])
    t_epoch = t_prev
    # delayed state: the previous epoch's residual, its H rows and the cross covariance Cov(x_k, x_{k−1})
    have_prev = False
    epoch_no = 0
    rejected = 0
    r_prev = np.zeros(3)
    h_prev = np.zeros((2, N))
    P_clone = np.zeros((N, N))
    P_cross = np.zeros((N, N))
    for k in range(n_s):
        dt = t[k] - t_prev
        t_prev = t[k]
        mech_sample(
            imu, k, dt, b_g, b_a, 0.0, -1, q, v, pos, v_prev, pos_prev, dth_prev, dv_prev, a_th, a_dv, f_n, fsum
        )
        q_to_c_into(q, c_sn)
        c_bn_into(c_sn, c_bs, k, rotating, c_bn)
        if ldv_ok[k] and t[k] > zupt_end:
            vd = np.array([0.0, nu_f[k] * s_ldv, 0.0])
            v_l = c_bn @ (cdb @ vd)
            racc += v - v_l
            vlacc += v_l
            nuacc += nu_f[k]
            cacc += c_bn
            nl += 1
        q_out[k] = q
        v_out[k] = v
        p_out[k] = pos
        s_out[k] = s_ldv
        if t[k] - t_epoch < period_s - 1e-9 and k < n_s - 1:
            continue
        T = t[k] - t_epoch
        t_epoch = t[k]
        epoch_no += 1
        propagate_epoch(fin, c_sn, fsum, v, pos, 0.0, T, no_tau, -1, qd, P, Phi, M, Pm)
        P, Pm = Pm, P
        # the working covariance: [x_k] alone, or [x_k; clone] when a delayed state is carried
        aug = mode == 2 and have_prev
        na = 2 * N if aug else N
        Pa = np.zeros((na, na))
        Pa[:N, :N] = P
        if aug:
            P_cross = Phi @ P_cross
            Pa[:N, N:] = P_cross
            Pa[N:, :N] = P_cross.T
            Pa[N:, N:] = P_clone
        xa = np.zeros(na)
        static = t[k] <= zupt_end
        # vertical channel: the vessel stays on the water surface
        ha = np.zeros(na)
        ha[5] = 1.0
        _update(xa, Pa, ha, v[2], vu_sigma**2)
        ha = np.zeros(na)
        ha[8] = 1.0
        _update(xa, Pa, ha, pos[2] - h_ref, h_sigma**2)
        took_ds = False
        if static:
            for i in range(2):
                ha = np.zeros(na)
                ha[3 + i] = 1.0
                _update(xa, Pa, ha, v[i], 0.003**2)
        elif nl > 0 and mode > 0 and (mode == 1 or epoch_no % ds_every == 0 or not have_prev):
            r = racc / nl
            vl = vlacc / nl
            cb = cacc / nl
            hphi = -skew_nb(vl)
            col_s = -cb @ (cdb @ np.array([0.0, nuacc / nl, 0.0]))
            hk = np.zeros((2, N))
            for i in range(2):
                hk[i, 0:3] = hphi[i]
                hk[i, 3 + i] = 1.0
                hk[i, 15] = col_s[i]
            rr = ldv_sigma**2 / nl
            if mode == 1:
                for i in range(2):
                    ha = np.zeros(na)
                    ha[:N] = hk[i]
                    _update(xa, Pa, ha, r[i], rr)
            elif aug:
                # a change of the current between the two residuals breaks the method's premise:
                # gate the velocity change, and on rejection start a new baseline here
                ok = True
                for i in range(2):
                    ha = np.zeros(na)
                    ha[:N] = hk[i]
                    ha[N:] = -h_prev[i]
                    nu = r[i] - r_prev[i] - ha @ xa
                    if nu * nu > gate * gate * (ha @ Pa @ ha + 2 * rr):
                        ok = False
                if ok:
                    for i in range(2):
                        ha = np.zeros(na)
                        ha[:N] = hk[i]
                        ha[N:] = -h_prev[i]
                        _update(xa, Pa, ha, r[i] - r_prev[i], 2 * rr)
                else:
                    rejected += 1
            if mode == 2:
                took_ds = True
                x_now = xa[:N]
                r_prev = r.copy()
                for i in range(2):  # residual of the post-feedback nominal: the next delayed term
                    r_prev[i] = r[i] - hk[i] @ x_now
                h_prev = hk.copy()
        x = xa[:N].copy()
        P = 0.5 * (Pa[:N, :N] + Pa[:N, :N].T)
        if aug:
            P_cross = Pa[:N, N:].copy()
            P_clone = Pa[N:, N:].copy()
        if took_ds:  # this epoch's error becomes the delayed state of the next measurement
            P_clone = P.copy()
            P_cross = P.copy()
            have_prev = True
        # feedback
        feedback_into(x, q, v, pos, v_prev, pos_prev, b_g, b_a)
        s_ldv = s_ldv - x[15]
        q_out[k] = q
        v_out[k] = v
        p_out[k] = pos
        fsum[:] = 0.0
        racc[:] = 0.0
        vlacc[:] = 0.0
        nuacc = 0.0
        cacc[:, :] = 0.0
        nl = 0
    return q_out, v_out, p_out, s_out, rejected
