"""Benchmark: refusing an ``imu.csv`` whose header has a million columns (issue 28: 10 s and
209 MB before its 422). Prints the wall time and the growth of the peak resident memory of the
refusal, from bytes and from files on disk (how uploads reach the parser); asserts nothing.
Run: .venv/bin/python benchmarks/bench_wide_header.py
"""

import resource
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from ldvsurvey.errors import InputError  # noqa: E402
from ldvsurvey.io.drivelog import parse_files  # noqa: E402
from tests.badinput import wide_imu  # noqa: E402
from tests.bundles import make_bundle  # noqa: E402


def _peak_mib() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def main(columns: int = 10**6) -> None:
    files = wide_imu(make_bundle(seed=3, n_imu=300), columns)
    print(f"imu.csv: {len(files['imu.csv']) / 1e6:.1f} MB, header of {columns + 7} columns")
    with tempfile.TemporaryDirectory() as d:
        for n, b in files.items():
            (Path(d) / n).write_bytes(b)
        for what, arg in (("bytes", files), ("files on disk", {n: Path(d) / n for n in files})):
            before = _peak_mib()
            t0 = time.perf_counter()
            try:
                parse_files(arg)
                answer = "accepted"
            except InputError as exc:
                answer = str(exc)
            dt = time.perf_counter() - t0
            print(f"{what}: {dt * 1e3:.1f} ms, peak RSS +{_peak_mib() - before:.0f} MiB: {answer[:100]}")


if __name__ == "__main__":
    main()
