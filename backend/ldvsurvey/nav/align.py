"""Coarse alignment (levelling + gyrocompassing) from a static period.

Fine alignment is the zero-velocity Kalman filter: :func:`ldvsurvey.nav.filter.run_filter`
with ``zupt_intervals`` covering the static period.
"""

from __future__ import annotations

import numpy as np

from ldvsurvey.nav.earth import OMEGA_IE


def _triad(a, b):
    """Orthonormal frame (3, 3) whose first axis is ``a`` and second is normal to ``a`` and ``b``.

    When ``b`` is zero or along ``a`` (gyros that read nothing at rest; the Earth rate at a pole) it
    gives no second direction: the second axis is then normal to ``a`` and to the coordinate axis
    least aligned with it, so the first axis (the level) stays right and the rest is arbitrary."""
    e1 = a / np.linalg.norm(a)
    e2 = np.cross(a, b)
    n2 = float(np.linalg.norm(e2))
    if not n2 > 1e-12 * float(np.linalg.norm(a) * np.linalg.norm(b)):
        e2 = np.cross(e1, np.eye(3)[int(np.argmin(np.abs(e1)))])
        n2 = float(np.linalg.norm(e2))
    e2 = e2 / n2
    return np.column_stack([e1, e2, np.cross(e1, e2)])


def _increments_in_body(dtheta_rad, dvel_mps, c_bs, turntable_rad):
    """(K, 3) increments taken from s to b (C_s^b = (C_b^s)ᵀ), the turntable's own turn removed from the rate."""
    dth = np.asarray(dtheta_rad, float)
    dv = np.asarray(dvel_mps, float)
    if c_bs is not None:
        dth = np.einsum("kji,kj->ki", c_bs, dth)
        dv = np.einsum("kji,kj->ki", c_bs, dv)
        if turntable_rad is not None:
            dth[:, 2] -= np.diff(np.unwrap(turntable_rad), prepend=turntable_rad[0])
    return dth, dv


def coarse_align(dtheta_rad, dvel_mps, lat_rad: float, c_bs=None, turntable_rad=None):
    """C_b^n from the mean specific force and angular rate of a static stretch.

    Parameters
    ----------
    dtheta_rad : (K, 3) array
        Angle increments of the static stretch in the sensor frame (rad).
    dvel_mps : (K, 3) array
        Velocity increments of the static stretch in the sensor frame (m/s).
    lat_rad : float
        Latitude (rad).
    c_bs : (K, 3, 3) array, optional
        C_b^s per sample (rotating IMU): the increments are taken to b first.
    turntable_rad : (K,) array, optional
        Encoder angle (rad); its change is removed from the b-frame rate.

    Returns
    -------
    c_bn : (3, 3) array
        Body attitude C_b^n. With s = b this is C_s^n. Levelled by the specific force alone; a rate
        with no part normal to it (gyros reading zero at rest, a pole) leaves the heading arbitrary
        (0 for a body close to level): whether the gyros found north is for the caller to judge.
    """
    dth, dv = _increments_in_body(dtheta_rad, dvel_mps, c_bs, turntable_rad)
    f_b = dv.sum(axis=0)
    w_b = dth.sum(axis=0)
    f_n = np.array([0.0, 0.0, 1.0])
    w_n = np.array([0.0, OMEGA_IE * np.cos(lat_rad), OMEGA_IE * np.sin(lat_rad)])
    return _triad(f_n, w_n) @ _triad(f_b, w_b).T


