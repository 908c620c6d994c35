"""Real-drive effects injected into the product's simulator for the filter/calibration/height tests.

Independent of the pipelines: the truth is built here from the simulator's motion model.

- **Squat/dive**: the body pitches against the travel direction by k·a (rad per m/s² of tangential
  acceleration a), on top of the stance mounting (η₀, φ₀): C_b^t(t) = C_d^b(η₀ + k·a(t), φ₀)ᵀ. The
  body rate gains ω_tb^b from the changing pitch. The LDV head is fixed in the body along the stance
  travel direction C_d^b(η₀, φ₀) e_y and measures the velocity component along its axis (so the
  travel direction the LDV sees is η₀ + k·a).
- **Gauss–Markov bias drift** of gyros and accelerometers (σ, τ) on top of the turn-on bias.
- **LDV dropout bursts** whose rows carry garbage (zeros, spikes, stale repeats) below min_quality,
  and spikes of a few m/s flagged good.
- **Gravity field** (ξ, η, Δg) through the simulator's ``field`` hook.
"""

from __future__ import annotations

import numpy as np

from ldvsurvey.nav.attitude import c_bs
from ldvsurvey.nav.earth import gravity_n, w_en_n, w_ie_n
from ldvsurvey.nav.errmodel import c_db
from ldvsurvey.sim.imu import GL_W, GL_X, ImuTruth
from ldvsurvey.sim.motion import Motion, Turntable
from ldvsurvey.sim.scenario import SimResult
from ldvsurvey.sim.sensors import ImuErrors, gnss_fixes

H_FD = 1e-3  # s, finite-difference step for the jerk


def _tangential(m: Motion, t):
    """Forward acceleration of the vehicle (m/s²): s̈ signed by the direction of travel along the road."""
    s, sd, sdd, *_ = m._kinematics(t)
    return sdd * np.sign(sd)


def _rates(m: Motion, t, eta0, phi0, k, field=None, table=None, alpha=0.0, beta=0.0):
    tr = m.truth(t)
    a = _tangential(m, t)
    lo, hi = m.t0_s, m.t_end_s
    ta, tb = np.clip(t - H_FD, lo, hi), np.clip(t + H_FD, lo, hi)
    jerk = (_tangential(m, tb) - _tangential(m, ta)) / np.maximum(tb - ta, 1e-12)
    th = eta0 + k * a
    c_tb = c_db(0.0, phi0)[None] @ np.array([c_db(x, 0.0) for x in th])  # C_t^b = R_z(φ) R_x(θ)
    c_bn = tr["c_tn"] @ np.swapaxes(c_tb, 1, 2)
    # Ċ_b^t = C_b^t [ω_tb^b×] with C_b^t = R_x(θ)ᵀ R_z(φ)ᵀ: ω_tb^b = −θ̇ R_z(φ) e_x
    w_tb_b = -(k * jerk)[:, None] * c_db(0.0, phi0)[:, 0][None, :]
    w_nb_b = np.einsum("kij,kj->ki", c_tb, tr["w_nt_t"]) + w_tb_b
    lat, lon, h, v_n = tr["lat_rad"], tr["lon_rad"], tr["h_m"], tr["v_n"]
    xi, eta, dg = field(lat, lon, h) if field is not None else (0.0, 0.0, 0.0)
    g_n = gravity_n(lat, h, xi, eta, dg)
    wie, wen = w_ie_n(lat), w_en_n(lat, h, v_n)
    f_n = tr["a_n"] + np.cross(2 * wie + wen, v_n) - g_n
    f_b = np.einsum("kji,kj->ki", c_bn, f_n)
    w_ib_b = w_nb_b + np.einsum("kji,kj->ki", c_bn, wie + wen)
    eta_t = None
    if table is not None:
        eta_t, eta_dot = table.angle(t)
        cbs = c_bs(eta_t, alpha, beta)
        w_s = np.einsum("kij,kj->ki", cbs, w_ib_b) + eta_dot[:, None] * cbs[:, :, 2]
        f_s = np.einsum("kij,kj->ki", cbs, f_b)
    else:
        w_s, f_s = w_ib_b, f_b
    return w_s, f_s, tr, c_bn, f_n, w_nb_b, eta_t


def _imu(m, t_s, eta0, phi0, k, field, table, alpha, beta, chunk=20000):
    n = len(t_s) - 1
    dth = np.empty((n, 3))
    dv = np.empty((n, 3))
    for a in range(0, n, chunk):
        b = min(n, a + chunk)
        t0, t1 = t_s[a:b], t_s[a + 1:b + 1]
        half, mid = (t1 - t0) / 2, (t1 + t0) / 2
        nodes = (mid[:, None] + half[:, None] * GL_X[None, :]).ravel()
        w_s, f_s, *_ = _rates(m, nodes, eta0, phi0, k, field, table, alpha, beta)
        wts = (half[:, None] * GL_W[None, :]).ravel()[:, None]
        dth[a:b] = (w_s * wts).reshape(b - a, 3, 3).sum(axis=1)
        dv[a:b] = (f_s * wts).reshape(b - a, 3, 3).sum(axis=1)
    w_s, f_s, tr, c_bn, f_n, w_nb_b, eta = _rates(m, t_s[1:], eta0, phi0, k, field, table, alpha, beta)
    return ImuTruth(t_s=t_s[1:], dtheta_rad=dth, dvel_mps=dv, eta_rad=eta, lat_rad=tr["lat_rad"],
                    lon_rad=tr["lon_rad"], h_m=tr["h_m"], v_n=tr["v_n"], c_bn=c_bn, f_n=f_n, w_nb_b=w_nb_b)


