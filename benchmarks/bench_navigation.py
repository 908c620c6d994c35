"""Benchmark: one hour at 100 Hz, forward filter + RTS smoother, LDV at 100 Hz, GNSS at 1 Hz.

Also times the simulator and the bare mechanization. Prints figures; asserts nothing.
Run: .venv/bin/python benchmarks/bench_navigation.py
"""

import statistics
import time

import numpy as np

from ldvsurvey.nav.align import coarse_align
from ldvsurvey.nav.attitude import q_from_c
from ldvsurvey.nav.filter import FilterConfig, GnssAid, ImuData, ImuNoise, LdvAid, NavStart, run_filter
from ldvsurvey.nav.mech import mechanize
from ldvsurvey.sim import catalog
from ldvsurvey.sim.scenario import simulate
from ldvsurvey.sim.sensors import FIX_SIGMA

RAD = np.pi / 180


def timed(fn, repeats=3):
    out = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        out.append(time.perf_counter() - t0)
    return statistics.median(out), min(out), max(out)


def main():
    t0 = time.perf_counter()
    sc = catalog.drive(minutes=60)
    sim = simulate(sc, seed=1)
    print(f"simulate one hour (IMU 100 Hz, LDV 100 Hz, GNSS 1 Hz): {time.perf_counter() - t0:.2f} s")
    imu = sim.imu
    n = len(imu.t_s)
    c0 = coarse_align(sim.dtheta_rad[:30000], sim.dvel_mps[:30000], sc.road.lat0_rad)
    pos0 = np.array([sc.road.lat0_rad, sc.road.lon0_rad, sc.road.h0_m])
    sig = np.array([FIX_SIGMA.get(int(f), (np.nan, np.nan)) for f in sim.gnss_fix])
    gnss = GnssAid(
        sim.gnss_t_s,
        sim.gnss_lat_deg * RAD,
        sim.gnss_lon_deg * RAD,
        sim.gnss_h_m,
        sig[:, 0],
        sig[:, 1],
        sc.gnss_lever_m,
    )
    ldv = LdvAid(sim.ldv_quality >= 100, sim.ldv_v_fwd, sim.ldv_v_up, lever_arm_m=sc.ldv.lever_arm_m)
    noise = ImuNoise(0.003, 20, 0.0005, 5)
    for aug in ((), ("scale", "pitch", "heading")):
        cfg = FilterConfig(ldv_aug=aug)

        def run(smooth, cfg=cfg):
            return run_filter(
                ImuData(imu.t_s, sim.dtheta_rad, sim.dvel_mps),
                NavStart(q_from_c(c0), np.zeros(3), pos0),
                noise,
                cfg,
                zupt_intervals=[(sc.t0_s, sc.t0_s + 300)],
                ldv=ldv,
                gnss=gnss,
                smooth=smooth,
            )

        run(True)  # compile (cached on disk after the first run)
        med, lo, hi = timed(lambda: run(False))
        print(
            f"{15 + len(aug)} states, forward filter only, {n} samples: median {med:.2f} s (min {lo:.2f}, max {hi:.2f})"
        )
        med, lo, hi = timed(lambda: run(True))
        print(f"{15 + len(aug)} states, forward + RTS smoother: median {med:.2f} s (min {lo:.2f}, max {hi:.2f})")
    med, lo, hi = timed(lambda: mechanize(imu.t_s, sim.dtheta_rad, sim.dvel_mps, q_from_c(c0), np.zeros(3), pos0))
    print(f"bare mechanization: median {med:.3f} s")


if __name__ == "__main__":
    main()
