"""Compiled loops: closed-loop forward filter (mechanization + error-state KF) and RTS smoother.

Filter epochs fall every ``decim`` IMU samples. Between epochs the LDV residual
v̂_head − Ĉ_b^n V̂^b is averaged; a GNSS fix is brought to the epoch (back-dated by v̂·Δt).
Scalar sequential updates with an innovation gate; after each epoch the estimate is fed
back and the error state reset. Stored per epoch for the smoother: Φ, P⁺, Δt and the
feedback dx (see :mod:`ldvsurvey.nav.filter` for the smoothing algebra).

Augmented LDV states (when enabled, in this order after the 15): δs_f, δη_L (rad), δφ_L (rad),
δs_u, δk_η (rad per m/s²), where s = 1/K is the factor applied to the measured speed
(V_d = [0, s_f ν_f, s_u ν_u]) and the travel direction the LDV sees is pitched by
η_L + k_η·a_f, a_f the forward acceleration (the body's squat and dive under acceleration).
Inverse scales are estimated additively, so the feedback is linear like the smoother's algebra.
"""

from __future__ import annotations

import numba as nb
import numpy as np

from ldvsurvey.nav.attitude import cross, q_rotvec, q_to_c, qmul
from ldvsurvey.nav.earth import radii_nb
from ldvsurvey.nav.errmodel import build_f, c_db, discretize, skew_nb
from ldvsurvey.nav.mech import mech_step


@nb.njit(cache=True)
def feedback(x, q, v, pos, v_prev, pos_prev, b_g, b_a):
    """Closed-loop reset of the 15 base states: C ← (I + [φ×]) C, v ← v − δv, p ← p − δp (metres to
    lat/lon), biases += estimates. The previous velocity/position (used for mid-interval
    extrapolation) get the same correction. Returns the corrected (q, v, pos, v_prev, pos_prev, b_g, b_a)."""
    q = qmul(q_rotvec(x[0:3]), q)
    q = q / np.sqrt(np.sum(q * q))
    rm, rn = radii_nb(pos[0])
    dpos = np.array([x[7] / (rm + pos[2]), x[6] / ((rn + pos[2]) * np.cos(pos[0])), x[8]])
    return (q, v - x[3:6], pos - dpos, v_prev - x[3:6], pos_prev - dpos, b_g + x[9:12], b_a + x[12:15])


MAX_REJECT_RUN = 5  #: epochs of consecutive rejections after which a measurement is taken anyway


@nb.njit(cache=True)
def _gated_rows(x, P, H, z, r, gate, kind, run, rejected, nis_row):
    """Scalar updates for the rows of one measurement type with the innovation gate and its
    lock-out protection: after MAX_REJECT_RUN epochs with a rejection the gate is lifted.
    ``kind`` indexes ``run``/``rejected``; normalized innovations go to ``nis_row``."""
    g_eff = gate if run[kind] < MAX_REJECT_RUN else 0.0
    any_rej = False
    for i in range(H.shape[0]):
        ok, nz = _scalar_update(x, P, H[i], z[i], r[i], g_eff)
        nis_row[i] = nz
        if not ok:
            rejected[kind] += 1
            any_rej = True
    run[kind] = run[kind] + 1 if any_rej else 0


@nb.njit(cache=True)
def _scalar_update(x, P, h, z, r, gate):
    """One scalar measurement z = h·x + noise(r). Returns accepted (bool) and normalized innovation.

    ``gate`` ≤ 0 accepts every measurement."""
    ph = P @ h
    s = h @ ph + r
    nu = z - h @ x
    if gate > 0 and nu * nu > gate * gate * s:
        return False, nu / np.sqrt(s)
    k = ph / s
    x += k * nu
    P -= np.outer(k, ph)
    return True, nu / np.sqrt(s)


