"""Benchmark (issue 29): gravity from a sloppy logger on the independent six-line drive.

The six repeated 11-km lines of ``catalog.realistic_gravity`` (seed 1, 5 µg/√Hz accelerometer, FIR
200 s), written by a perfect logger and by one whose IMU time tags jitter (σ 0.3 ms, a 1e-4 share up
to 2 ms) and which loses a run of 1-5 rows a minute: each defect alone, both, and both with a
drifting accelerometer (the simulator's in-run IMU errors) beside the same drifting drive from a
perfect logger. Prints per case the coincidence beside the printed floors, the stop tie (range
and the largest |drift|/σ over the stops) and per line the bridged IMU time and its estimated cost;
ends with a markdown table for ``docs/accuracy.md``. Asserts nothing; not in the suite (~10 min).

Run: PYTHONPATH=backend .venv/bin/python benchmarks/bench_gravity_logger.py [--fir 200] [--seed 1]
"""

from __future__ import annotations

import argparse
import time

from ldvsurvey.io.drivelog import parse_files
from ldvsurvey.pipelines.base import run_pipeline
from ldvsurvey.pipelines.registry import get
from ldvsurvey.sim import catalog
from ldvsurvey.sim.effects import Effects, ImuTiming
from ldvsurvey.sim.scenario import bundle_files, simulate

JITTER = ImuTiming(drops_per_min=0.0, jitter_s=3e-4)
LOST = ImuTiming(drops_per_min=1.0, drop_max_rows=5, jitter_s=0.0, big_jitter_share=0.0)
BOTH = ImuTiming(drops_per_min=1.0, drop_max_rows=5, jitter_s=3e-4)


def cases(seed):
    drift = Effects.realistic(seed).imu_errors
    base = Effects.ideal()
    return [
        ("perfect logger", base),
        ("jitter alone", base.with_(imu_timing=JITTER)),
        ("lost rows alone", base.with_(imu_timing=LOST)),
        ("jitter + lost rows", base.with_(imu_timing=BOTH)),
        ("drifting accelerometer, perfect logger", base.with_(imu_errors=drift)),
        ("drifting accelerometer, jitter + lost rows", base.with_(imu_errors=drift, imu_timing=BOTH)),
    ]


def run_case(seed, effects, fir_s):
    sim = simulate(catalog.realistic_gravity(seed=seed, effects=effects))
    log = parse_files(bundle_files(sim))
    r = run_pipeline(get("gravity"), [log], {"fir_length_s": fir_s, "gnss_comparison": False})
    s = r.summary
    nf, dc = s["noise_floor"], s["drift_correction"]
    return {
        "coincidence_mgal": s["total_mgal"],
        "white_mgal": nf["total_mgal"],
        "drift_floor_mgal": nf.get("drift_mgal"),
        "bridge_mgal": nf.get("imu_bridge_mgal"),
        "combined_mgal": nf.get("combined_mgal"),
        "tie": dc.get("method"),
        "tie_range_mgal": dc.get("drift_range_mgal"),
        "tie_max_sigmas": dc.get("max_drift_sigmas"),
        "tie_end_mgal": dc["stops"][-1]["drift_mgal"] if dc.get("stops") else None,
        "tie_end_sigma_mgal": dc["stops"][-1]["drift_sigma_mgal"] if dc.get("stops") else None,
        "lost_gaps": s["imu_gaps"]["lost_gaps"],
        "lost_rows": s["imu_gaps"]["lost_rows"],
        "lines": [(ln["name"], ln.get("imu_bridged_s", 0.0), ln.get("imu_bridge_cost_mgal")) for ln in s["lines"]],
    }


def _f(x, fmt=".3f"):
    return "–" if x is None else format(x, fmt)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--fir", type=float, default=200.0)
    ap.add_argument("--seed", type=int, default=1)
    a = ap.parse_args()
    rows = []
    for name, eff in cases(a.seed):
        t0 = time.time()
        f = run_case(a.seed, eff, a.fir)
        rows.append((name, f))
        print(f"{name}: {f} ({time.time() - t0:.0f} s)", flush=True)
    print()
    print(
        "| logger | coincidence (mGal) | white floor | lost-row term | combined floor | ratio | stop tie: "
        "range (mGal), largest drift/σ | lost runs / rows | bridged per line (s) | its cost per line (mGal) |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|")
    for name, f in rows:
        ratio = f["coincidence_mgal"] / f["combined_mgal"] if f["combined_mgal"] else None
        tie = f"{f['tie']}: {_f(f['tie_range_mgal'], '.2f')}, {_f(f['tie_max_sigmas'], '.1f')}"
        print(
            f"| {name} | {_f(f['coincidence_mgal'])} | {_f(f['white_mgal'])} | {_f(f['bridge_mgal'])} | "
            f"{_f(f['combined_mgal'])} | {_f(ratio, '.2f')} | {tie} | {f['lost_gaps']} / {f['lost_rows']} | "
            + ", ".join(f"{b:.2f}" for _, b, _ in f["lines"])
            + " | "
            + ", ".join(_f(c) for _, _, c in f["lines"])
            + " |"
        )


if __name__ == "__main__":
    main()
