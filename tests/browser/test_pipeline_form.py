"""The log page's pipeline form in Chromium: only the pipelines that apply, fields from the schema,
an out-of-range value refused at the door with the field named."""

import httpx
import pytest

from tests.bundles import make_bundle

pytestmark = pytest.mark.browser


def test_form_offers_only_applicable_pipelines_and_names_a_bad_field(server, page):
    # a vehicle with a fixed IMU and a 2-D LDV: no tilt (needs a rotating IMU), no damping (vessels)
    r = httpx.post(
        server + "/api/logs",
        files=[("files", (n, d, "x")) for n, d in make_bundle(seed=71, n_imu=300).items()],
        timeout=60,
    )
    assert r.status_code in (200, 201), r.text
    log_id = r.json()["id"]
    page.goto(f"{server}/#/logs/{log_id}")
    page.wait_for_selector("#pipe")
    offered = page.eval_on_selector_all("#pipe option", "os => os.map(o => o.value)")
    assert "tilt" not in offered and "damping" not in offered
    assert {"height", "navigate", "calibrate"} <= set(offered)
    assert "rotating IMU" in page.text_content("[data-na='tilt']")
    assert "vessels" in page.text_content("[data-na='damping']")
    # fields generated from the schema: bounds on number inputs, enums as choice lists
    page.select_option("#pipe", "height")
    scale = page.locator("[data-p='ldv_scale']")
    assert scale.get_attribute("type") == "number"
    assert float(scale.get_attribute("min")) == 0.5 and float(scale.get_attribute("max")) == 1.5
    assert page.eval_on_selector_all("select[data-p='dov'] option", "os => os.map(o => o.value)") == [
        "none",
        "egm2008",
        "grid",
    ]
    # labelled with the parameter's label and unit (pipelines/labels.py), never its key
    shown = page.inner_text("#params")
    assert "LDV mounting pitch η_L (°)" in shown and "Initial height of the IMU centre (m)" in shown
    assert "ldv_pitch_deg" not in shown and "initial_h_m" not in shown
    assert "LDV scale factor K" in scale.locator("xpath=..").inner_text()
    before = len(httpx.get(f"{server}/api/jobs?log_id={log_id}").json())
    scale.fill("-3")
    page.click("#start")
    page.wait_for_selector("#startmsg .error")
    assert "ldv_scale" in page.inner_text("#startmsg")
    assert len(httpx.get(f"{server}/api/jobs?log_id={log_id}").json()) == before  # nothing queued