def _gm(rng, n, dt, sigma, tau):
    """(n, 3) first-order Gauss–Markov sequences of stationary σ and correlation time τ."""
    phi = np.exp(-dt / tau)
    out = np.empty((n, 3))
    out[0] = rng.normal(0, sigma, 3)
    drive = rng.normal(0, sigma * np.sqrt(1 - phi ** 2), (n, 3))
    from scipy.signal import lfilter

    for i in range(3):
        out[:, i], _ = lfilter([1.0], [1.0, -phi], drive[:, i], zi=[phi * out[0, i]])
    return out


def simulate_effects(sc, seed=1, squat_rad_per_mps2=0.0, gm_gyro_dph=0.0, gm_accel_ug=0.0, gm_tau_s=1800.0,
                     bursts_per_min=0.0, good_spikes=0, field=None):
    """A :class:`SimResult` of scenario ``sc`` with the effects above switched on."""
    rng = np.random.default_rng(seed)
    m = Motion(sc.road, sc.segments, sc.t0_s, dt_s=1.0 / sc.imu_rate_hz)
    dt = 1.0 / sc.imu_rate_hz
    n = int(round((m.t_end_s - sc.t0_s) / dt))
    t = sc.t0_s + np.arange(n + 1) * dt
    eta0, phi0 = sc.ldv.pitch_rad, sc.ldv.heading_rad
    table = Turntable(sc.t0_s, dwell_s=sc.turntable_dwell_s, dt_s=dt) if sc.rotating else None
    imu = _imu(m, t, eta0, phi0, squat_rad_per_mps2, field, table, sc.alpha_rad, sc.beta_rad)
    err = ImuErrors.draw(rng, sc.gyro_bias_dph, sc.accel_bias_ug, sc.gyro_arw_dprh, sc.accel_vrw_ug_rthz)
    dth, dv = err.apply(imu.dtheta_rad, imu.dvel_mps, dt, rng)
    gm_g = gm_a = np.zeros((len(dth), 3))
    if gm_gyro_dph > 0:
        gm_g = _gm(rng, len(dth), dt, gm_gyro_dph * np.pi / 180 / 3600, gm_tau_s)
        dth = dth + gm_g * dt
    if gm_accel_ug > 0:
        gm_a = _gm(rng, len(dv), dt, gm_accel_ug * 9.80665e-6, gm_tau_s)
        dv = dv + gm_a * dt
    # LDV: head fixed in the body along the stance travel direction, velocity component along its axis
    n_l = int(np.floor((m.t_end_s - sc.t0_s) * sc.ldv_rate_hz + 1e-9))
    t_l = sc.t0_s + np.arange(1, n_l + 1) / sc.ldv_rate_hz
    _, _, tr, c_bn, _, w_nb_b, _ = _rates(m, t_l, eta0, phi0, squat_rad_per_mps2)
    lever = np.asarray(sc.ldv.lever_arm_m, float)
    v_head = tr["v_n"] + np.einsum("kij,kj->ki", c_bn, np.cross(w_nb_b, lever))
    c_dn = c_bn @ c_db(eta0, phi0)
    v_d = np.einsum("kji,kj->ki", c_dn, v_head)
    vf = sc.ldv.scale * v_d[:, 1] + rng.normal(0, sc.ldv.noise_mps, n_l)
    vu = sc.ldv.scale_up * v_d[:, 2] + rng.normal(0, sc.ldv.noise_mps, n_l)
    quality = rng.integers(150, 400, n_l).astype(float)
    if bursts_per_min > 0:
        n_b = int(round(bursts_per_min * (t_l[-1] - t_l[0]) / 60.0))
        starts = rng.integers(0, n_l - 600, n_b)
        for i, s0 in enumerate(starts):
            ln = int(rng.uniform(0.1, 4.0) * sc.ldv_rate_hz)
            sl = slice(s0, s0 + ln)
            quality[sl] = rng.integers(0, 90, ln)
            kind = i % 3
            if kind == 0:
                vf[sl], vu[sl] = 0.0, 0.0
            elif kind == 1:
                vf[sl] += rng.normal(0, 5.0, ln)
                vu[sl] += rng.normal(0, 5.0, ln)
            else:
                vf[sl], vu[sl] = vf[s0 - 1], vu[s0 - 1]
    spikes = np.array([], int)
    if good_spikes:
        moving = np.flatnonzero(np.abs(vf) > 3.0)
        spikes = rng.choice(moving, good_spikes, replace=False)
        vf[spikes] += rng.choice([-5.0, 5.0], good_spikes)
    t_g = np.arange(np.ceil(sc.t0_s), np.floor(m.t_end_s) + 1e-9, 1.0)
    lat, lon, h, fix = gnss_fixes(m, t_g, sc.ldv.c_bt(), sc.gnss_lever_m, sc.fix_of_t, rng)
    sim = SimResult(sc, m, imu, err, dth, dv, t_l, vf, vu, quality, t_g, lat, lon, h, fix, None)
    sim.spikes = spikes
    sim.gyro_bias_rps = err.gyro_bias_rps + gm_g  # (N, 3) true total biases, sensor frame
    sim.accel_bias_mps2 = err.accel_bias_mps2 + gm_a
    return sim
