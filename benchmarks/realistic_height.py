"""Accuracy figures of calibrate and height on the simulator's ``realistic_height`` drive.

Prints figures against the simulator's truth (calibration vs the mean effective travel direction
over the calibration's span, height vs the true height, and vs fix-4 GNSS); asserts nothing.
The DOV grids written beside the bundle (truth.grid_files) are used with dov=grid.

Run: PYTHONPATH=backend .venv/bin/python benchmarks/realistic_height.py [seed] [minutes] [effects-json]
e.g. ``1 40 '{"turntable": false, "imu_timing": false}'`` switches those effects off.
"""

import json
import pathlib
import sys
import tempfile
import time

import numpy as np

from ldvsurvey.io.drivelog import parse_files
from ldvsurvey.pipelines.base import run_pipeline
from ldvsurvey.pipelines.registry import get
from ldvsurvey.sim import catalog
from ldvsurvey.sim import truth as TR
from ldvsurvey.sim.scenario import bundle_files, simulate

A = np.pi / 180 / 3600


def main(seed=1, minutes=40.0, over=None):
    kw = {} if minutes == 40 else dict(length_m=10000.0 * minutes / 40, relief_m=35.0 * minutes / 40)
    sc = catalog.realistic_height(seed=seed, minutes=minutes, **kw, **(over or {}))
    sim = simulate(sc)
    d = pathlib.Path(tempfile.mkdtemp())
    grids = TR.grid_files(sim)
    params = {"dov": "none"}
    if grids:
        for n, b in grids.items():
            (d / n).write_bytes(b)
        params = {"dov": "grid", "dov_grid": f"{d / 'xi.gdf'},{d / 'eta.gdf'},{d / 'dg.gdf'}"}
    log = parse_files(bundle_files(sim))
    for name in ("calibrate", "height"):
        t0 = time.perf_counter()
        try:
            r = run_pipeline(get(name), [log], params)
        except Exception as e:  # noqa: BLE001 - a benchmark reports what failed
            print(f"{name}: FAILED {type(e).__name__}: {e}")
            continue
        s = r.summary
        print(f"{name}: {time.perf_counter() - t0:.1f} s, warnings {r.warnings}")
        if name == "calibrate":
            a, b = s["segment_t_s"]
            mt = TR.mean_travel_direction(sim, a, b)
            ep = np.radians(s["ldv_pitch_deg"]) - mt["pitch_rad"]
            eh = np.radians(s["ldv_heading_deg"]) - mt["heading_rad"]
            # the LDV measures along its head axis: the speed it reports is K·cos δ, δ the angle between
            # the head axis and the travel direction (stance, squat, bounce), speed-weighted over the span
            t = np.arange(a, b, 0.1)
            tr = sim.motion.truth(t)
            p, hd = TR.effective_travel_direction(sim, t)
            u = np.column_stack([-np.sin(hd) * np.cos(p), np.cos(hd) * np.cos(p), np.sin(p)])
            from ldvsurvey.nav.errmodel import c_db

            cosd = u @ c_db(sc.ldv.pitch_rad, sc.ldv.heading_rad)[:, 1]
            k_eff = sc.ldv.scale * np.sum(cosd * tr["speed_mps"]) / np.sum(tr["speed_mps"])
            print(
                f"  effective scale K·cos δ = {k_eff:.7f} (K = {sc.ldv.scale:.7f}): "
                f"scale error vs effective {s['ldv_scale'] - k_eff:+.2e}"
            )
            print(
                f"  pitch error {ep / A:+.2f}″ (1-σ {np.radians(s['ldv_pitch_deg_sigma']) / A:.2f}″), "
                f"heading error {eh / A:+.2f}″ (1-σ {np.radians(s['ldv_heading_deg_sigma']) / A:.2f}″), "
                f"scale error {s['ldv_scale'] - sc.ldv.scale:+.2e} (1-σ {s['ldv_scale_sigma']:.2e}), "
                f"compliance {s['ldv_pitch_k_rad_per_mps2']} ± {s['ldv_pitch_k_rad_per_mps2_sigma']} rad/(m/s²)"
            )
        else:
            h = r.tables["height"]
            e = h["h_m"] - np.interp(h["t_s"], sim.imu.t_s, sim.imu.h_m)
            print(
                f"  height vs truth: std {np.std(e):.3f} m, max {np.abs(e).max():.3f} m; vs fix-4 GNSS: std "
                f"{s.get('std_error_m_fix4')} m, max {s.get('max_error_m_fix4')} m (n={s.get('n_reference_fix4')})"
            )


if __name__ == "__main__":
    a = sys.argv[1:]
    main(int(a[0]) if a else 1, float(a[1]) if len(a) > 1 else 40.0, json.loads(a[2]) if len(a) > 2 else None)
