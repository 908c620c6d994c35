"""Benchmark: open a one-hour log's height view in Chromium; time to the plots drawn and bytes per chart.

Prints figures; asserts nothing. Run: .venv/bin/python benchmarks/bench_views.py
"""

import os
import statistics
import time

import httpx


def main(repeats=5):
    from _server import start
    from playwright.sync_api import sync_playwright

    from ldvsurvey.sim import catalog
    from ldvsurvey.sim.scenario import bundle_files, simulate

    srv, base, data = start(["-m", "ldvsurvey.cli", "serve", "--port", "{port}"], {"LDVSURVEY_DEMO_MODE": "1"})
    try:
        files = bundle_files(simulate(catalog.height(minutes=60.0, length_m=15000.0), seed=1))
        log_id = httpx.post(
            base + "/api/logs", files=[("files", (n, d)) for n, d in files.items()], timeout=300
        ).json()["id"]
        job = httpx.post(f"{base}/api/logs/{log_id}/jobs", json={"pipeline": "height"}).json()["id"]
        while httpx.get(f"{base}/api/jobs/{job}").json()["status"] not in ("succeeded", "failed"):
            time.sleep(0.5)
        rows = len(httpx.get(f"{base}/api/jobs/{job}/files/height.csv").text.splitlines()) - 1
        with sync_playwright() as p:
            b = p.chromium.launch(
                executable_path="/usr/bin/chromium",
                args=["--no-sandbox", "--disable-gpu", "--disable-background-networking", "--disable-component-update"],
            )
            times, sizes = [], {}
            ctx = b.new_context()  # one browser profile: the first opening is cold, later ones warm
            for _ in range(repeats):
                page = ctx.new_page()
                page.on(
                    "response",
                    lambda r: (
                        sizes.__setitem__(r.url.split("?")[0].rsplit("/", 1)[-1], len(r.body()))
                        if "/views/" in r.url
                        else None
                    ),
                )
                t0 = time.perf_counter()
                page.goto(f"{base}/#/jobs/{job}")
                page.wait_for_selector("#view-height .main-svg")
                page.wait_for_selector("#view-height_error .main-svg")
                times.append(time.perf_counter() - t0)
                if os.environ.get("BENCH_TRACE"):
                    for e in page.evaluate(
                        "() => performance.getEntriesByType('resource').map(e => [e.name.split('/').slice(-2)"
                        ".join('/'), Math.round(e.startTime), Math.round(e.responseEnd)])"
                    ):
                        print("  ", e)
                    print(
                        "   domContentLoaded",
                        page.evaluate(
                            "() => Math.round(performance.getEntriesByType('navigation')[0].domContentLoadedEventEnd)"
                        ),
                    )
                page.close()
            # in the app: the dashboard is open (plotly.js loaded) and the user opens the job's view
            page = ctx.new_page()
            page.goto(f"{base}/#/logs")
            page.wait_for_selector("#logs tbody tr")
            nav = []
            for _ in range(repeats):
                page.evaluate("() => { location.hash = '#/logs'; }")
                page.wait_for_selector("#logs tbody tr")
                t0 = time.perf_counter()
                page.evaluate(f"() => {{ location.hash = '#/jobs/{job}'; }}")
                page.wait_for_selector("#view-height .main-svg")
                page.wait_for_selector("#view-height_error .main-svg")
                nav.append(time.perf_counter() - t0)
            b.close()
        print(f"height.csv of the one-hour log: {rows} rows")
        print(f"cold (first opening, plotly.js not cached): {times[0]:.3f} s to both height charts drawn")
        print(
            f"in the app (dashboard open, click to the job's height view): median "
            f"{statistics.median(nav):.3f} s (min {min(nav):.3f}, max {max(nav):.3f})"
        )
        warm = times[1:]
        print(
            f"full page reload, warm: median {statistics.median(warm):.3f} s (min {min(warm):.3f}, max {max(warm):.3f})"
        )
        for k, v in sizes.items():
            print(f"bytes sent for chart '{k}': {v / 1e3:.0f} kB")
    finally:
        srv.terminate()
        srv.wait()


if __name__ == "__main__":
    main()
