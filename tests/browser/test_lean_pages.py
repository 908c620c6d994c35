"""What a page costs on the wire: Plotly (1.5 MB) is fetched only by the pages that draw a chart."""

import time

import pytest

from tests.browser.helpers import start_server
from tests.bundles import make_bundle

pytestmark = pytest.mark.browser


@pytest.fixture(scope="module")
def lean_server(tmp_path_factory):
    """A demo-mode server with one uploaded log (no demo survey, no job)."""
    import httpx

    data = tmp_path_factory.mktemp("leansrv")
    proc, base = start_server(data, {"LDVSURVEY_DEMO_MODE": "1"})
    files = make_bundle(seed=31, n_imu=300)
    r = httpx.post(base + "/api/logs", files=[("files", (n, d, "x")) for n, d in files.items()], timeout=60)
    assert r.status_code in (200, 201), r.text
    yield base, r.json()["id"]
    proc.terminate()
    proc.wait(timeout=20)


def _bytes_of(page, url, ready, settle_s=2.0):
    """(bytes received over the wire, paths fetched) while ``url`` loads and then idles ``settle_s``."""
    got = []
    page.on("requestfinished", lambda r: got.append(r))
    page.goto(url)
    page.wait_for_selector(ready)
    page.wait_for_load_state("networkidle")
    time.sleep(settle_s)  # the old page fetched Plotly when idle after the first paint
    page.wait_for_load_state("networkidle")
    total = 0
    for r in got:
        s = r.sizes()
        total += s["responseBodySize"] + s["responseHeadersSize"]
    return total, [r.url.split("/", 3)[-1] for r in got]


def test_logs_list_does_not_fetch_plotly(lean_server, page):
    base, _ = lean_server
    total, paths = _bytes_of(page, f"{base}/#/logs", "#logs tbody tr")
    print(f"\nlogs list: {total} bytes over the wire in {len(paths)} requests")
    assert not [p for p in paths if "plotly" in p], paths
    assert total < 300_000, (total, paths)  # the page's own scripts and styles; Plotly alone is ~1.5 MB


def test_log_page_with_a_chart_fetches_plotly(lean_server, page):
    base, log_id = lean_server
    total, paths = _bytes_of(page, f"{base}/#/logs/{log_id}", "#pipe")
    print(f"\nlog page: {total} bytes over the wire in {len(paths)} requests")
    assert [p for p in paths if "plotly" in p], paths