def align_in_motion(
    dtheta_rad,
    dvel_mps,
    duration_s: float,
    *,
    v_fwd_mps: float,
    a_fwd_mps2: float,
    course_rad: float,
    c_db_mount,
    c_bs=None,
    turntable_rad=None,
):
    """Coarse C_b^n of a vehicle already moving, from a short stretch (about a second).

    The level comes from the mean specific force with the vehicle's own acceleration removed:
    f^b = a^b − g^b, with a^b = C_d^b [0, v̇, 0] + ω_ib^b × v^b and v^b = C_d^b [0, v, 0] (the LDV
    speed and its rate along the travel axis d, which the LDV mounting C_d^b ties to the body).
    The heading turns the body's travel direction onto the course over ground (from GNSS).
    Neglected: the Coriolis and transport terms (2 ω_ie v ≈ 2e-3 m/s² at 15 m/s, a level error
    ≈ 2e-4 rad) and side-slip: the fine alignment is the filter's.

    Parameters
    ----------
    dtheta_rad : (K, 3) array
        Angle increments of the stretch in the sensor frame (rad).
    dvel_mps : (K, 3) array
        Velocity increments of the stretch in the sensor frame (m/s).
    duration_s : float
        Length of the stretch (s).
    v_fwd_mps : float
        Mean travel speed over the stretch (m/s).
    a_fwd_mps2 : float
        Rate of the travel speed (m/s²).
    course_rad : float
        Course over ground (rad, clockwise from north).
    c_db_mount : (3, 3) array
        LDV mounting C_d^b.
    c_bs : (K, 3, 3) array, optional
        C_b^s per sample (rotating IMU), as in :func:`coarse_align`.
    turntable_rad : (K,) array, optional
        Encoder angle (rad), as in :func:`coarse_align`.

    Returns
    -------
    c_bn : (3, 3) array
        Body attitude C_b^n.
    """
    from ldvsurvey.nav.attitude import c_bn_from_euler

    dth, dv = _increments_in_body(dtheta_rad, dvel_mps, c_bs, turntable_rad)
    f_b = dv.sum(axis=0) / duration_s
    w_b = dth.sum(axis=0) / duration_s
    fwd_b = c_db_mount @ np.array([0.0, 1.0, 0.0])
    a_b = a_fwd_mps2 * fwd_b + np.cross(w_b, v_fwd_mps * fwd_b)
    up_b = f_b - a_b
    up_b /= np.linalg.norm(up_b)
    pitch = np.arcsin(np.clip(up_b[1], -1.0, 1.0))
    roll = np.arctan2(-up_b[0], up_b[2])
    v_n0 = c_bn_from_euler(pitch, roll, 0.0) @ fwd_b
    heading = course_rad - np.arctan2(v_n0[0], v_n0[1])
    return c_bn_from_euler(pitch, roll, heading)


def standstill_rates(dtheta_rad, dvel_mps, dt_s: float, block_s: float = 1.0):
    """Mean turn rate and specific force of a standstill with the σ of those means from the data.

    The σ come from the scatter of ``block_s`` block means (an idling engine's vibration and the
    sensor noise alike average out over a block; what is left between blocks is what the whole
    mean keeps, divided by √(number of blocks)).

    Parameters
    ----------
    dtheta_rad, dvel_mps : (K, 3) arrays
        Angle (rad) and velocity (m/s) increments of the standstill, body frame.
    dt_s : float
        Sampling interval (s).
    block_s : float
        Block length (s).

    Returns
    -------
    w_mean_rps, w_sigma_rps : (3,) arrays
        Mean angular rate (rad/s) and the 1-σ of that mean (rad/s).
    f_mean_mps2 : (3,) array
        Mean specific force (m/s²).
    w_sample_rps : (3,) array
        Per-sample σ of the rate (rad/s): vibration and noise as the gyro saw them.
    """
    dth = np.asarray(dtheta_rad, float)
    dv = np.asarray(dvel_mps, float)
    k = len(dth)
    span = k * dt_s
    w_mean = dth.sum(axis=0) / span
    f_mean = dv.sum(axis=0) / span
    n_b = max(1, int(round(block_s / dt_s)))
    nb = k // n_b
    w_sample = np.std(dth / dt_s, axis=0)
    if nb >= 3:
        blocks = dth[: nb * n_b].reshape(nb, n_b, 3).sum(axis=1) / (n_b * dt_s)
        w_sigma = np.std(blocks, axis=0, ddof=1) / np.sqrt(nb)
    else:
        w_sigma = w_sample / np.sqrt(max(k, 1))
    return w_mean, w_sigma, f_mean, w_sample


def earth_rate_in_body(c_bn, lat_rad: float) -> np.ndarray:
    """ω_ie^b = (C_b^n)ᵀ ω_ie^n (rad/s) with ω_ie^n = [0, ω cos L, ω sin L] (ENU)."""
    w_n = np.array([0.0, OMEGA_IE * np.cos(lat_rad), OMEGA_IE * np.sin(lat_rad)])
    return np.asarray(c_bn, float).T @ w_n


def gyrocompass_sigma(lat_rad: float, bias_sigma_rps: float, mean_sigma_rps: float) -> float:
    """1-σ (rad) of a gyrocompassed heading: σ_ψ = √(σ_b² + σ_mean²) / (ω_ie cos L).

    The horizontal Earth rate ω_ie cos L (≈ 15 °/h · cos L) is all the gyros have to find north
    with; a bias of the horizontal gyros (``bias_sigma_rps``) is read as that rate turned, and so
    is the noise left in the standstill's mean (``mean_sigma_rps``). Returns π when the error is
    as large as the signal (north not found at all).
    """
    h = OMEGA_IE * abs(np.cos(lat_rad))
    s = float(np.hypot(bias_sigma_rps, mean_sigma_rps))
    return float(np.pi) if s >= h else float(min(np.pi, np.arcsin(s / h)))
