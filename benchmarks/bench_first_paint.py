"""Benchmark: cold first paint of the dashboard in Chromium on loopback.

Each run opens a fresh browser context (empty cache) on ``/`` with a few logs stored, and reads
first-contentful-paint from the Performance API, plus the time until the logs table is filled.
Prints figures; asserts nothing. Target: first paint <= 1 s.
Run: PYTHONPATH=backend .venv/bin/python benchmarks/bench_first_paint.py
"""

import statistics
import sys
from pathlib import Path

import httpx

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))


def main(repeats=7):
    from _server import start
    from playwright.sync_api import sync_playwright

    from tests.bundles import make_bundle

    srv, base, _ = start(["-m", "ldvsurvey.cli", "serve", "--port", "{port}"], {"LDVSURVEY_DEMO_MODE": "1"})
    try:
        for seed in range(3):
            httpx.post(
                base + "/api/logs",
                files=[("files", (n, d)) for n, d in make_bundle(seed=seed, n_imu=500).items()],
                timeout=60,
            )
        with sync_playwright() as p:
            b = p.chromium.launch(
                executable_path="/usr/bin/chromium",
                args=["--no-sandbox", "--disable-gpu", "--disable-background-networking", "--disable-component-update"],
            )
            fcp, table, transferred = [], [], []
            for _ in range(repeats):
                ctx = b.new_context()  # cold: nothing cached
                page = ctx.new_page()
                page.goto(base + "/", wait_until="commit")
                page.wait_for_selector("#logs tbody tr[data-id]")
                t = page.evaluate("""() => {
                    const p = performance.getEntriesByName('first-contentful-paint')[0];
                    const nav = performance.getEntriesByType('navigation')[0];
                    const res = performance.getEntriesByType('resource');
                    return {fcp: p ? p.startTime : null, now: performance.now(),
                            bytes: nav.transferSize + res.reduce((a, r) => a + r.transferSize, 0)}; }""")
                fcp.append(t["fcp"] / 1000)
                table.append(t["now"] / 1000)
                transferred.append(t["bytes"])
                ctx.close()
            b.close()
        print(
            f"cold first contentful paint: median {statistics.median(fcp):.3f} s, max {max(fcp):.3f} s "
            f"over {repeats} fresh contexts (target <= 1 s)"
        )
        print(f"logs table filled by:        median {statistics.median(table):.3f} s")
        print(
            f"bytes transferred (cold):    {statistics.median(transferred) / 1024:.0f} KiB "
            "(plotly is fetched later, when a page has a plot)"
        )
    finally:
        srv.terminate()
        srv.wait(timeout=20)


if __name__ == "__main__":
    main()
