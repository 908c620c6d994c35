"""Attitude: C_b^n ⇄ (pitch θ, roll γ, heading ψ) ⇄ quaternion, the spec's 3-1-2 convention.

With yaw y = −ψ, C_b^n = R_z(y) R_x(θ) R_y(γ) (columns are the body axes in ENU):
heading 90° puts the forward axis on East, pitch > 0 lifts it, roll > 0 lowers the right axis.
Quaternions are [w, x, y, z], Hamilton product, q ⊗ v ⊗ q* maps b to n.
The rotating IMU: C_b^s = R_y(β) R_x(α) R_z(η) with passive elementary rotations (spec eq. 12).
"""

from __future__ import annotations

import numba as nb
import numpy as np


def c_bn_from_euler(pitch_rad, roll_rad, heading_rad):
    """C_b^n (..., 3, 3) from pitch, roll, heading (rad), vectorized."""
    th, ga, y = np.broadcast_arrays(
        np.asarray(pitch_rad, float), np.asarray(roll_rad, float), -np.asarray(heading_rad, float)
    )
    cy, sy, ct, st, cg, sg = np.cos(y), np.sin(y), np.cos(th), np.sin(th), np.cos(ga), np.sin(ga)
    c = np.empty(th.shape + (3, 3))
    c[..., 0, 0] = cy * cg - sy * st * sg
    c[..., 0, 1] = -sy * ct
    c[..., 0, 2] = cy * sg + sy * st * cg
    c[..., 1, 0] = sy * cg + cy * st * sg
    c[..., 1, 1] = cy * ct
    c[..., 1, 2] = sy * sg - cy * st * cg
    c[..., 2, 0] = -ct * sg
    c[..., 2, 1] = st
    c[..., 2, 2] = ct * cg
    return c


def euler_from_c_bn(c_bn):
    """(pitch, roll, heading) in rad from C_b^n (..., 3, 3); heading in [0, 2π)."""
    c_bn = np.asarray(c_bn, float)
    pitch = np.arcsin(np.clip(c_bn[..., 2, 1], -1.0, 1.0))
    roll = np.arctan2(-c_bn[..., 2, 0], c_bn[..., 2, 2])
    yaw = np.arctan2(-c_bn[..., 0, 1], c_bn[..., 1, 1])
    return pitch, roll, np.mod(-yaw, 2 * np.pi)


def q_from_c(c):
    """Unit quaternion [w, x, y, z] from a rotation matrix (..., 3, 3) (Shepperd's method)."""
    c = np.asarray(c, float)
    shape = c.shape[:-2]
    c = c.reshape(-1, 3, 3)
    q = np.empty((len(c), 4))
    tr = c[:, 0, 0] + c[:, 1, 1] + c[:, 2, 2]
    cand = np.stack([tr, c[:, 0, 0], c[:, 1, 1], c[:, 2, 2]], axis=1)
    k = np.argmax(cand, axis=1)
    for i in range(4):
        m = k == i
        if not m.any():
            continue
        cc = c[m]
        if i == 0:
            r = np.sqrt(1 + tr[m])
            q[m] = np.stack(
                [
                    r / 2,
                    (cc[:, 2, 1] - cc[:, 1, 2]) / (2 * r),
                    (cc[:, 0, 2] - cc[:, 2, 0]) / (2 * r),
                    (cc[:, 1, 0] - cc[:, 0, 1]) / (2 * r),
                ],
                axis=1,
            )
        else:
            a, b_, c_ = i - 1, i % 3, (i + 1) % 3
            r = np.sqrt(1 + cc[:, a, a] - cc[:, b_, b_] - cc[:, c_, c_])
            v = np.empty((len(cc), 4))
            v[:, 0] = (cc[:, c_, b_] - cc[:, b_, c_]) / (2 * r)
            v[:, 1 + a] = r / 2
            v[:, 1 + b_] = (cc[:, b_, a] + cc[:, a, b_]) / (2 * r)
            v[:, 1 + c_] = (cc[:, c_, a] + cc[:, a, c_]) / (2 * r)
            q[m] = v
    q *= np.where(q[:, :1] < 0, -1.0, 1.0)
    return q.reshape(shape + (4,))


def c_from_q(q):
    """Rotation matrix (..., 3, 3) from quaternion(s) [w, x, y, z]."""
    q = np.asarray(q, float)
    q = q / np.linalg.norm(q, axis=-1, keepdims=True)
    w, x, y, z = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    c = np.empty(q.shape[:-1] + (3, 3))
    c[..., 0, 0] = 1 - 2 * (y * y + z * z)
    c[..., 0, 1] = 2 * (x * y - w * z)
    c[..., 0, 2] = 2 * (x * z + w * y)
    c[..., 1, 0] = 2 * (x * y + w * z)
    c[..., 1, 1] = 1 - 2 * (x * x + z * z)
    c[..., 1, 2] = 2 * (y * z - w * x)
    c[..., 2, 0] = 2 * (x * z - w * y)
    c[..., 2, 1] = 2 * (y * z + w * x)
    c[..., 2, 2] = 1 - 2 * (x * x + y * y)
    return c


