"""Coarse alignment (levelling + gyrocompassing) from a static period.

Fine alignment is the zero-velocity Kalman filter: :func:`ldvsurvey.nav.filter.run_filter`
with ``zupt_intervals`` covering the static period.
"""

from __future__ import annotations

import numpy as np

from ldvsurvey.nav.earth import OMEGA_IE


def _triad(a, b):
    e1 = a / np.linalg.norm(a)
    e2 = np.cross(a, b)
    e2 /= np.linalg.norm(e2)
    return np.column_stack([e1, e2, np.cross(e1, e2)])


def coarse_align(dtheta_rad, dvel_mps, lat_rad: float, c_bs=None, turntable_rad=None):
    """C_b^n from the mean specific force and angular rate of a static stretch.

    Parameters
    ----------
    dtheta_rad, dvel_mps : (K, 3) increments of the static stretch in the sensor frame.
    lat_rad : latitude.
    c_bs : optional (K, 3, 3) C_b^s per sample (rotating IMU): increments are taken to b first.
    turntable_rad : optional (K,) encoder angle; its change is removed from the b-frame rate.

    Returns
    -------
    c_bn : (3, 3) body attitude C_b^n. With s = b this is C_s^n.
    """
    dth = np.asarray(dtheta_rad, float)
    dv = np.asarray(dvel_mps, float)
    if c_bs is not None:  # C_s^b = (C_b^s)ᵀ
        dth = np.einsum("kji,kj->ki", c_bs, dth)
        dv = np.einsum("kji,kj->ki", c_bs, dv)
        if turntable_rad is not None:
            deta = np.diff(np.unwrap(turntable_rad), prepend=turntable_rad[0])
            dth[:, 2] -= deta
    f_b = dv.sum(axis=0)
    w_b = dth.sum(axis=0)
    f_n = np.array([0.0, 0.0, 1.0])
    w_n = np.array([0.0, OMEGA_IE * np.cos(lat_rad), OMEGA_IE * np.sin(lat_rad)])
    return _triad(f_n, w_n) @ _triad(f_b, w_b).T
