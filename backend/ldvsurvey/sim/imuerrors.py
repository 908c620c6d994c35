"""IMU errors real sensors have beyond constant bias and white noise (``imu_errors``, ``imu_timing``).

Sensor-frame model of each increment over (t_{k−1}, t_k] (applied before the turn-on bias and
white noise of :class:`~ldvsurvey.sim.sensors.ImuErrors`)::

    Δθ̃ = (I + S_g + N_g) Δθ + b_g,GM(t_k) Δt,    Δṽ = (I + S_a + N_a) Δv + b_a,GM(t_k) Δt

S = diag(scale factors), 10–300 ppm per axis; N = non-orthogonality (off-diagonal, tens of µrad);
b_GM a first-order Gauss–Markov bias instability per axis, b_k = φ b_{k−1} + σ√(1−φ²) w_k,
φ = exp(−Δt/τ), started from its stationary distribution, σ a share (~30 %) of the manifest's
bias, τ 10–60 min. The turn-on bias (constant for the run) stays the one of ``ImuErrors``.

Timing (``imu_timing``): dropped rows, ~0.2 events a minute of 1–5 consecutive rows (their
increments are lost: the next row still holds only its own interval); time-tag jitter of σ
~50 µs with a share 1e-4 of rows off by up to 2 ms (|jitter| < 0.4 Δt keeps the order), the
increments remaining those of the true intervals.
"""

from __future__ import annotations

import numpy as np
from scipy.signal import lfilter

from ldvsurvey.sim.effects import EngineVibration, ImuErrorSpec, ImuTiming
from ldvsurvey.units import G0_MPS2 as G0  # noqa: E402
from ldvsurvey.units import RAD_PER_DEG as DEG  # noqa: E402  (rad per degree)


def misalignment(scale_ppm, nonorth_urad) -> np.ndarray:
    """I + S + N from three scale factors (ppm) and six off-diagonal terms (µrad, row-major)."""
    m = np.eye(3) + np.diag(np.asarray(scale_ppm, float) * 1e-6)
    off = [(0, 1), (0, 2), (1, 0), (1, 2), (2, 0), (2, 1)]
    for (i, j), v in zip(off, nonorth_urad):
        m[i, j] = v * 1e-6
    return m


def gauss_markov(n: int, dt_s: float, sigma, tau_s: float, rng) -> np.ndarray:
    """Stationary first-order Gauss–Markov sequences.

    Parameters
    ----------
    n : int
        Samples.
    dt_s : float
        Sampling interval (s).
    sigma : sequence of float
        Stationary σ of each sequence (any unit).
    tau_s : float
        Correlation time (s).
    rng : numpy.random.Generator
        Noise generator.

    Returns
    -------
    (n, len(sigma)) array
        The sequences (the unit of ``sigma``).
    """
    sigma = np.atleast_1d(np.asarray(sigma, float))
    phi = np.exp(-dt_s / tau_s)
    out = np.empty((n, len(sigma)))
    for j, s in enumerate(sigma):
        w = rng.normal(0.0, s * np.sqrt(1 - phi**2), n)
        x0 = rng.normal(0.0, s)
        out[:, j] = lfilter([1.0], [1.0, -phi], w, zi=[phi * x0])[0]
    return out


def apply_imu_errors(
    dtheta, dvel, dt_s: float, spec: ImuErrorSpec, gyro_bias_dph: float, accel_bias_ug: float, rng
) -> tuple[np.ndarray, np.ndarray, dict]:
    """Increments with scale, non-orthogonality and bias instability; and their truth.

    Parameters
    ----------
    dtheta, dvel : (N, 3) arrays
        Ideal angle (rad) and velocity (m/s) increments.
    dt_s : float
        Sampling interval (s).
    spec : ImuErrorSpec
        Scale factors (ppm), non-orthogonality (µrad), instability fraction and correlation times (s).
    gyro_bias_dph, accel_bias_ug : float
        The IMU's bias grade (°/h, µg); the instability σ is ``spec``'s fraction of it.
    rng : numpy.random.Generator
        The effects' generator.

    Returns
    -------
    dtheta, dvel : (N, 3) arrays
        The increments with the errors (rad, m/s).
    truth : dict
        The matrices ``m_gyro``, ``m_accel``, the Gauss-Markov biases ``gyro_gm_rps`` (rad/s) and
        ``accel_gm_mps2`` (m/s²), their σ and correlation times (s).
    """
    n = len(dtheta)
    mg = misalignment(spec.gyro_scale_ppm, spec.gyro_nonorth_urad)
    ma = misalignment(spec.accel_scale_ppm, spec.accel_nonorth_urad)
    sg = spec.gyro_bi_frac * gyro_bias_dph * DEG / 3600.0
    sa = spec.accel_bi_frac * accel_bias_ug * 1e-6 * G0
    bg = gauss_markov(n, dt_s, [sg] * 3, spec.gyro_tau_s, rng)
    ba = gauss_markov(n, dt_s, [sa] * 3, spec.accel_tau_s, rng)
    dth = dtheta @ mg.T + bg * dt_s
    dv = dvel @ ma.T + ba * dt_s
    truth = dict(
        m_gyro=mg,
        m_accel=ma,
        gyro_gm_rps=bg,
        accel_gm_mps2=ba,
        gyro_gm_sigma_rps=sg,
        accel_gm_sigma_mps2=sa,
        gyro_tau_s=spec.gyro_tau_s,
        accel_tau_s=spec.accel_tau_s,
    )
    return dth, dv, truth


