"""Benchmark: the survey report of a simulated gravity run (three 3-km lines): time to build the
HTML (figures drawn as SVG by matplotlib), its size, and the time of each view's figure.

Prints figures; asserts nothing. Run: .venv/bin/python benchmarks/bench_report.py
"""

import datetime as dt
import statistics
import time


def main(repeats=3):
    import numpy as np

    from ldvsurvey.api.report import ReportJob, job_report
    from ldvsurvey.api.views import DictTables, build_view, views_of
    from ldvsurvey.io.drivelog import parse_files
    from ldvsurvey.pipelines.base import run_pipeline
    from ldvsurvey.pipelines.registry import get
    from ldvsurvey.sim import catalog
    from ldvsurvey.sim.scenario import bundle_files, simulate

    log = parse_files(bundle_files(simulate(catalog.gravity(n_lines=3, line_km=3.0), seed=9)))
    res = run_pipeline(get("gravity"), [log], {})
    tables = {f"{k}.csv": {c: v for c, v in t.items()} for k, t in res.tables.items()}
    for t in tables.values():
        if "line" in t:  # text columns as the CSV reader gives them
            t["line"] = np.asarray(t["line"], dtype=object)
    g = log.gnss
    arrays = {"gnss": {"t_s": g.t_s, "lat_deg": g.lat_deg, "lon_deg": g.lon_deg, "fix": g.fix}}
    reader = DictTables(tables, arrays)
    rows = {k: len(next(iter(t.values()))) for k, t in tables.items()}
    print(f"gravity run: {rows} rows, {len(g.t_s)} GNSS epochs")
    for v in views_of("gravity"):
        t0 = time.perf_counter()
        fig = build_view(reader, "gravity", res.summary, v.name, None, None, 2000)
        n = sum(len(tr["x"]) for tr in fig["data"])
        print(f"  view {v.name:22s} {1000 * (time.perf_counter() - t0):7.1f} ms  {n} points")
    job = ReportJob(1, "gravity", "succeeded", res.summary, reader, [{"id": 1, "name": "sim", "sha256": "-"}])
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        html = job_report(job, "bench", dt.datetime.now(dt.UTC))
        times.append(time.perf_counter() - t0)
    print(
        f"job report: median {statistics.median(times):.2f} s (min {min(times):.2f}, first {times[0]:.2f}) "
        f"over {repeats}; {len(html) / 1024:.0f} KiB, {html.count('<svg')} SVG figures"
    )


if __name__ == "__main__":
    main()
