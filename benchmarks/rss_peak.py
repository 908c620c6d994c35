"""Where a pipeline's memory peaks: run it in-process and record the Python stack at each new RSS high.

Prints the stack at the peak and the RSS after each pipeline stage. Not part of the test suite.
Run: .venv/bin/python benchmarks/rss_peak.py PIPELINE BUNDLE [KEY=VALUE ...]
"""

from __future__ import annotations

import sys
import threading
import time
import traceback
from pathlib import Path


def _rss_mb() -> float:
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1]) / 1024.0
    return 0.0


def main(name: str, bundle: str, sets: list[str]) -> None:
    from ldvsurvey.io.drivelog import load_bundle
    from ldvsurvey.pipelines.base import Progress, parse_set_args, run_pipeline
    from ldvsurvey.pipelines.registry import get

    main_id = threading.get_ident()
    peak = {"mb": 0.0, "stack": ""}
    stop = threading.Event()

    def watch():
        while not stop.wait(0.05):
            mb = _rss_mb()
            if mb > peak["mb"] + 20:
                frame = sys._current_frames().get(main_id)
                peak.update(mb=mb, stack="".join(traceback.format_stack(frame, limit=12)))

    threading.Thread(target=watch, daemon=True).start()
    t0 = time.perf_counter()
    logs = [load_bundle(bundle)]
    print(f"after load: {_rss_mb():.0f} MB, {time.perf_counter() - t0:.1f} s")

    def report(stage, frac):
        print(f"  {time.perf_counter() - t0:6.1f} s {_rss_mb():7.0f} MB  {stage} {frac:.2f}", flush=True)

    run_pipeline(get(name), logs, parse_set_args(sets), Progress(report))
    stop.set()
    print(f"peak {peak['mb']:.0f} MB at:\n{peak['stack']}")


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2], sys.argv[3:])
