"""Benchmark: each pipeline end to end on a simulated one-hour 100 Hz log (parsing excluded).

Prints figures; asserts nothing. Run: .venv/bin/python benchmarks/bench_pipelines.py [pipeline ...]
"""

import statistics
import sys
import time

from ldvsurvey.io.drivelog import parse_files
from ldvsurvey.pipelines.base import run_pipeline
from ldvsurvey.pipelines.registry import PIPELINES
from ldvsurvey.sim import catalog
from ldvsurvey.sim.scenario import bundle_files, simulate


def logs_for(name):
    if name in ("tilt", "height", "calibrate"):
        sc = catalog.height(minutes=60.0, length_m=15000.0)
    elif name in ("gravity", "navigate"):
        sc = catalog.gravity(n_lines=4)  # four 11-km lines: about one hour
    else:
        raise SystemExit(f"no benchmark log for {name}")
    t0 = time.perf_counter()
    log = parse_files(bundle_files(simulate(sc, seed=1)))
    print(
        f"  (simulated and parsed the one-hour log in {time.perf_counter() - t0:.1f} s, {len(log.imu.t_s)} IMU samples)"
    )
    return [log]


def main(names):
    cache = {}
    for name in names:
        key = "height" if name in ("tilt", "height", "calibrate") else "gravity"
        if key not in cache:
            cache[key] = logs_for(name)
        logs = cache[key]
        run_pipeline(PIPELINES[name], logs, {})  # warm-up: numba compile (cached on disk afterwards)
        times = []
        for _ in range(3):
            t0 = time.perf_counter()
            run_pipeline(PIPELINES[name], logs, {})
            times.append(time.perf_counter() - t0)
        print(
            f"{name}: median {statistics.median(times):.2f} s (min {min(times):.2f}, max {max(times):.2f}) "
            f"for one hour at 100 Hz"
        )


if __name__ == "__main__":
    main(sys.argv[1:] or ["tilt", "calibrate", "height", "navigate", "gravity"])