def timing(t_s: np.ndarray, dt_s: float, spec: ImuTiming, rng) -> tuple[np.ndarray, np.ndarray]:
    """Dropped rows and jittered time tags of a logger writing rows at true times ``t_s``.

    Parameters
    ----------
    t_s : (N,) array
        True sample times (s).
    dt_s : float
        Sampling interval (s).
    spec : ImuTiming
        Drops per minute, longest drop (rows), jitter σ (s) and share of large jitter.
    rng : numpy.random.Generator
        The effects' generator.

    Returns
    -------
    keep : (N,) bool array
        Rows written.
    t_written_s : (N,) array
        Written time tags (s), within ±0.4 ``dt_s`` of the truth.
    """
    n = len(t_s)
    keep = np.ones(n, bool)
    minutes = n * dt_s / 60.0
    n_ev = rng.poisson(spec.drops_per_min * minutes)
    for k in rng.integers(10, max(11, n - 10), n_ev):
        keep[k : k + int(rng.integers(1, spec.drop_max_rows + 1))] = False
    jit = rng.normal(0.0, spec.jitter_s, n)
    big = rng.random(n) < spec.big_jitter_share
    jit[big] = rng.uniform(-2e-3, 2e-3, big.sum())
    jit = np.clip(jit, -0.4 * dt_s, 0.4 * dt_s)
    return keep, t_s + jit


def engine_vibration(t_s: np.ndarray, dt_s: float, spec: EngineVibration, rng) -> tuple[np.ndarray, np.ndarray]:
    """Angle and velocity increments an idling (or running) engine adds to the sensor's.

    Each line a·sin(2πf t + φ) (φ drawn per axis and line) enters as its exact integral over the
    increment's interval, a/(2πf)·[cos(2πf t_{k−1} + φ) − cos(2πf t_k + φ)]: a shake that moves the
    vehicle nowhere. Broadband noise adds σ·Δt per sample.

    Parameters
    ----------
    t_s : (N,) array
        Sample times (s), each the end of its interval.
    dt_s : float
        Sampling interval (s).
    spec : EngineVibration
        Frequencies (Hz), amplitudes (m/s², °/s), axis shares and broadband σ.
    rng : numpy.random.Generator
        The effects' generator.

    Returns
    -------
    dtheta_rad, dvel_mps : (N, 3) arrays
        The increments to add (rad, m/s).
    """
    t = np.asarray(t_s, float)
    n = len(t)
    share = np.asarray(spec.axis_share, float)
    dth = np.zeros((n, 3))
    dv = np.zeros((n, 3))
    for f, a, w in zip(spec.freq_hz, spec.accel_mps2, spec.rate_dps):
        om = 2 * np.pi * f
        for out, amp in ((dv, a), (dth, w * DEG)):
            ph = rng.uniform(0, 2 * np.pi, 3)
            arg1 = om * t[:, None] + ph
            arg0 = arg1 - om * dt_s
            out += amp * share / om * (np.cos(arg0) - np.cos(arg1))
    dv += rng.normal(0.0, spec.accel_noise_mps2 * dt_s, (n, 3)) * share
    dth += rng.normal(0.0, spec.rate_noise_dps * DEG * dt_s, (n, 3)) * share
    return dth, dv
