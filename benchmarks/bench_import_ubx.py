"""Benchmark: reading a u-blox log (ESF-RAW at 100 Hz in messages of ten samples, NAV-PVT at 1 Hz).

The stream is the import tests' simulated receiver (sensor time tags at 25.6 kHz, as a NEO-M8U).
Prints CPU seconds per role and per hour of log; asserts nothing.
Run: PYTHONPATH=backend .venv/bin/python benchmarks/bench_import_ubx.py [minutes]
"""

import datetime as dt
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from ldvsurvey.io.importers import get_importer  # noqa: E402
from ldvsurvey.sim import catalog  # noqa: E402
from ldvsurvey.sim.scenario import simulate  # noqa: E402
from tests.io.test_import_ubx import receiver_stream  # noqa: E402


def main(minutes: float = 5.0) -> None:
    sim = simulate(catalog.drive(minutes=minutes, static_s=30.0), seed=6)
    data = receiver_stream(sim, dt.date.fromisoformat(sim.scenario.date))
    hours = (sim.imu.t_s[-1] - sim.imu.t_s[0]) / 3600.0
    print(f"log: {len(data) / 1e6:.2f} MB, {len(sim.imu.t_s)} IMU samples, {hours * 60:.1f} min")
    ubx = get_importer("ubx")
    for role in ("imu", "gnss"):
        best = float("inf")
        for _ in range(3):
            t0 = time.process_time()
            ubx.read(data, "bench.ubx", role, {})
            best = min(best, time.process_time() - t0)
        print(f"{role}: {best:.3f} CPU s ({best / hours:.1f} CPU s per hour of log)")


if __name__ == "__main__":
    main(float(sys.argv[1]) if len(sys.argv) > 1 else 5.0)
