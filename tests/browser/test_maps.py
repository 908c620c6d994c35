"""Maps in Chromium: a plain projected map in metres (scale bar, north arrow) when no basemap is set,
and with LDVSURVEY_BASEMAP_TILE_URL the tiles of that server (and no other), admitted by the
Content-Security-Policy, with a scale bar true to the zoom and a way back to the plain map.

The tiles come from a small server in this test (a plain PNG), so no network is needed."""

import io
import re
import threading
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer

import httpx
import pytest

from tests.api.helpers import SUMMARIES, provenance, store_job, tables
from tests.browser.helpers import shot, start_server
from tests.bundles import make_bundle

pytestmark = pytest.mark.browser


def _png() -> bytes:
    from PIL import Image

    buf = io.BytesIO()
    Image.new("RGB", (256, 256), (200, 230, 200)).save(buf, format="PNG")
    return buf.getvalue()


@pytest.fixture(scope="module")
def tiles():
    """A tile server on loopback; records the tile paths asked for."""
    png, asked = _png(), []

    class H(BaseHTTPRequestHandler):
        def do_GET(self):
            asked.append(self.path)
            self.send_response(200)
            self.send_header("Content-Type", "image/png")
            self.send_header("Access-Control-Allow-Origin", "*")
            self.send_header("Content-Length", str(len(png)))
            self.end_headers()
            self.wfile.write(png)

        def log_message(self, *a):
            pass

    srv = ThreadingHTTPServer(("127.0.0.1", 0), H)
    threading.Thread(target=srv.serve_forever, daemon=True).start()
    yield f"http://127.0.0.1:{srv.server_address[1]}", asked
    srv.shutdown()


def _serve_with_jobs(tmp_path_factory, extra):
    data = tmp_path_factory.mktemp("mapsrv")
    url = f"sqlite:///{data / 'ldvsurvey.db'}"
    proc, base = start_server(data, {"LDVSURVEY_DEMO_MODE": "1", "LDVSURVEY_DATABASE_URL": url, **extra})
    files = make_bundle(seed=75, n_imu=300)
    r = httpx.post(base + "/api/logs", files=[("files", (n, d, "x")) for n, d in files.items()], timeout=60)
    log_id = r.json()["id"]
    tabs, _ = tables()
    jobs = {
        "navigate": store_job(
            url, [log_id], "navigate", {"trajectory.csv": tabs["trajectory.csv"]}, provenance("navigate", "a" * 64)
        ),
        "gravity": store_job(
            url,
            [log_id],
            "gravity",
            {k: tabs[k] for k in ("gravity.csv", "coincidence.csv")},
            {**provenance("gravity", "b" * 64), **SUMMARIES["gravity"]},
        ),
    }
    return proc, base, jobs


@pytest.fixture(scope="module")
def plain_server(tmp_path_factory):
    proc, base, jobs = _serve_with_jobs(tmp_path_factory, {})
    yield base, jobs
    proc.terminate()
    proc.wait(timeout=20)


@pytest.fixture(scope="module")
def tile_server(tmp_path_factory, tiles):
    origin, _ = tiles
    extra = {
        "LDVSURVEY_BASEMAP_TILE_URL": origin + "/tiles/{z}/{x}/{y}.png",
        "LDVSURVEY_BASEMAP_ATTRIBUTION": "test tiles",
    }
    proc, base, jobs = _serve_with_jobs(tmp_path_factory, extra)
    yield base, jobs, origin
    proc.terminate()
    proc.wait(timeout=20)


def _watch(page):
    """Requests leaving the server's origin and CSP refusals, as the page makes them."""
    seen = {"requests": [], "refused": []}
    page.on("request", lambda r: seen["requests"].append(r.url))
    page.on("console", lambda m: "Content Security Policy" in m.text and seen["refused"].append(m.text))
    return seen


