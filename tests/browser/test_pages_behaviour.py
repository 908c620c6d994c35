"""Page behaviour in Chromium: stale timers, job states, formatting, escaping, layout rules."""

import time
from pathlib import Path

import httpx
import pytest

from tests.browser.helpers import ADMIN, shot
from tests.bundles import make_bundle

pytestmark = pytest.mark.browser
FRONTEND = Path(__file__).resolve().parents[2] / "frontend"


def upload(base, seed) -> int:
    r = httpx.post(
        base + "/api/logs",
        files=[("files", (n, d, "x")) for n, d in make_bundle(seed=seed, n_imu=300).items()],
        timeout=60,
    )
    assert r.status_code in (200, 201), r.text
    return r.json()["id"]


def finished(base, job_id, timeout_s=60):
    for _ in range(timeout_s * 4):
        j = httpx.get(f"{base}/api/jobs/{job_id}").json()
        if j["status"] not in ("queued", "running"):
            return j
        time.sleep(0.25)
    raise TimeoutError(job_id)


def test_old_page_does_not_write_into_the_next(server, page):
    a, b = upload(server, 92), upload(server, 93)
    job = httpx.post(f"{server}/api/logs/{a}/jobs", json={"pipeline": "height", "parameters": {"dov": "none"}}).json()[
        "id"
    ]
    finished(server, job)
    # log A's job list answers late (1.5 s): by then the page shows log B
    page.add_init_script(
        """(() => {
        const real = window.fetch;
        window.fetch = (url, opts) => String(url).includes('/api/jobs?log_id=LOG_A')
            ? new Promise((ok) => setTimeout(() => ok(real(url, opts)), 1500)) : real(url, opts);
    })();""".replace("LOG_A", str(a))
    )
    page.goto(f"{server}/#/logs/{a}")
    page.wait_for_selector("#pipe")
    page.evaluate("(b) => { location.hash = '#/logs/' + b; }", b)
    page.wait_for_selector("#jobs tbody tr")
    page.evaluate("""() => { window.foreign = 0; new MutationObserver(() => {
        if (document.querySelector('#jobs tr[data-job]')) window.foreign += 1; })
        .observe(document.getElementById('app'), {childList: true, subtree: true}); }""")
    time.sleep(4)
    assert page.evaluate("window.foreign") == 0
    assert page.inner_text("#jobs tbody") == "No jobs yet."


def test_failed_job_page_says_why(server, page):
    log_id = upload(server, 94)
    # passes the door (height applies to this log) and fails in the worker: too short for a calibration
    job = httpx.post(
        f"{server}/api/logs/{log_id}/jobs", json={"pipeline": "height", "parameters": {"dov": "none"}}
    ).json()["id"]
    j = finished(server, job)
    assert j["status"] == "failed"
    page.goto(f"{server}/#/jobs/{job}")
    page.wait_for_selector("#joberror")
    assert page.inner_text("#jobstatus") == "failed"
    assert "moving stretch with good GNSS" in page.inner_text("#joberror")
    body = page.inner_text("#app")
    assert "no results yet" not in body and "running" not in body
    # the job's record: parameters, inputs with their SHA-256, warnings, stage log
    sha = httpx.get(f"{server}/api/logs/{log_id}").json()["files"]
    for f in sha:
        assert f["sha256"] in page.inner_text("#job-inputs")
    assert "started" in page.inner_text("#job-stages") and "failed" in page.inner_text("#job-stages")
    # long errors wrap inside the table instead of running over it
    page.goto(f"{server}/#/logs/{log_id}")
    page.wait_for_selector(f"tr[data-job='{job}'] .error")
    over = page.evaluate(
        """(id) => { const td = document.querySelector(`tr[data-job='${id}'] td.err`);
        return td.scrollWidth - td.clientWidth; }""",
        job,
    )
    assert over <= 1
    shot(page, "failed-job-row")


def test_formatting_and_escaping_helpers(server, page):
    page.goto(server + "/")
    page.wait_for_selector("#logs")
    got = page.evaluate("""async () => {
        const f = await import('/js/format.js');
        const h = await import('/js/html.js');
        const s = await import('/js/summary.js');
        const nested = String(s.fields({n_lines: 3, dov: {xi_rms_arcsec: 0.123456789, lines: [{name: 'L1',
            rms_mgal: 1.5}]}, alpha_rad: 1e-4}));
        return {int: f.num(1200), whole: f.num(2.0), frac: f.num(0.1234567), big: f.num(1234567.891),
                tilt: f.quantity('alpha_rad', 1e-4), esc: String(h.html`<b title="${'"x'}">${'<i>&'}</b>`),
                nested};
    }""")
    assert got["int"] == "1200" and got["whole"] == "2" and got["frac"] == "0.123457"
    assert got["big"] == "1234567.891"
    assert got["tilt"] == "0.0001 rad (20.626″)"  # 1e-4 rad = 20.6265 arcsec
    assert got["esc"] == '<b title="&quot;x">&lt;i&gt;&amp;</b>'
    assert "xi_rms_arcsec" in got["nested"] and "0.123457" in got["nested"] and "L1" in got["nested"]
    assert "20.626″" in got["nested"] and ">3<" in got["nested"]


def test_favicon_and_shell(server, page):
    r = page.goto(server + "/")
    assert 'rel="icon"' in r.text()
    assert httpx.get(server + "/favicon.svg").status_code == 200
    assert "plotly" not in r.text()  # the 4.8 MB bundle does not block the first paint


def test_frontend_source_rules():
    """Small modules, lines of at most 120 characters, one escaping helper."""
    files = sorted(FRONTEND.rglob("*.js")) + sorted(FRONTEND.rglob("*.css")) + sorted(FRONTEND.rglob("*.html"))
    assert len(list(FRONTEND.rglob("*.js"))) >= 8
    for f in files:
        for k, line in enumerate(f.read_text().splitlines(), 1):
            assert len(line) <= 120, f"{f.name}:{k} has {len(line)} characters"
    for f in FRONTEND.rglob("*.js"):
        text = f.read_text()
        assert len(text.splitlines()) <= 400, f.name
        if f.name != "html.js":
            assert "&amp;" not in text and "&lt;" not in text, f"{f.name} escapes by itself"


def test_delete_is_visible_at_once(auth_server):
    """Over real HTTP the 204 comes after the commit: an immediate GET says 404 every time (as a
    logged-in user: the demo account deletes nothing, tests/api/test_demo_readonly.py)."""
    with httpx.Client(base_url=auth_server, timeout=60) as c:
        r = c.post("/api/login", json={"username": ADMIN[0], "password": ADMIN[1]})
        assert r.status_code == 200, r.text
        c.headers["X-CSRF-Token"] = r.json()["csrf"]
        for seed in range(95, 100):
            up = c.post(
                "/api/logs", files=[("files", (n, d, "x")) for n, d in make_bundle(seed=seed, n_imu=300).items()]
            )
            assert up.status_code in (200, 201), up.text
            log_id = up.json()["id"]
            assert c.delete(f"/api/logs/{log_id}").status_code == 204
            assert c.get(f"/api/logs/{log_id}").status_code == 404


def test_demo_page_offers_no_delete(server, page):
    upload(server, 94)
    page.goto(server + "/#/logs")
    page.wait_for_selector("#logs tbody tr td a")
    assert page.locator("button.del").count() == 0
