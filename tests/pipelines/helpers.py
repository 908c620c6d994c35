"""Helpers of the pipeline tests."""

import numpy as np

from ldvsurvey.nav.earth import MGAL
from ldvsurvey.nav.gravity import Lowpass


def truth_height(sim, t_s):
    """The simulation's true ellipsoidal height (m) at times ``t_s`` (s), linearly interpolated."""
    return np.interp(t_s, sim.imu.t_s, sim.imu.h_m)


def truth_dg_error_mgal(sim, table, column="dg_mgal", fir_s=150.0):
    """A gravity table's ``column`` (mGal) on its survey lines less the simulation's true disturbance
    along the driven path, low-passed by the same zero-phase FIR of ``fir_s`` seconds (mGal); finite
    values only."""
    on = np.array([x != "" for x in table["line"]])
    im = sim.imu
    tm = 0.5 * (im.t_s[1:] + im.t_s[:-1])
    true = sim.scenario.gravity_field.dg_mgal(
        0.5 * (im.lat_rad[1:] + im.lat_rad[:-1]), 0.5 * (im.lon_rad[1:] + im.lon_rad[:-1])
    )
    rate_hz = 1.0 / float(np.median(np.diff(im.t_s)))
    tf = Lowpass(fir_s, rate_hz).apply(true * MGAL) / MGAL
    e = table[column][on] - np.interp(table["t_s"][on], tm, tf)
    return e[np.isfinite(e)]
