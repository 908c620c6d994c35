"""In Chromium with authentication on: log in, administer people and projects, API tokens, /docs offline."""

from urllib.parse import urlparse

import httpx
import pytest

from tests.browser.helpers import ADMIN, shot
from tests.bundles import make_bundle

pytestmark = pytest.mark.browser


def ui_login(page, base, user, password):
    page.goto(base + "/")
    page.wait_for_selector("#login-form")
    page.fill("#login-user", user)
    page.fill("#login-password", password)
    page.click("#login-submit")
    page.wait_for_selector("#account-link")


def api_as(base, user, password) -> httpx.Client:
    c = httpx.Client(base_url=base)
    r = c.post("/api/login", json={"username": user, "password": password})
    assert r.status_code == 200, r.text
    c.headers["X-CSRF-Token"] = r.json()["csrf"]
    return c


def test_admin_makes_user_and_project_user_sees_only_that(auth_server, page):
    page.goto(auth_server + "/")
    page.wait_for_selector("#login-form")  # a form, not "authentication required"
    page.fill("#login-user", ADMIN[0])
    page.fill("#login-password", "wrong password")
    page.click("#login-submit")
    page.wait_for_selector("#login-error")
    shot(page, "login-error")
    ui_login(page, auth_server, *ADMIN)
    page.click("#admin-link")
    page.wait_for_selector("#project-form")
    page.wait_for_selector("#leftovers-removed")  # the storage figures of GET /api/admin/storage
    assert "Stored logs:" in page.inner_text("#storage")
    assert "0 staging folders and 0 partial files, 0.0 MB" in page.inner_text("#leftovers-removed")
    page.fill("#project-name", "Field 2026")
    page.click("#project-create")
    page.wait_for_selector("tr[data-project='Field 2026']")
    page.fill("#user-name", "ivan")
    page.fill("#user-password", "ivan-password")
    page.select_option("#user-project", label="Field 2026")
    page.click("#user-create")
    page.wait_for_selector("tr[data-user='ivan']")
    assert "Field 2026" in page.inner_text("tr[data-user='ivan']")
    lines = [ln.strip() for ln in page.inner_text("#admin").split("\n")]
    assert "," not in lines  # lists of rows are joined without separators
    shot(page, "admin")
    # one log in the new project, one in the admin's own (upload without project_id)
    c = api_as(auth_server, *ADMIN)
    pid = next(p["id"] for p in c.get("/api/projects").json() if p["name"] == "Field 2026")
    ok = c.post(
        "/api/logs",
        data={"project_id": str(pid)},
        files=[("files", (n, d, "x")) for n, d in make_bundle(seed=90, n_imu=300).items()],
    )
    mine = c.post("/api/logs", files=[("files", (n, d, "x")) for n, d in make_bundle(seed=91, n_imu=300).items()])
    c.close()
    assert ok.status_code == 201 and mine.status_code == 201
    assert mine.json()["project_id"] not in (None, pid)
    page.click("#logout")
    page.wait_for_selector("#login-form")
    ui_login(page, auth_server, "ivan", "ivan-password")
    page.wait_for_selector("#logs tbody tr[data-id]")
    options = page.eval_on_selector_all("#f-project option", "os => os.map(o => o.textContent.trim())")
    assert options == ["all", "Field 2026"]
    ids = page.eval_on_selector_all("#logs tbody tr[data-id]", "rs => rs.map(r => +r.dataset.id)")
    assert ids == [ok.json()["id"]]
    assert page.locator("#admin-link").count() == 0
    shot(page, "member-logs")


def test_token_created_listed_and_revoked(auth_server, page):
    ui_login(page, auth_server, *ADMIN)
    page.click("#account-link")
    page.wait_for_selector("#token-form")
    page.fill("#token-name", "field laptop")
    page.fill("#token-days", "30")
    page.click("#token-create")
    page.wait_for_selector("#new-token")
    secret = page.inner_text("#new-token").strip()
    row = page.locator("#tokens tr[data-token]", has_text="field laptop")
    assert row.count() == 1
    bearer = {"Authorization": f"Bearer {secret}"}
    assert httpx.get(auth_server + "/api/logs", headers=bearer).status_code == 200
    shot(page, "tokens")
    row.locator("button[data-revoke]").click()
    page.click("#token-confirm [data-confirm='yes']")
    page.wait_for_selector("#tokens tr[data-token]:has-text('field laptop')", state="detached")
    assert httpx.get(auth_server + "/api/logs", headers=bearer).status_code == 401


def test_docs_render_without_network(auth_server, page):
    outside = []

    def only_loopback(route):
        host = urlparse(route.request.url).hostname
        if host in ("127.0.0.1", "localhost"):
            return route.continue_()
        outside.append(route.request.url)
        return route.abort()

    page.route("**/*", only_loopback)
    r = page.goto(auth_server + "/docs")
    assert "frame-ancestors" in r.headers["content-security-policy"]
    page.wait_for_selector(".swagger-ui .info .title", timeout=20_000)
    assert "ldv-survey" in page.inner_text(".swagger-ui .info .title")
    page.wait_for_selector(".opblock-summary-path[data-path='/api/logs']")
    assert outside == []
    shot(page, "docs-offline")


def test_change_password_in_the_browser(auth_server, page):
    c = api_as(auth_server, *ADMIN)
    assert c.post("/api/admin/users", json={"username": "judy", "password": "judy-password"}).status_code == 201
    c.close()
    ui_login(page, auth_server, "judy", "judy-password")
    page.click("#account-link")
    page.wait_for_selector("#password-form")
    page.fill("#password-form input[name=old]", "judy-password")
    page.fill("#password-form input[name=new]", "judy-new-password")
    page.click("#password-change")
    page.wait_for_selector("#login-form")  # every session ended: log in again
    page.fill("#login-user", "judy")
    page.fill("#login-password", "judy-password")
    page.click("#login-submit")
    page.wait_for_selector("#login-error")
    page.fill("#login-password", "judy-new-password")
    page.click("#login-submit")
    page.wait_for_selector("#account-link")
