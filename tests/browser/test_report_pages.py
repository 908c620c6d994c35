"""Views and reports in Chromium: every view drawn on the job page against its data, the compare
page's panels, and the survey report of a gravity job and of a project opened offline and printed
to PDF.

The jobs here are stored directly (their tables built to trip a view up, tests/api/helpers.py),
so every pipeline's views are drawn without running the pipelines; the report of a real gravity
run is checked on the session server (test_report_of_a_real_gravity_run).
"""

import re
import time

import httpx
import pytest

from ldvsurvey.api import views as V
from tests.api.helpers import NETWORK, SUMMARIES, provenance, store_job, tables
from tests.browser.helpers import shot, start_server
from tests.bundles import make_bundle

pytestmark = pytest.mark.browser
SHA = "fedcba9876543210" * 4
FILES = {
    "height": ("height.csv",),
    "tilt": ("attitude.csv",),
    "navigate": ("trajectory.csv",),
    "calibrate": ("calibration_track.csv",),
    "gravity": ("gravity.csv", "coincidence.csv", "gravity_adjusted.csv", "network_residuals.csv"),
    "dov": ("dov.csv",),
    "damping": ("damping.csv",),
}


@pytest.fixture(scope="module")
def stored_server(tmp_path_factory):
    """A demo-mode server on a database this test can write to, with one stored job per pipeline
    that has views, plus a second gravity job (for the compare page), all on one uploaded log."""
    data = tmp_path_factory.mktemp("reportsrv")
    url = f"sqlite:///{data / 'ldvsurvey.db'}"
    proc, base = start_server(data, {"LDVSURVEY_DEMO_MODE": "1", "LDVSURVEY_DATABASE_URL": url})
    files = make_bundle(seed=74, n_imu=300)
    r = httpx.post(base + "/api/logs", files=[("files", (n, d, "x")) for n, d in files.items()], timeout=60)
    assert r.status_code in (200, 201), r.text
    log_id = r.json()["id"]
    tabs, _ = tables()
    jobs = {}
    for pipe, names in FILES.items():
        summary = {**provenance(pipe, SHA), **SUMMARIES[pipe], **(NETWORK if pipe == "gravity" else {})}
        jobs[pipe] = store_job(url, [log_id], pipe, {n: tabs[n] for n in names}, summary)
    jobs["gravity2"] = store_job(
        url, [log_id], "gravity", {n: tabs[n] for n in FILES["gravity"]}, {**provenance("gravity", SHA)}
    )
    yield base, jobs, log_id
    proc.terminate()
    proc.wait(timeout=20)


#: the figure as the page drew it against the figure the API serves, and its layout on screen
CHECK = """(el) => {
  const fl = el._fullLayout, svg = el.querySelector('.main-svg').getBoundingClientRect();
  const out = {traces: el.data.map(t => ({name: t.name, x: t.x, y: t.y})), axes: {}, title: null};
  const t = el.querySelector('.gtitle');
  if (t) { const b = t.getBoundingClientRect();
           out.title = [b.left - svg.left, b.right - svg.left, svg.width, b.bottom - svg.top, fl._size.t]; }
  for (const ax of ['xaxis', 'yaxis']) out.axes[ax] = {range: fl[ax].range, title: fl[ax].title.text};
  out.axisTitles = [...el.querySelectorAll('.xtitle, .ytitle')].map(n => n.textContent);
  return out;
}"""


def _span(vals):
    v = [p for p in vals if p is not None]
    return (min(v), max(v)) if v else None


def test_every_view_on_the_job_page_against_its_data(stored_server, page):
    base, jobs, _ = stored_server
    seen = set()
    for pipe in FILES:
        job = jobs[pipe]
        page.goto(f"{base}/#/jobs/{job}")
        for name in [x["name"] for x in httpx.get(f"{base}/api/jobs/{job}").json()["views"]]:
            v = V.VIEWS[name]
            page.wait_for_selector(f"#view-{v.name} .main-svg", timeout=30_000)
            got = page.evaluate(CHECK, page.query_selector(f"#view-{v.name}"))
            fig = httpx.get(f"{base}/api/jobs/{job}/views/{v.name}", params={"points": 2000}).json()
            # the page draws the server's figure as it is (thinned in data order, gaps as breaks)
            assert [t["x"] for t in got["traces"]] == [t["x"] for t in fig["data"]], v.name
            assert [t["y"] for t in got["traces"]] == [t["y"] for t in fig["data"]], v.name
            # the title fits inside the plot, both axes have titles with units
            left, right, width, bottom, plot_top = got["title"]
            assert left >= 0 and right <= width, (v.name, got["title"])
            assert bottom <= plot_top + 1, (v.name, "the title runs into the plot", got["title"])
            assert len(got["axisTitles"]) >= 2 and all(re.search(r"\(.+\)$", s) for s in got["axisTitles"])
            # the axis ranges stay near the data's (autorange pads a little; nothing runs km beyond)
            for ax, key in (("xaxis", "x"), ("yaxis", "y")):
                lo, hi = _span(sum((t[key] for t in fig["data"] if "floor" not in (t["name"] or "")), []))
                r0, r1 = got["axes"][ax]["range"]
                pad = 0.15 * max(hi - lo, 1e-9)
                assert lo - pad <= r0 <= lo + 1e-9 and hi - 1e-9 <= r1 <= hi + pad, (v.name, ax, (r0, r1), (lo, hi))
            seen.add(v.name)
        shot(page, f"views-{pipe}")
    assert seen == set(V.VIEWS)


