"""Admin and account pages in Chromium: forms clear after a create and confirm beside themselves,
users and projects deleted after a question that says what happens to the logs, a token revoked
only after asking (and its secret gone from the page), names with bidi controls refused."""

import httpx
import pytest

from tests.browser.helpers import ADMIN, shot
from tests.browser.test_people_pages import api_as, ui_login
from tests.bundles import make_bundle

pytestmark = pytest.mark.browser

#: the element is on screen (inside the viewport) and below the given element
ON_SCREEN = """(sel) => { const r = document.querySelector(sel).getBoundingClientRect();
  return r.height > 0 && r.top >= 0 && r.bottom <= window.innerHeight; }"""


def test_admin_forms_clear_confirm_beside_and_delete_after_asking(auth_server, page):
    ui_login(page, auth_server, *ADMIN)
    page.click("#admin-link")
    page.wait_for_selector("#project-form")
    page.fill("#project-name", "Trial 2026")
    page.click("#project-create")
    page.wait_for_selector("tr[data-project='Trial 2026']")
    assert page.input_value("#project-name") == ""
    assert "Project “Trial 2026” created." in page.inner_text("#project-msg")
    assert page.evaluate(ON_SCREEN, "#project-msg p")
    page.fill("#user-name", "kate")
    page.fill("#user-password", "kate-password")
    page.select_option("#user-project", label="Trial 2026")
    page.click("#user-create")
    page.wait_for_selector("tr[data-user='kate']")
    assert page.input_value("#user-name") == "" and page.input_value("#user-password") == ""
    assert "User “kate” created." in page.inner_text("#user-msg")
    page.locator("#user-msg p").scroll_into_view_if_needed()
    assert page.evaluate(ON_SCREEN, "#user-msg p")
    # a name with a right-to-left override is refused, naming the character, and stays in the form
    page.fill("#user-name", "ev\u202eil")
    page.fill("#user-password", "evil-password")
    page.click("#user-create")
    page.wait_for_selector("#user-msg .error")
    assert "U+202E" in page.inner_text("#user-msg")
    assert page.locator("tr[data-user^='ev']").count() == 0
    # a log in the project, uploaded by kate
    k = api_as(auth_server, "kate", "kate-password")
    pid = next(p["id"] for p in k.get("/api/projects").json() if p["name"] == "Trial 2026")
    up = k.post(
        "/api/logs",
        data={"project_id": str(pid)},
        files=[("files", (n, d, "x")) for n, d in make_bundle(seed=94, n_imu=300).items()],
    )
    k.close()
    assert up.status_code == 201, up.text
    log_id = up.json()["id"]
    page.reload()
    page.wait_for_selector("tr[data-user='kate']")
    # one's own row offers neither disable nor delete (the server refuses both)
    assert page.locator(f"tr[data-user='{ADMIN[0]}'] button").count() == 0
    # deleting a user asks first and says their logs stay; cancel keeps them
    page.click("tr[data-user='kate'] button[data-deluser]")
    question = page.inner_text("#user-confirm")
    assert "Delete user “kate”?" in question and "stay in their projects" in question
    shot(page, "admin-delete-user-question")
    page.click("#user-confirm [data-confirm='no']")
    assert page.locator("#user-confirm .confirm").count() == 0
    assert page.locator("tr[data-user='kate']").count() == 1
    page.click("tr[data-user='kate'] button[data-deluser]")
    page.click("#user-confirm [data-confirm='yes']")
    page.wait_for_selector("tr[data-user='kate']", state="detached")
    assert "their logs stay" in page.inner_text("#user-msg")
    a = api_as(auth_server, *ADMIN)
    assert a.get(f"/api/logs/{log_id}").status_code == 200
    # deleting the project says how many logs go, and they go
    row = page.locator("tr[data-project='Trial 2026']")
    assert row.locator("td").nth(1).inner_text().strip() == "1"
    row.locator("button[data-delproject]").click()
    question = page.inner_text("#project-confirm")
    assert "Delete project “Trial 2026”?" in question and "Its 1 log is deleted" in question
    page.click("#project-confirm [data-confirm='yes']")
    page.wait_for_selector("tr[data-project='Trial 2026']", state="detached")
    assert "deleted with 1 logs" in page.inner_text("#project-msg")
    assert a.get(f"/api/logs/{log_id}").status_code == 404
    a.close()


def test_token_form_clears_revoke_asks_and_hides_the_secret(auth_server, page):
    ui_login(page, auth_server, *ADMIN)
    page.click("#account-link")
    page.wait_for_selector("#token-form")
    page.fill("#token-name", "survey van")
    page.fill("#token-days", "7")
    page.click("#token-create")
    page.wait_for_selector("#new-token")
    secret = page.inner_text("#new-token").strip()
    assert page.input_value("#token-name") == "laptop" and page.input_value("#token-days") == "90"  # defaults
    bearer = {"Authorization": f"Bearer {secret}"}
    row = page.locator("#tokens tr[data-token]", has_text="survey van")
    # asked first; cancelling keeps the token working
    row.locator("button[data-revoke]").click()
    assert "Revoke token “survey van”?" in page.inner_text("#token-confirm")
    shot(page, "token-revoke-question")
    page.click("#token-confirm [data-confirm='no']")
    assert httpx.get(auth_server + "/api/logs", headers=bearer).status_code == 200
    assert row.count() == 1
    row.locator("button[data-revoke]").click()
    page.click("#token-confirm [data-confirm='yes']")
    page.wait_for_selector("#tokens tr[data-token]:has-text('survey van')", state="detached")
    assert page.locator("#new-token").count() == 0 and secret not in page.inner_text("body")
    assert "revoked; its secret is hidden" in page.inner_text("#token-msg")
    r = httpx.get(auth_server + "/api/logs", headers=bearer)
    assert r.status_code == 401
    # a secret can also be hidden by hand once copied
    page.fill("#token-name", "desk")
    page.click("#token-create")
    page.wait_for_selector("#new-token")
    s2 = page.inner_text("#new-token").strip()
    page.click("#hide-token")
    assert s2 not in page.inner_text("body")
