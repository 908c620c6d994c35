"""GNSS outages placed along a simulated INS/GNSS drive (no LDV): the position error against the
simulator's truth at the end of each outage, beside the filter's own 1-σ there. Shared by
``test_outages.py`` (short) and ``benchmarks/bench_outages.py`` (the figures of docs/accuracy.md)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ldvsurvey.io.drivelog import parse_files
from ldvsurvey.nav.earth import enu_offset_m
from ldvsurvey.pipelines.base import run_pipeline
from ldvsurvey.pipelines.registry import get
from ldvsurvey.sim import catalog
from ldvsurvey.sim.scenario import bundle_files, simulate

#: IMU grades (gyro bias °/h, accelerometer bias µg, ARW °/√h, VRW µg/√Hz): the product's
#: navigation-grade default and a tactical-grade MEMS unit as KF-GINS users record
GRADES = {
    "navigation": dict(gyro_bias_dph=0.003, accel_bias_ug=20.0, gyro_arw_dprh=0.0005, accel_vrw_ug_rthz=5.0),
    "tactical": dict(gyro_bias_dph=1.0, accel_bias_ug=250.0, gyro_arw_dprh=0.05, accel_vrw_ug_rthz=50.0),
}


@dataclass
class Outage:
    length_s: float
    t_start_s: float
    t_end_s: float
    horizontal_m: float  #: largest horizontal error against truth inside the outage
    vertical_m: float  #: largest |vertical error| inside the outage (signed)
    horizontal_sigma_m: float  #: the filter's own 1-σ where the horizontal error is largest: √(σ_E² + σ_N²)
    vertical_sigma_m: float  #: the filter's vertical 1-σ where the vertical error is largest


def outage_schedule(lengths_s, first_s: float, spacing_s: float) -> list[tuple[float, float, int]]:
    """``fix_schedule`` entries (seconds from the start) of no-fix windows: one per length, the
    next one ``spacing_s`` after the previous one ends (time for the filter to reconverge)."""
    out, t = [], first_s
    for length in lengths_s:
        out.append((t, t + length, 0))
        t += length + spacing_s
    return out


def run_outages(lengths_s, grade="navigation", smooth=False, seed=1, spacing_s=120.0):
    """Simulate a winding RTK drive without an LDV with outages of ``lengths_s`` seconds, run
    ``navigate`` (GNSS aiding, forward filter only unless ``smooth``) and measure each outage.

    Returns (outages, elapsed wall seconds of the navigate run, the scenario)."""
    import time

    sched = outage_schedule(lengths_s, 360.0, spacing_s)
    minutes = (sched[-1][1] + spacing_s) / 60.0 + 1.0
    sc = catalog.drive(minutes=minutes, fix_schedule=sched, with_ldv=False, **GRADES[grade])
    sim = simulate(sc, seed=seed)
    log = parse_files(bundle_files(sim))
    t0 = time.perf_counter()
    r = run_pipeline(get("navigate"), [log], {"smooth": smooth, "output_rate_hz": 100.0})
    elapsed = time.perf_counter() - t0
    tab = r.tables["trajectory"]
    t = np.asarray(tab["t_s"])
    im = sim.imu
    out = []
    for (a, b, _), length in zip(sched, lengths_s):
        ta, tb = sc.t0_s + a, sc.t0_s + b
        g = sim.gnss_t_s[(sim.gnss_fix == 0) & (sim.gnss_t_s >= ta) & (sim.gnss_t_s < tb)]
        k = np.flatnonzero((t > g[0] - 1.0) & (t <= g[-1]))  # from the last fix to the last epoch without one
        e = enu_offset_m(
            np.interp(t[k], im.t_s, im.lat_rad),
            np.interp(t[k], im.t_s, im.lon_rad),
            np.interp(t[k], im.t_s, im.h_m),
            np.radians(tab["lat_deg"][k]),
            np.radians(tab["lon_deg"][k]),
            np.asarray(tab["h_m"])[k],
        )
        hz = np.hypot(e[:, 0], e[:, 1])
        i, j = int(np.argmax(hz)), int(np.argmax(np.abs(e[:, 2])))
        out.append(
            Outage(
                float(length),
                float(ta),
                float(g[-1]),
                float(hz[i]),
                float(e[j, 2]),
                float(np.hypot(tab["e_sigma_m"][k[i]], tab["n_sigma_m"][k[i]])),
                float(tab["h_sigma_m"][k[j]]),
            )
        )
    return out, elapsed, sc