def test_compare_page_axes_and_a_single_job(stored_server, page):
    base, jobs, _ = stored_server
    page.goto(f"{base}/#/compare")
    page.wait_for_selector("#cmp .main-svg", timeout=30_000)
    for c in page.query_selector_all("#cmp-jobs input"):  # only our two gravity jobs
        if int(c.get_attribute("value")) not in (jobs["gravity"], jobs["gravity2"]):
            c.uncheck()
    page.wait_for_timeout(500)
    geo = page.evaluate(
        """() => {
        const el = document.getElementById('cmp'), fl = el._fullLayout;
        const top = el.querySelector('.main-svg').getBoundingClientRect().top;
        const t = el.querySelector('.xtitle').getBoundingClientRect();
        // the lower panel's plot area ends at its y axis' offset + length (px from the svg's top)
        return {title: {top: t.top - top}, low: {bottom: fl.yaxis2._offset + fl.yaxis2._length},
                xticks: el.querySelectorAll('.xaxislayer-above .xtick text').length,
                x2ticks: el.querySelectorAll('.xaxislayer-above .x2tick text').length};
    }"""
    )
    # the x title sits under the lower panel, and both panels have tick labels
    assert geo["title"]["top"] >= geo["low"]["bottom"] - 1, geo
    assert geo["xticks"] > 2 and geo["x2ticks"] > 2, geo
    shot(page, "compare-two")
    for c in page.query_selector_all("#cmp-jobs input"):
        if int(c.get_attribute("value")) != jobs["gravity"]:
            c.uncheck()
    page.wait_for_function("() => document.querySelector('#cmp .gtitle').textContent.includes('second')")
    assert "no common points" not in page.inner_text("#cmp")


def _open_offline(browser, path):
    """The saved report in a context without network: every request is refused and recorded."""
    ctx = browser.new_context(offline=True, viewport={"width": 794, "height": 1123})
    asked = []

    def refuse(route):
        asked.append(route.request.url)
        route.abort()

    ctx.route(re.compile(r"^(?!file:).*"), refuse)
    pg = ctx.new_page()
    pg.goto(path.as_uri())
    return ctx, pg, asked


def _check_report(browser, tmp_path, text, name, must_have):
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    ctx, pg, asked = _open_offline(browser, path)
    try:
        body = pg.inner_text("body")
        for s in must_have:
            assert s in body, s
        assert pg.locator("svg").count() >= 2
        assert asked == [], asked  # nothing fetched: it is self-contained
        pg.emulate_media(media="print")
        # A4 at 96 dpi less the 12-mm margins: nothing wider than the printed page
        assert pg.evaluate("() => document.documentElement.scrollWidth") <= 794
        pdf = pg.pdf(format="A4", print_background=True)
        assert pdf.startswith(b"%PDF-")
        pages = len(re.findall(rb"/Type\s*/Page[^s]", pdf))
        assert pages >= 2, pages
        (tmp_path / (name + ".pdf")).write_bytes(pdf)
        return pages
    finally:
        ctx.close()


def test_reports_open_offline_print_to_pdf_and_carry_provenance(stored_server, browser, page, tmp_path):
    base, jobs, log_id = stored_server
    bundle = httpx.get(f"{base}/api/logs/{log_id}").json()["sha256"]
    # downloadable from the job page
    page.goto(f"{base}/#/jobs/{jobs['gravity']}")
    page.wait_for_selector("#report-download")
    with page.expect_download(timeout=180_000) as dl:
        page.click("#report-download button")
    text = open(dl.value.path(), encoding="utf-8").read()
    assert dl.value.suggested_filename == f"ldv-survey-job-{jobs['gravity']}-gravity-report.html"
    prov = ["Provenance", SHA, SHA[::-1], bundle, "9.8.7-test", "fir_length_s", "2026-01-02T03:04:05+00:00"]
    _check_report(browser, tmp_path, text, "job.html", prov + ["Headline figures", "Per line"])
    # and a project's, from the logs page with the project chosen
    me = httpx.get(f"{base}/api/me").json()
    pid = httpx.get(f"{base}/api/logs/{log_id}").json()["project_id"]
    pname = next(p["name"] for p in me["project_list"] if p["id"] == pid)
    page.goto(f"{base}/#/logs?project={pid}")
    page.wait_for_selector("#project-report-download")
    with page.expect_download(timeout=180_000) as dl:
        page.click("#project-report-download")
    text = open(dl.value.path(), encoding="utf-8").read()
    _check_report(browser, tmp_path, text, "project.html", prov + [f"Survey report: project {pname}", "Finished jobs"])


def test_report_of_a_real_gravity_run(server, browser, tmp_path):
    """A gravity job the pipeline really ran (three 3-km lines): its report, offline, to PDF."""
    from ldvsurvey.sim import catalog
    from ldvsurvey.sim.scenario import bundle_files, simulate
    from tests.bundles import zip_bytes

    z = zip_bytes(bundle_files(simulate(catalog.gravity(n_lines=3, line_km=3.0), seed=9)))
    r = httpx.post(server + "/api/logs", files=[("files", ("gravity.zip", z, "application/zip"))], timeout=120)
    assert r.status_code in (200, 201), r.text
    log_id = r.json()["id"]
    job = httpx.post(f"{server}/api/logs/{log_id}/jobs", json={"pipeline": "gravity"}, timeout=60).json()["id"]
    for _ in range(400):
        j = httpx.get(f"{server}/api/jobs/{job}", timeout=60).json()
        if j["status"] not in ("queued", "running"):
            break
        time.sleep(1.0)
    assert j["status"] == "succeeded", j["error"]
    text = httpx.get(f"{server}/api/jobs/{job}/report", timeout=120).text
    hashes = [f["sha256"] for i in j["inputs"] for f in i["files"]]
    s = j["summary"]
    must = hashes + [s["software_version"], s["started_at"], "Headline figures", "Repeatability"]
    _check_report(browser, tmp_path, text, "gravity.html", must)
