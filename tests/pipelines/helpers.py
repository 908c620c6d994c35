"""Helpers of the pipeline tests."""

import numpy as np


def truth_height(sim, t_s):
    """The simulation's true ellipsoidal height (m) at times ``t_s`` (s), linearly interpolated."""
    return np.interp(t_s, sim.imu.t_s, sim.imu.h_m)
