"""Benchmark: parse + quality report + store of a one-hour 100 Hz bundle.

360 000 IMU rows, 360 000 LDV rows, 3 600 GGA epochs. Prints figures; asserts nothing.
Run: .venv/bin/python benchmarks/bench_ingest.py
"""

import statistics
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from ldvsurvey.io.drivelog import parse_files  # noqa: E402
from ldvsurvey.io.quality import quality_report  # noqa: E402
from ldvsurvey.store.db import session_scope, upgrade_head  # noqa: E402
from ldvsurvey.store.logs import delete_log, store_log  # noqa: E402
from tests.bundles import make_bundle  # noqa: E402


def main(repeats: int = 5) -> None:
    files = make_bundle(seed=1, n_imu=360_000)
    size = sum(len(v) for v in files.values())
    print(f"bundle: {size / 1e6:.1f} MB ({', '.join(f'{k} {len(v) / 1e6:.1f} MB' for k, v in files.items())})")
    with tempfile.TemporaryDirectory() as d:
        url = f"sqlite:///{d}/bench.db"
        upgrade_head(url)
        parse_t, store_t = [], []
        for _ in range(repeats):
            t0 = time.perf_counter()
            log = parse_files(files)
            q = quality_report(log)
            t1 = time.perf_counter()
            with session_scope(url) as s:
                row, _ = store_log(s, log, q)
                log_id = row.id
            t2 = time.perf_counter()
            parse_t.append(t1 - t0)
            store_t.append(t2 - t1)
            with session_scope(url) as s:
                delete_log(s, log_id)
        tot = [a + b for a, b in zip(parse_t, store_t)]
        print(f"parse+quality: median {statistics.median(parse_t):.3f} s (min {min(parse_t):.3f})")
        print(f"store (SQLite, originals + Parquet): median {statistics.median(store_t):.3f} s")
        print(f"total parse+store: median {statistics.median(tot):.3f} s, min {min(tot):.3f} s, max {max(tot):.3f} s")


if __name__ == "__main__":
    main()