def test_plain_map_in_metres_without_a_basemap(plain_server, page):
    base, jobs = plain_server
    assert httpx.get(base + "/api/basemap").json()["tile_url"] is None
    csp = httpx.get(base + "/").headers["content-security-policy"]
    assert "img-src 'self' data: blob:;" in csp and "connect-src 'self';" in csp  # nothing foreign admitted
    seen = _watch(page)
    for pipe, view in (("navigate", "trajectory"), ("gravity", "gravity_map")):
        page.goto(f"{base}/#/jobs/{jobs[pipe]}")
        page.wait_for_selector(f"#view-{view} .main-svg", timeout=30_000)
        got = page.evaluate(
            """(el) => ({notes: [...el.querySelectorAll('.annotation-text')].map(n => n.textContent),
                        shapes: el.querySelectorAll('.shapelayer path').length,
                        axes: [...el.querySelectorAll('.xtitle, .ytitle')].map(n => n.textContent),
                        maplibre: el.querySelectorAll('.maplibregl-canvas').length})""",
            page.query_selector(f"#view-{view}"),
        )
        assert "N" in got["notes"] and any(re.fullmatch(r"\d+ k?m", t) for t in got["notes"]), got
        assert got["shapes"] >= 1 and got["axes"] == ["east (m)", "north (m)"] and got["maplibre"] == 0
        assert page.query_selector(f"#view-{view} ~ .map-toggle") is None  # no basemap, nothing to toggle
        shot(page, f"map-plain-{pipe}")
    assert all(u.startswith(base) for u in seen["requests"]), [u for u in seen["requests"] if not u.startswith(base)]
    assert seen["refused"] == []


def test_basemap_tiles_from_the_setting_with_a_true_scale_bar(tile_server, tiles, page):
    base, jobs, origin = tile_server
    _, asked = tiles
    csp = httpx.get(base + "/").headers["content-security-policy"]
    assert f"img-src 'self' data: blob: {origin};" in csp and f"connect-src 'self' {origin};" in csp
    seen = _watch(page)
    page.goto(f"{base}/#/jobs/{jobs['gravity']}")
    page.wait_for_selector("#view-gravity_map .maplibregl-canvas", timeout=60_000)
    page.wait_for_function("() => document.querySelector('.map-overlay .scalebar')", timeout=30_000)
    page.wait_for_timeout(1500)
    assert any(p.startswith("/tiles/") and p.endswith(".png") for p in asked), asked
    foreign = {re.match(r"https?://[^/]+", u).group(0) for u in seen["requests"] if u.startswith("http")}
    assert foreign <= {base, origin}, foreign  # the tiles' server and no other
    assert seen["refused"] == []
    # the scale bar: its pixels × metres per pixel at the map's zoom and latitude = the length it states
    bar = page.evaluate(
        """() => { const el = document.getElementById('view-gravity_map'), m = el._fullLayout.map;
        const sb = document.querySelector('.map-overlay .scalebar');
        return {metres: Number(sb.dataset.metres), px: sb.querySelector('span').getBoundingClientRect().width,
                text: sb.textContent.trim(), lat: m.center.lat, zoom: m.zoom,
                north: document.querySelector('.map-overlay .north').textContent}; }"""
    )
    import math

    mpp = 156543.03392 * math.cos(math.radians(bar["lat"])) / 2 ** bar["zoom"]  # web Mercator, 256-px tiles
    assert bar["px"] * mpp == pytest.approx(bar["metres"], rel=0.02), bar
    assert bar["text"].endswith("m") and "N" in bar["north"]
    shot(page, "map-basemap-gravity")
    # back to the plain map in metres (e.g. with the network off)
    page.uncheck("#view-gravity_map ~ .map-toggle input")
    page.wait_for_selector("#view-gravity_map .main-svg .xtitle", timeout=30_000)
    assert page.query_selector("#view-gravity_map .maplibregl-canvas") is None
    assert page.text_content("#view-gravity_map .xtitle") == "east (m)"


def test_a_bad_tile_url_is_refused_at_start():
    from pydantic import ValidationError

    from ldvsurvey.settings import Settings

    for bad in ("ftp://x/{z}/{x}/{y}.png", "https://tiles.example/{z}/{x}.png", "https://a b/{z}/{x}/{y}", "x; y"):
        with pytest.raises(ValidationError, match="BASEMAP_TILE_URL"):
            Settings(basemap_tile_url=bad)
    s = Settings(basemap_tile_url="https://tile.openstreetmap.org/{z}/{x}/{y}.png")
    assert s.basemap_origin() == "https://tile.openstreetmap.org"