def c_bs(eta_rad, alpha_rad=0.0, beta_rad=0.0):
    """C_b^s(η, α, β) = R_y(β) R_x(α) R_z(η), (..., 3, 3): body to rotating-IMU sensor frame."""
    e, a, b = np.broadcast_arrays(np.asarray(eta_rad, float), np.asarray(alpha_rad, float), np.asarray(beta_rad, float))
    ce, se, ca, sa, cb, sb = np.cos(e), np.sin(e), np.cos(a), np.sin(a), np.cos(b), np.sin(b)
    c = np.empty(e.shape + (3, 3))
    c[..., 0, 0] = ce * cb - se * sa * sb
    c[..., 0, 1] = se * cb + ce * sa * sb
    c[..., 0, 2] = -ca * sb
    c[..., 1, 0] = -se * ca
    c[..., 1, 1] = ce * ca
    c[..., 1, 2] = sa
    c[..., 2, 0] = ce * sb + se * sa * cb
    c[..., 2, 1] = se * sb - ce * sa * cb
    c[..., 2, 2] = ca * cb
    return c


def skew(v):
    """[v×] for v of shape (..., 3)."""
    v = np.asarray(v, float)
    z = np.zeros(v.shape[:-1])
    return np.stack(
        [
            np.stack([z, -v[..., 2], v[..., 1]], -1),
            np.stack([v[..., 2], z, -v[..., 0]], -1),
            np.stack([-v[..., 1], v[..., 0], z], -1),
        ],
        -2,
    )


def rotvec_to_c(phi):
    """Rotation matrix of rotation vector(s) (Rodrigues), (..., 3, 3)."""
    phi = np.asarray(phi, float)
    ang = np.linalg.norm(phi, axis=-1)[..., None, None]
    k = skew(phi)
    small = ang < 1e-8
    a = np.where(small, 1 - ang**2 / 6, np.sin(ang) / np.where(small, 1, ang))
    b = np.where(small, 0.5 - ang**2 / 24, (1 - np.cos(ang)) / np.where(small, 1, ang) ** 2)
    return np.eye(3) + a * k + b * (k @ k)


def c_to_rotvec(c):
    """Rotation vector(s) of rotation matrix(es) (..., 3, 3)."""
    q = q_from_c(c)
    v = q[..., 1:]
    s = np.linalg.norm(v, axis=-1)
    ang = 2 * np.arctan2(s, q[..., 0])
    f = np.where(s < 1e-12, 2.0, ang / np.where(s < 1e-12, 1.0, s))
    return v * f[..., None]


def attitude_error_rad(c_est, c_true):
    """Small-angle error φ (rad, ENU) with C_est = (I − [φ×]) C_true, i.e. φ = −rotvec(C_est C_trueᵀ)."""
    return -c_to_rotvec(np.einsum("...ij,...kj->...ik", c_est, c_true))


# ---- numba scalar helpers for the per-sample loops ----


@nb.njit(cache=True)
def qmul(p, q):
    """Hamilton product p ⊗ q."""
    return np.array(
        [
            p[0] * q[0] - p[1] * q[1] - p[2] * q[2] - p[3] * q[3],
            p[0] * q[1] + p[1] * q[0] + p[2] * q[3] - p[3] * q[2],
            p[0] * q[2] - p[1] * q[3] + p[2] * q[0] + p[3] * q[1],
            p[0] * q[3] + p[1] * q[2] - p[2] * q[1] + p[3] * q[0],
        ]
    )


@nb.njit(cache=True)
def q_rotvec(v):
    """Quaternion of rotation vector v (rad)."""
    a2 = v[0] * v[0] + v[1] * v[1] + v[2] * v[2]
    if a2 < 1e-16:
        s = 0.5 - a2 / 48.0
        c = 1.0 - a2 / 8.0
    else:
        a = np.sqrt(a2)
        s = np.sin(a / 2) / a
        c = np.cos(a / 2)
    return np.array([c, s * v[0], s * v[1], s * v[2]])


@nb.njit(cache=True)
def q_to_c(q):
    """C (3×3) of the unit quaternion q = [w, x, y, z] (:func:`q_to_c_into` into a new array)."""
    c = np.empty((3, 3))
    q_to_c_into(q, c)
    return c


@nb.njit(cache=True, inline="always")
def q_to_c_into(q, c):
    """C (3×3, written into ``c``) of the unit quaternion q = [w, x, y, z], without allocating."""
    w, x, y, z = q[0], q[1], q[2], q[3]
    c[0, 0] = 1 - 2 * (y * y + z * z)
    c[0, 1] = 2 * (x * y - w * z)
    c[0, 2] = 2 * (x * z + w * y)
    c[1, 0] = 2 * (x * y + w * z)
    c[1, 1] = 1 - 2 * (x * x + z * z)
    c[1, 2] = 2 * (y * z - w * x)
    c[2, 0] = 2 * (x * z - w * y)
    c[2, 1] = 2 * (y * z + w * x)
    c[2, 2] = 1 - 2 * (x * x + y * y)


@nb.njit(cache=True)
def cross(a, b):
    """a × b of two 3-vectors (units multiply), allocated."""
    return np.array([a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]])
