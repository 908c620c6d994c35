"""A project's base stations in Chromium: entered on the project's logs page (a bad value refused
naming its field, nothing added), edited and deleted after asking; the gravity job form of a log of
the project offers them and fills base_ties with the server's text."""

import json

import pytest

from tests.browser.helpers import ADMIN, shot
from tests.browser.test_people_pages import api_as, ui_login
from tests.bundles import make_bundle

pytestmark = pytest.mark.browser


def test_project_ties_panel_and_the_job_form(auth_server, page):
    a = api_as(auth_server, *ADMIN)
    pid = a.post("/api/admin/projects", json={"name": "Ties 2026"}).json()["id"]
    files = make_bundle(seed=95)
    manifest = json.loads(files["manifest.json"])  # two lines: the gravity pipeline applies (not run here)
    manifest["lines"] = [
        {"name": "L1", "t_start": 30002.0, "t_end": 30009.0},
        {"name": "L2", "t_start": 30011.0, "t_end": 30018.0},
    ]
    files["manifest.json"] = json.dumps(manifest).encode()
    up = a.post("/api/logs", data={"project_id": str(pid)}, files=[("files", (n, d, "x")) for n, d in files.items()])
    assert up.status_code == 201, up.text
    log_id = up.json()["id"]
    ui_login(page, auth_server, *ADMIN)
    page.goto(f"{auth_server}/#/logs?project={pid}")
    page.wait_for_selector("#ties #tie-form")
    values = {"name": "AG-1", "lat_deg": "28.4861", "lon_deg": "113.0623", "h_m": "120.5", "sigma_mgal": "0.005"}
    for k, v in values.items():
        page.fill(f"#tie-{k}", v)
    page.fill("#tie-g_mgal", "13.2")  # a relative value where an absolute one belongs
    page.click("#tie-save")
    page.wait_for_selector("#tie-msg .error")
    assert "not an absolute gravity value" in page.inner_text("#tie-msg")
    assert page.evaluate("document.activeElement.id") == "tie-g_mgal"
    assert a.get(f"/api/projects/{pid}/ties").json()["ties"] == []
    page.fill("#tie-g_mgal", "979137.254")
    page.click("#tie-save")
    page.wait_for_selector("#ties tr[data-tie]")
    assert "AG-1" in page.inner_text("#ties tr[data-tie]")
    shot(page, "project-ties")
    tid = a.get(f"/api/projects/{pid}/ties").json()["ties"][0]["id"]
    page.click(f"button[data-edit='{tid}']")
    page.fill("#tie-h_m", "151.25")
    page.click("#tie-save")
    page.wait_for_selector("#ties tr[data-tie]:has-text('151.250')")
    # the job form of the project's log offers them, filling base_ties with the list's text
    text = a.get(f"/api/projects/{pid}/ties").json()["base_ties"]
    page.goto(f"{auth_server}/#/logs/{log_id}")
    page.wait_for_selector("#pipe")
    page.select_option("#pipe", "gravity")
    page.click("#use-project-ties")
    assert page.input_value('[data-p="base_ties"]') == text and "151.25" in text
    # deleting asks first
    page.goto(f"{auth_server}/#/logs?project={pid}")
    page.wait_for_selector("#ties tr[data-tie]")
    page.click(f"button[data-del='{tid}']")
    assert "Delete station AG-1?" in page.inner_text("#tie-msg")
    page.click("#tie-msg [data-confirm='yes']")
    page.wait_for_selector("#ties tr[data-tie]", state="detached")
    assert a.get(f"/api/projects/{pid}/ties").json()["ties"] == []
    a.close()
