"""Benchmark: store, load and download a one-hour 100 Hz log with its blobs in the SQLite folder and
in PostgreSQL (``blob_chunks``). Prints wall time and the peak of Python allocations (tracemalloc)
of each step; asserts nothing.

Run: .venv/bin/python benchmarks/bench_blobstore.py [POSTGRESQL_URL]
(the URL's database is emptied first; without it only SQLite is measured)
"""

import sys
import tempfile
import time
import tracemalloc
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from ldvsurvey.io.drivelog import parse_files  # noqa: E402
from ldvsurvey.io.quality import quality_report  # noqa: E402
from ldvsurvey.store import blobs  # noqa: E402
from ldvsurvey.store.db import session_scope, upgrade_head  # noqa: E402
from ldvsurvey.store.logs import delete_log, get_file, load_drivelog, store_log  # noqa: E402
from tests.bundles import make_bundle  # noqa: E402


def _measure(what: str, fn):
    tracemalloc.start()
    t0 = time.perf_counter()
    out = fn()
    dt = time.perf_counter() - t0
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    print(f"  {what:<34} {dt:7.3f} s   peak allocations {peak / 2**20:7.1f} MiB")
    return out


def run(url: str, label: str, log) -> None:
    print(f"{label}:")
    q = quality_report(log)

    def store():
        with session_scope(url) as s:
            return store_log(s, log, q)[0].id

    log_id = _measure("store (originals + Parquet)", store)

    def load():
        with session_scope(url) as s:
            return load_drivelog(s, log_id).imu.t_s.size

    _measure("load arrays (as a job does)", load)

    def download():
        with session_scope(url) as s:
            f = get_file(s, log_id, "imu.csv")
            pieces, size = blobs.download(f, f.blob, piece_bytes=256 * 1024)
            n = sum(len(p) for p in pieces)
            assert n == size
            return n

    n = _measure("download imu.csv (256-KiB pieces)", download)
    print(f"  (imu.csv {n / 1e6:.1f} MB)")
    with session_scope(url) as s:
        delete_log(s, log_id)


def main() -> None:
    files = make_bundle(seed=1, n_imu=360_000)
    print(f"bundle: {sum(len(v) for v in files.values()) / 1e6:.1f} MB")
    with tempfile.TemporaryDirectory() as d:
        url = f"sqlite:///{d}/bench.db"
        upgrade_head(url)
        run(url, "SQLite + blob folder", parse_files(files))
    if len(sys.argv) > 1:
        from tests.helpers.db import reset_database

        reset_database(sys.argv[1])
        run(sys.argv[1], "PostgreSQL + blob_chunks", parse_files(files))


if __name__ == "__main__":
    main()