@nb.njit(cache=True)
def forward(t, dth, dvel, c_bs, q0, v0, pos0, xi, eta, dg,
            decim, p0, qd, zupt_epoch, zupt_sigma,
            ldv_ok, nu_f, nu_u, ldv_par0, l_ldv, ldv_sigma, ldv_up, aug_idx,
            g_t, g_pos, g_sig, l_gnss, gate, bias0, a_fwd):
    """Run the forward filter. See the Python wrapper :func:`ldvsurvey.nav.filter.run_filter`."""
    n_s = len(t)
    n = len(p0)
    m = n_s // decim
    q_out = np.empty((n_s, 4))
    v_out = np.empty((n_s, 3))
    p_out = np.empty((n_s, 3))
    f_out = np.empty((n_s, 3))  # mean specific force in n over each interval, as integrated
    fb_out = np.empty(n_s)  # its up component of the accelerometer-bias correction (C_s^n b̂_a)_U
    phis = np.empty((m + 1, n, n))
    pplus = np.empty((m + 1, n, n))
    dts = np.zeros(m + 1)
    dxs = np.zeros((m + 1, n))
    par_out = np.empty((m + 1, 5))
    bias_out = np.empty((m + 1, 6))
    nis = np.full((m + 1, 9), np.nan)  # normalized innovations: zupt(3), ldv(3), gnss(3)
    rejected = np.zeros(3, dtype=np.int64)
    run = np.zeros(3, dtype=np.int64)  # consecutive epochs with a rejection, per measurement type

    q, v, pos = q0.copy(), v0.copy(), pos0.copy()
    v_prev, pos_prev = v.copy(), pos.copy()
    dth_prev, dv_prev = dth[0].copy(), dvel[0].copy()
    b_g, b_a = bias0[:3].copy(), bias0[3:].copy()
    par = ldv_par0.copy()  # K_f, eta_L, phi_L, K_u
    P = np.diag(p0)
    pplus[0] = P
    phis[0] = np.eye(n)
    par_out[0] = par
    bias_out[0, :3], bias_out[0, 3:] = b_g, b_a
    has_g = len(xi) > 0
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
    for kk in range(0, n_s, max(1, n_s // 50)):  # identity C_b^s (fixed IMU): skip the products
        if np.abs(c_bs[kk] - np.eye(3)).max() > 0.0:
            rotating = True
            break
    cdb = c_db(par[1], par[2])  # LDV mounting; changes only at feedback
    c_bn_prev = q_to_c(q) @ c_bs[0] if rotating else q_to_c(q)
    j = 0
    for k in range(n_s):
        dt = t[k] - t_prev
        t_prev = t[k]
        gx = xi[k] if has_g else 0.0
        ge = eta[k] if has_g else 0.0
        gd = dg[k] if has_g else 0.0
        a_th = dth[k] - b_g * dt
        a_dv = dvel[k] - b_a * dt
        q_new, v_new, p_new, f_n = mech_step(q, v, pos, v_prev, pos_prev, a_th, a_dv, dth_prev, dv_prev,
                                             dt, gx, ge, gd)
        v_prev, pos_prev = v, pos
        q, v, pos = q_new, v_new, p_new
        dth_prev, dv_prev = a_th, a_dv
        fsum += f_n * dt
        f_out[k] = f_n
        c_sn = q_to_c(q)
        fb_out[k] = c_sn[2, 0] * b_a[0] + c_sn[2, 1] * b_a[1] + c_sn[2, 2] * b_a[2]
        c_bn = c_sn @ c_bs[k] if rotating else c_sn
        if ldv_ok[k]:
            vd1 = nu_f[k] * par[0]
            vd2 = (nu_u[k] * par[3]) if ldv_up else 0.0
            # V^b = C_d^b [0, vd1, vd2]; v_l = C_b^n V^b (scalars: no small-array allocations)
            if use_k:  # C_d^b(η_L + k a, φ_L): forward and up columns
                ak = a_fwd[k]
                ee = par[1] + par[4] * ak
                ce, se, cp, sp = np.cos(ee), np.sin(ee), np.cos(par[2]), np.sin(par[2])
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
        c_bn_prev = c_bn
        while gi < n_g and g_t[gi] <= t[k]:
            # GNSS fix at g_t[gi] in (t[k-1], t[k]]: residual INS − GNSS at the antenna, local metres
            rm, rn = radii_nb(pos[0])
            back = t[k] - g_t[gi]
            lev = c_bn @ l_gnss
            gz[0] = (pos[1] - g_pos[gi, 1]) * (rn + pos[2]) * np.cos(pos[0]) + lev[0] - v[0] * back
            gz[1] = (pos[0] - g_pos[gi, 0]) * (rm + pos[2]) + lev[1] - v[1] * back
            gz[2] = pos[2] - g_pos[gi, 2] + lev[2] - v[2] * back
            gc = c_bn.copy()
            gsig[0], gsig[1] = g_sig[gi, 0], g_sig[gi, 1]
            g_pending = True
            gi += 1
        q_out[k] = q
        v_out[k] = v
        p_out[k] = pos
        if (k + 1) % decim != 0:
            continue
        # ---- filter epoch ----
        j += 1
        T = t[k] - t_epoch
        t_epoch = t[k]
        F = np.zeros((n, n))
        F[:15, :15] = build_f(15, c_sn, fsum / T, v, pos[0], pos[2])[:15, :15]
        Phi = discretize(F, T)
        P = Phi @ P @ Phi.T
        for i in range(n):
            P[i, i] += qd[i] * T
        phis[j] = Phi
        dts[j] = T
        x = np.zeros(n)
        if zupt_epoch[j]:
            H = np.zeros((3, n))
            for i in range(3):
                H[i, 3 + i] = 1.0
            _gated_rows(x, P, H, v, np.full(3, zupt_sigma ** 2), gate, 0, run, rejected, nis[j, 0:3])
        if ln > 0:
            z = lz / ln
            v_l = lvl / ln
            vd = lvd / ln
            cb = lc / ln
            ch = c_db(par[1] + par[4] * la / ln, par[2]) if use_k else cdb
            cols = np.zeros((3, 5))
            cols[:, 0] = -cb @ (ch @ np.array([0.0, lnu[0] / ln, 0.0]))
            cols[:, 1] = -cb @ (ch @ cross(np.array([1.0, 0.0, 0.0]), vd))
            cols[:, 2] = -cb @ cross(np.array([0.0, 0.0, 1.0]), ch @ vd)
            cols[:, 3] = -cb @ (ch @ np.array([0.0, 0.0, lnu[1] / ln]))
            cols[:, 4] = -cb @ (ch @ cross(np.array([1.0, 0.0, 0.0]), lvda / ln))
            hphi = -skew_nb(v_l)
            H = np.zeros((3, n))
            for i in range(3):
                H[i, 0:3] = hphi[i]
                H[i, 3 + i] = 1.0
                for a in range(5):
                    if aug_idx[a] >= 0:
                        H[i, aug_idx[a]] = cols[i, a]
            _gated_rows(x, P, H, z, ldv_sigma ** 2 / ln, gate, 1, run, rejected, nis[j, 3:6])
        if g_pending:
            hphi = skew_nb(gc @ l_gnss)
            H = np.zeros((3, n))
            for i in range(3):
                H[i, 0:3] = hphi[i]
                H[i, 6 + i] = 1.0
            r_g = np.array([gsig[0] ** 2, gsig[0] ** 2, gsig[1] ** 2])
            _gated_rows(x, P, H, gz, r_g, gate, 2, run, rejected, nis[j, 6:9])
            g_pending = False
        P = 0.5 * (P + P.T)
        # ---- feedback ----
        q, v, pos, v_prev, pos_prev, b_g, b_a = feedback(x, q, v, pos, v_prev, pos_prev, b_g, b_a)
        if aug_idx[0] >= 0:
            par[0] -= x[aug_idx[0]]
        if aug_idx[1] >= 0:
            par[1] -= x[aug_idx[1]]
        if aug_idx[2] >= 0:
            par[2] -= x[aug_idx[2]]
        if aug_idx[3] >= 0:
            par[3] -= x[aug_idx[3]]
        if aug_idx[4] >= 0:
            par[4] -= x[aug_idx[4]]
        cdb = c_db(par[1], par[2])
        c_bn_prev = q_to_c(q) @ c_bs[k] if rotating else q_to_c(q)
        dxs[j] = x
        pplus[j] = P
        par_out[j] = par
        bias_out[j, :3], bias_out[j, 3:] = b_g, b_a
        fsum[:] = 0.0
        lz[:] = 0.0
        lvl[:] = 0.0
        lvd[:] = 0.0
        lnu[:] = 0.0
        lvda[:] = 0.0
        la = 0.0
        lc[:, :] = 0.0
        ln = 0
        q_out[k] = q
        v_out[k] = v
        p_out[k] = pos
    return q_out, v_out, p_out, f_out, fb_out, phis, pplus, dts, dxs, par_out, bias_out, nis, rejected


@nb.njit(cache=True)
def rts(phis, pplus, dts, dxs, qd):
    """Rauch-Tung-Striebel smoother over the stored closed-loop forward pass.

    Returns x_s (M+1, n): smoothed error of the post-feedback nominal at each epoch,
    and P_s (M+1, n, n).
    """
    m1, n, _ = pplus.shape
    xs = np.zeros((m1, n))
    ps = np.empty((m1, n, n))
    ps[m1 - 1] = pplus[m1 - 1]
    for j in range(m1 - 2, -1, -1):
        Phi = phis[j + 1]
        pm = Phi @ pplus[j] @ Phi.T
        for i in range(n):
            pm[i, i] += qd[i] * dts[j + 1]
        # A = P⁺_j Φᵀ (P⁻_{j+1})⁻¹  ⇒  Aᵀ = solve(P⁻, Φ P⁺_j)
        at = np.linalg.solve(pm, Phi @ pplus[j])
        a = at.T
        xs[j] = a @ (xs[j + 1] + dxs[j + 1])
        ps[j] = pplus[j] + a @ (ps[j + 1] - pm) @ at
    return xs, ps


@nb.njit(cache=True)
def apply_corrections(t, ep_t, decim, m, xs, dxs, q, v, p, f, fb):
    """Correct the forward nominal at every sample with the smoothed error interpolated in time
    from x_s(j−1) to x_s(j) + dx_j (the post-update sample of epoch j takes x_s(j)).

    The specific force f (n frame, per interval) gets the same attitude correction,
    f ← (I + [φ×]) f, and the smoothed accelerometer-bias correction, f ← f − C_s^n δ∇;
    ``fb`` (the up component of C_s^n b̂_a) gets + (C_s^n δ∇)_U."""
    n_s = len(t)
    q2 = np.empty_like(q)
    v2 = np.empty_like(v)
    p2 = np.empty_like(p)
    f2 = np.empty_like(f)
    fb2 = np.empty_like(fb)
    x = np.zeros(15)
    for k in range(n_s):
        if k < m * decim:
            j = k // decim + 1
            if (k + 1) % decim == 0:
                x[:] = xs[j, :15]
            else:
                ta, tb = ep_t[j - 1], ep_t[j]
                w = (t[k] - ta) / (tb - ta) if tb > ta else 1.0
                x[:] = (1.0 - w) * xs[j - 1, :15] + w * (xs[j, :15] + dxs[j, :15])
        else:
            x[:] = xs[m, :15]
        qc = qmul(q_rotvec(x[0:3]), q[k])
        q2[k] = qc / np.sqrt(np.sum(qc * qc))
        v2[k] = v[k] - x[3:6]
        rm, rn = radii_nb(p[k, 0])
        p2[k, 0] = p[k, 0] - x[7] / (rm + p[k, 2])
        p2[k, 1] = p[k, 1] - x[6] / ((rn + p[k, 2]) * np.cos(p[k, 0]))
        p2[k, 2] = p[k, 2] - x[8]
        c = q_to_c(q2[k])
        da = c @ x[12:15]
        f2[k] = f[k] + cross(x[0:3], f[k]) - da
        fb2[k] = fb[k] + da[2]
    return q2, v2, p2, f2, fb2
