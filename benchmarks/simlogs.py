"""Simulated logs of a given length for the benchmarks, made once and kept in ``benchmarks/.logs/``.

The product's own simulator (the gravimetry survey: repeated 11-km lines with relief, fixed IMU,
2-D LDV, GNSS partly degraded) with as many lines as fill the wanted hours, at the wanted IMU rate.
Not part of the test suite. Run alone: ``python benchmarks/simlogs.py HOURS [RATE_HZ]``.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
CACHE = HERE / ".logs"
LINE_S = 11000.0 / 15.0 + 70.0  # one line at 15 m/s plus the turn at its end (catalog.gravity)


def bundle_path(hours: float, rate_hz: float = 100.0) -> Path:
    """The bundle zip of a ``hours``-long simulated survey at ``rate_hz`` (made on first use)."""
    path = CACHE / f"survey-{hours:g}h-{rate_hz:g}hz.zip"
    if path.exists():
        return path
    from ldvsurvey.io.writers import write_bundle
    from ldvsurvey.sim import catalog
    from ldvsurvey.sim.scenario import bundle_files, simulate

    n_lines = max(1, round((hours * 3600.0 - 300.0) / LINE_S))
    t0 = time.perf_counter()
    sc = catalog.gravity(n_lines=n_lines, imu_rate_hz=rate_hz)
    files = bundle_files(simulate(sc, seed=1))
    CACHE.mkdir(exist_ok=True)
    tmp = path.with_suffix(".tmp.zip")
    write_bundle(files, tmp)
    tmp.rename(path)
    print(f"simulated {path.name} ({n_lines} lines) in {time.perf_counter() - t0:.0f} s", file=sys.stderr)
    return path


if __name__ == "__main__":
    print(bundle_path(float(sys.argv[1]), float(sys.argv[2]) if len(sys.argv) > 2 else 100.0))
