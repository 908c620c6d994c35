"""The dashboard in a real headless Chromium: drag-and-drop upload, pipelines, plots, downloads, errors."""

import base64
import io
import json
import zipfile

import httpx
import pytest

from ldvsurvey.sim import catalog
from ldvsurvey.sim.scenario import bundle_files, simulate
from tests.browser.helpers import shot
from tests.bundles import zip_bytes

pytestmark = pytest.mark.browser


def drop_files(page, name_bytes: dict):
    """Dispatch a real drop event carrying File objects onto the drop zone."""
    payload = {n: base64.b64encode(b).decode() for n, b in name_bytes.items()}
    page.evaluate(
        """(files) => {
        const dt = new DataTransfer();
        for (const [name, b64] of Object.entries(files)) {
            const bin = Uint8Array.from(atob(b64), c => c.charCodeAt(0));
            dt.items.add(new File([bin], name));
        }
        const zone = document.getElementById('drop');
        zone.dispatchEvent(new DragEvent('dragover', {dataTransfer: dt, bubbles: true}));
        zone.dispatchEvent(new DragEvent('drop', {dataTransfer: dt, bubbles: true}));
    }""",
        payload,
    )


def wait_job(base, job_id, timeout_s=240):
    import time

    for _ in range(int(timeout_s * 2)):
        j = httpx.get(f"{base}/api/jobs/{job_id}").json()
        if j["status"] in ("succeeded", "failed", "cancelled"):
            return j
        time.sleep(0.5)
    raise TimeoutError(job_id)


def start_job(page, pipeline):
    page.select_option("#pipe", pipeline)
    page.click("#start")
    page.wait_for_selector("#startmsg:has-text('queued')")
    return int(page.inner_text("#startmsg").split()[1])


@pytest.fixture(scope="module")
def height_zip():
    return zip_bytes(bundle_files(simulate(catalog.height(minutes=12.0, length_m=3000.0), seed=8)))


@pytest.fixture(scope="module")
def gravity_zip():
    return zip_bytes(bundle_files(simulate(catalog.gravity(n_lines=3, line_km=3.0), seed=9)))


def test_upload_run_height_plot_and_download(server, page, height_zip):
    page.goto(server + "/#/logs")
    drop_files(page, {"height-run.zip": height_zip})
    page.wait_for_selector("#upload-ok", timeout=60_000)
    shot(page, "logs")
    page.click("#upload-ok a")
    page.wait_for_selector("#pipe")
    shot(page, "log-detail")
    csp = []
    page.on("console", lambda m: csp.append(m.text) if "Content Security Policy" in m.text else None)
    job = start_job(page, "height")
    page.wait_for_selector(f"tr[data-job='{job}'] progress")  # live progress row
    page.goto(f"{server}/#/jobs/{job}")  # watched while it runs: the page follows it to the end
    page.wait_for_selector("#jobstatus .status-succeeded", timeout=240_000)
    j = wait_job(server, job)
    assert j["status"] == "succeeded", j["error"]
    page.wait_for_selector("#view-height .main-svg", timeout=30_000)
    assert "running" not in page.inner_text("#jobstate")
    assert "done" in page.inner_text("#job-stages")
    imu_sha = next(f["sha256"] for f in j["inputs"][0]["files"] if f["name"] == "imu.csv")
    assert imu_sha in page.inner_text("#job-inputs")
    # every plot names both axes
    for v in ("height", "height_error"):
        page.wait_for_selector(f"#view-{v} .main-svg", timeout=30_000)
        titles = page.evaluate(f"""() => {{ const l = document.getElementById('view-{v}').layout;
            return [l.xaxis.title.text, l.yaxis.title.text]; }}""")
        assert all(titles), (v, titles)
    # the plot carries the data, not just a div
    n = page.evaluate("() => document.getElementById('view-height').data.map(t => t.x.length)")
    assert len(n) == 3 and min(n[:2]) > 100
    ys = page.evaluate("() => document.getElementById('view-height').data[0].y.slice(0, 5)")
    assert all(isinstance(v, (int, float)) for v in ys)
    shot(page, "view-height")
    with page.expect_download() as dl:
        page.click("#downloads a:has-text('height.csv')")
    got = open(dl.value.path(), "rb").read()
    assert got == httpx.get(f"{server}/api/jobs/{job}/files/height.csv").content
    assert got.startswith(b"t_s,gps_week,gps_sow_s,h_m,h_uncompensated_m,h_gnss_m,fix_quality")
    # the log page's GNSS fix plot: axis titles and one legend entry per fix quality
    page.goto(f"{server}/#/logs/{j['log_ids'][0]}")
    page.wait_for_selector("#fixplot .main-svg", timeout=30_000)
    fix = page.evaluate("""() => { const el = document.getElementById('fixplot');
        return {x: el.layout.xaxis.title.text, y: el.layout.yaxis.title.text, names: el.data.map(t => t.name)}; }""")
    assert fix["x"] and fix["y"] and len(fix["names"]) >= 1 and all(n[0].isdigit() for n in fix["names"])
    assert csp == []


def test_gravity_lines_and_coincidence_table(server, page, gravity_zip):
    page.goto(server + "/#/logs")
    page.set_input_files("#pick", files=[{"name": "gravity.zip", "mimeType": "application/zip", "buffer": gravity_zip}])
    page.wait_for_selector("#upload-ok", timeout=60_000)
    page.click("#upload-ok a")
    page.wait_for_selector("#pipe")
    job = start_job(page, "gravity")
    j = wait_job(server, job)
    assert j["status"] == "succeeded", j["error"]
    page.goto(f"{server}/#/jobs/{job}")
    page.wait_for_selector("#view-gravity_lines .main-svg", timeout=30_000)
    names = page.evaluate("() => document.getElementById('view-gravity_lines').data.map(t => t.name)")
    assert {"L1", "L2", "L3", "mean line"} <= set(names)
    rows = page.locator("table.coincidence").first.locator("tr").count()
    assert rows == 1 + 3
    shot(page, "view-gravity")
    page.goto(server + "/#/compare")
    page.wait_for_selector("#cmp .main-svg", timeout=30_000)
    page.wait_for_selector("#cmp-download")
    shot(page, "compare")


def test_bad_bundle_shows_file_line_field(server, page, height_zip):
    files = {}
    with zipfile.ZipFile(io.BytesIO(height_zip)) as zf:
        for n in zf.namelist():
            files[n] = zf.read(n)
    m = json.loads(files["manifest.json"])
    m["imu"]["rate_hz"] = "100 Hz"
    files["manifest.json"] = json.dumps(m, indent=2).encode()
    page.goto(server + "/#/logs")
    drop_files(page, files)
    page.wait_for_selector("#upload-error", timeout=60_000)
    text = page.inner_text("#upload-error")
    assert "manifest.json" in text and "imu.rate_hz" in text and "line" in text
    shot(page, "upload-error")
