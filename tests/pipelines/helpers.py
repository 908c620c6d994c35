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


def files_from(sim, t_cut_s: float) -> tuple[dict, int]:
    """The bundle files of a simulated drive cut at ``t_cut_s`` (s): IMU, LDV (where simulated) and the
    GNSS fixes (GGA with the scenario's geoid separation) after it, the manifest's ``initial`` emptied
    (the log must find its own start). Returns the files and the index of the first IMU sample kept."""
    import json

    from ldvsurvey.io.writers import imu_csv, ldv_csv, nmea_text
    from ldvsurvey.sim.scenario import GEOID_SEPARATION_M, bundle_files

    f = bundle_files(sim)
    ki, kg = sim.imu.t_s > t_cut_s, sim.gnss_t_s > t_cut_s
    f["imu.csv"] = imu_csv(sim.imu.t_s[ki], sim.dtheta_rad[ki], sim.dvel_mps[ki])
    if "ldv.csv" in f:
        kl = sim.ldv_t_s > t_cut_s
        f["ldv.csv"] = ldv_csv(
            sim.ldv_t_s[kl], v_fwd_mps=sim.ldv_v_fwd[kl], v_up_mps=sim.ldv_v_up[kl], quality=sim.ldv_quality[kl]
        )
    f["gnss.nmea"] = nmea_text(
        sim.gnss_t_s[kg],
        sim.gnss_lat_deg[kg],
        sim.gnss_lon_deg[kg],
        sim.gnss_h_m[kg],
        sim.gnss_fix[kg],
        sep_m=GEOID_SEPARATION_M,
        talker="GN",
    )
    m = json.loads(f["manifest.json"])
    m["initial"] = {}
    f["manifest.json"] = json.dumps(m).encode()
    return f, int(np.flatnonzero(ki)[0])
