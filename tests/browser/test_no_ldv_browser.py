"""A log without an LDV in Chromium (issue 25): the log page says "no LDV" and offers only the
pipelines that apply (calibrate, height and damping listed as not for this log, with the reason);
navigate, gravity and dov run from the page; the gravity job shows no SINS/LDV comparison panel."""

import httpx
import pytest

from ldvsurvey.sim import catalog
from ldvsurvey.sim.scenario import bundle_files, simulate
from tests.browser.helpers import shot
from tests.browser.test_dashboard import wait_job
from tests.bundles import zip_bytes

pytestmark = pytest.mark.browser


def start_job(page, pipeline, prev=None):
    """Start ``pipeline`` from the form; the new job's id (waits until the message names a job other
    than ``prev``, the one started before from the same page)."""
    if page.eval_on_selector("#pipe", "s => s.value") != pipeline:
        page.select_option("#pipe", pipeline)
    page.click("#start")
    page.wait_for_function(
        """prev => { const t = document.getElementById('startmsg').innerText;
        return t.includes('queued') && !t.startsWith('job ' + prev + ' '); }""",
        arg=str(prev),
    )
    return int(page.inner_text("#startmsg").split()[1])


@pytest.fixture(scope="module")
def noldv_zip():
    sc = catalog.gravity(n_lines=3, line_km=3.0, fix_schedule=[], with_ldv=False)
    return zip_bytes(bundle_files(simulate(sc, seed=9)))


def test_log_without_ldv_in_the_dashboard(server, page, noldv_zip):
    page.goto(server + "/#/logs")
    page.set_input_files("#pick", files=[{"name": "ins-gnss.zip", "mimeType": "application/zip", "buffer": noldv_zip}])
    page.wait_for_selector("#upload-ok", timeout=60_000)
    page.click("#upload-ok a")
    page.wait_for_selector("#pipe")
    assert "no LDV" in page.inner_text("#noldv")
    offered = page.eval_on_selector_all("#pipe option", "os => os.map(o => o.value)")
    assert {"navigate", "gravity", "dov"} <= set(offered)
    assert not {"calibrate", "height", "damping", "tilt"} & set(offered)
    for p in ("calibrate", "height", "damping"):
        assert "has no LDV" in page.text_content(f"[data-na='{p}']"), p
    shot(page, "log-no-ldv")
    log_url = page.url
    jobs = {"navigate": start_job(page, "navigate")}
    jobs["gravity"] = start_job(page, "gravity", jobs["navigate"])
    page.select_option("#pipe", "dov")
    page.select_option("select[data-p='compensation']", "false")
    jobs["dov"] = start_job(page, "dov", jobs["gravity"])
    for name, job in jobs.items():
        j = wait_job(server, job, timeout_s=400)
        assert j["status"] == "succeeded", (name, j["error"])
    nav = httpx.get(f"{server}/api/jobs/{jobs['navigate']}").json()
    assert nav["summary"]["aiding"] == "gnss"
    page.goto(f"{server}/#/jobs/{jobs['navigate']}")
    page.wait_for_selector("#view-trajectory .main-svg", timeout=30_000)
    g = httpx.get(f"{server}/api/jobs/{jobs['gravity']}").json()
    assert g["summary"]["aiding"] == "gnss"
    # no empty comparison panel; the map of the lines' δg applies
    assert [v["name"] for v in g["views"]] == ["gravity_lines", "gravity_residuals", "gravity_map"]
    page.goto(f"{server}/#/jobs/{jobs['gravity']}")
    page.wait_for_selector("#view-gravity_residuals .main-svg", timeout=30_000)
    names = page.evaluate("() => document.getElementById('view-gravity_lines').data.map(t => t.name)")
    assert {"L1", "L2", "L3", "mean line"} <= set(names)
    assert page.locator("#view-gravity_compare_gnss").count() == 0
    assert "SINS/GNSS internal coincidence" in page.inner_text("#lines")
    shot(page, "view-gravity-no-ldv")
    page.goto(log_url)
    page.wait_for_selector("#pipe")
