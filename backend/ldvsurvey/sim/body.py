"""Vehicle body attitude over the travel direction (the ``body_attitude`` effect).

Frames: t = travel frame (forward axis along the velocity, from :class:`Motion`);
d = vehicle body / LDV head frame (the LDV is fixed in the body and measures along its own
forward axis); b = IMU body, fixed to d by the LDV mounting C_d^b(η_L, φ_L).

Model (angles of d over t, the product's Euler convention: C_d^t = R_z(−y) R_x(p) R_y(r))::

    p(t) = p_stance + k_p · a_fwd/g + A_b (v/v_ref) sin(2π f_1 t + φ_1)      (squat/dive, bounce)
    r(t) = −k_r · a_lat/g + ½ A_b (v/v_ref) sin(2π f_2 t + φ_2)              (outward roll)
    y(t) = y_crab

a_fwd, a_lat: kinematic acceleration along the travel frame's forward and right axes (m/s²).
Realistic: p_stance, y_crab 0.1–0.5°; k_p, k_r 1–3°/g; bounce 0.02–0.05° at 1–2 Hz.
Rates: ω_td^d from the Euler-angle rates, which are central differences (h = 10⁻⁴ s) of the
analytic angles (truncation ~1e-9 rad/s, negligible against the sensors).

The LDV then sees the travel direction u_b = C_t^b e_fwd in body axes, whose pitch/heading in
the LDV mounting convention (:func:`travel_direction`) is what a calibration can estimate.
"""

from __future__ import annotations

import numpy as np

from ldvsurvey.nav.attitude import c_bn_from_euler
from ldvsurvey.nav.errmodel import c_db
from ldvsurvey.sim.effects import BodyAttitude
from ldvsurvey.sim.motion import euler_rate_to_body
from ldvsurvey.units import G0_MPS2 as G0  # noqa: E402

H_S = 1e-4


class BodyModel:
    """C_b^t(t) and ω_tb^b(t) of the IMU body with the body-attitude effect.

    Called by :func:`ldvsurvey.sim.imu.rates` as ``model(t, truth) -> (C_b^t, ω_tb^b)``.
    """

    def __init__(
        self, spec: BodyAttitude, motion, mount_pitch_rad: float, mount_heading_rad: float, rng: np.random.Generator
    ):
        self.spec = spec
        self.motion = motion
        self.c_db = c_db(mount_pitch_rad, mount_heading_rad)
        self.phase = rng.uniform(0.0, 2 * np.pi, 2)

    def angles(self, t, tr=None):
        """(p, r, y) of the body/LDV frame over the travel frame, rad, at times t."""
        sp = self.spec
        t = np.asarray(t, float)
        if tr is None:
            tr = self.motion.truth(t)
        a_t = np.einsum("kji,kj->ki", tr["c_tn"], tr["a_n"])  # C_n^t a_n
        v = tr["speed_mps"] / sp.bounce_ref_mps
        f1, f2 = sp.bounce_hz
        tau = t - self.motion.t0_s
        p = (
            sp.stance_pitch_rad
            + sp.squat_rad_per_g * a_t[:, 1] / G0
            + sp.bounce_rad * v * np.sin(2 * np.pi * f1 * tau + self.phase[0])
        )
        r = -sp.roll_rad_per_g * a_t[:, 0] / G0 + 0.5 * sp.bounce_rad * v * np.sin(2 * np.pi * f2 * tau + self.phase[1])
        y = np.full_like(p, sp.crab_rad)
        return p, r, y

    def c_dt(self, t, tr=None):
        """Attitude C_d^t of the vehicle body (LDV) frame d relative to the travel frame t at times ``t``.

        Parameters
        ----------
        t : (N,) array
            Times (s).
        tr : dict, optional
            ``Motion.truth(t)`` when already at hand (else computed).

        Returns
        -------
        (N, 3, 3) array
            C_d^t from the stance, squat, roll, bounce and crab angles (rad).
        """
        p, r, y = self.angles(t, tr)
        return c_bn_from_euler(p, r, y)

    def __call__(self, t, tr):
        t = np.asarray(t, float)
        lo = np.maximum(t - H_S, self.motion.t0_s)
        hi = np.minimum(t + H_S, self.motion.t_end_s)
        p, r, y = self.angles(t, tr)
        p1, r1, y1 = self.angles(hi)
        p0, r0, y0 = self.angles(lo)
        w = hi - lo
        w_td_d = euler_rate_to_body(p, r, y, (p1 - p0) / w, (r1 - r0) / w, (y1 - y0) / w)
        c_dt = c_bn_from_euler(p, r, y)
        c_bt = c_dt @ self.c_db.T  # C_b^t = C_d^t C_b^d
        w_tb_b = w_td_d @ self.c_db.T  # C_d^b ω (row-vector form)
        return c_bt, w_tb_b


def travel_direction(c_bt):
    """Pitch and heading (rad) of the travel direction in body axes, in the LDV mounting convention.

    u_b = C_t^b e_fwd (row 1 of C_b^t); η = asin(u_z), φ = atan2(−u_x, u_y), so that for a perfectly
    travelling LDV they equal the mounting angles of ``LdvSpecSim`` (forward column of C_d^b).
    """
    c_bt = np.asarray(c_bt, float)
    u = c_bt[..., 1, :]
    return np.arcsin(np.clip(u[..., 2], -1, 1)), np.arctan2(-u[..., 0], u[..., 1])
