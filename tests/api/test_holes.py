"""Holes a probe found: the many-member zip bomb, security headers, read-your-writes on DELETE,
deleting a log while its job runs, job and log ids never reused, compressed answers."""

import io
import threading
import tracemalloc
import zipfile

import pytest

from ldvsurvey.store.db import session_scope
from ldvsurvey.store.models import Job, JobFile
from tests.bundles import make_bundle, zip_bytes

MiB = 1 << 20


def many_member_bomb(n=1200) -> bytes:
    """The probe's archive: n members of 1 MiB of zeros each (about 1 kB compressed each)."""
    buf = io.BytesIO()
    zero = b"\0" * MiB
    with zipfile.ZipFile(buf, "w", zipfile.ZIP_DEFLATED, compresslevel=9) as zf:
        for k in range(n):
            zf.writestr(f"z{k:04d}.bin", zero)
    return buf.getvalue()


@pytest.fixture(scope="module")
def bomb():
    return many_member_bomb()


@pytest.mark.parametrize("max_members", [64, 5000])  # 5000: the count passes, the declared size/ratio must stop it
def test_many_member_bomb_refused_before_inflating(settings, bomb, max_members):
    from fastapi.testclient import TestClient

    from ldvsurvey.api.app import create_app

    # the production limits (2 GiB unpacked, 512 MiB upload): the archive fits both
    st = settings.model_copy(
        update={"max_unzipped_bytes": 2 << 30, "max_upload_bytes": 512 * MiB, "max_zip_members": max_members}
    )
    assert 1.0e6 < len(bomb) < 1.5e6
    with TestClient(create_app(st)) as c:
        tracemalloc.start()
        try:
            tracemalloc.reset_peak()
            base, _ = tracemalloc.get_traced_memory()
            r = c.post("/api/logs", files=[("files", ("bomb.zip", bomb, "application/zip"))])
            _, peak = tracemalloc.get_traced_memory()
        finally:
            tracemalloc.stop()
        assert r.status_code in (413, 422), r.text
        assert ("entries" if max_members < 1200 else "bomb") in r.json()["detail"]
        assert peak - base < 100 * MiB, f"peak grew {(peak - base) / MiB:.0f} MiB"
        assert c.get("/api/logs").json() == []


@pytest.mark.parametrize(
    "make,needle",
    [
        (lambda: zip_bytes({**make_bundle(seed=40, n_imu=300), **{f"x{k}.txt": b"x" for k in range(80)}}), "entries"),
        (lambda: zip_bytes({**make_bundle(seed=41, n_imu=300), "pad.bin": b"\0" * (3 * MiB)}), "bomb"),
    ],
)
def test_archive_judged_by_its_directory(client, make, needle):
    r = client.post("/api/logs", files=[("files", ("b.zip", make(), "application/zip"))])
    assert r.status_code == 413 and needle in r.json()["detail"], r.text


def test_unknown_member_named_but_not_inflated(client):
    files = make_bundle(seed=42, n_imu=300)
    r = client.post(
        "/api/logs", files=[("files", ("b.zip", zip_bytes({**files, "notes.txt": b"hello"}), "application/zip"))]
    )
    assert r.status_code == 201, r.text
    assert any("notes.txt" in w for w in r.json()["quality"]["warnings"])
    assert {f["name"] for f in client.get(f"/api/logs/{r.json()['id']}").json()["files"]} == set(files)


def test_security_headers_on_pages_docs_api_and_errors(client):
    for path in ("/", "/docs", "/api/health", "/api/logs/999999", "/js/main.js"):
        h = client.get(path).headers
        csp = h.get("content-security-policy", "")
        assert "script-src 'self'" in csp and "unsafe-inline" not in csp.split("script-src")[1].split(";")[0], path
        assert "frame-ancestors 'none'" in csp, path
        assert h.get("x-content-type-options") == "nosniff", path
        assert h.get("referrer-policy") == "no-referrer", path


def test_docs_served_from_this_server(client):
    page = client.get("/docs").text
    assert "cdn" not in page.lower() and "<script>" not in page  # no CDN, no inline script
    for src in ("/vendor/swagger-ui/swagger-ui-bundle.js", "/vendor/swagger-ui/swagger-ui.css", "/docs-init.js"):
        assert src in page
        r = client.get(src)
        assert r.status_code == 200 and len(r.content) > 50, src


def test_large_answers_are_gzipped(client):
    r = client.get("/vendor/plotly.min.js", headers={"Accept-Encoding": "gzip"})
    assert r.status_code == 200 and r.headers.get("content-encoding") == "gzip"


def test_delete_answers_after_commit(client):
    for seed in range(3):
        log_id = client.post(
            "/api/logs", files=[("files", (n, d, "x")) for n, d in make_bundle(seed=50 + seed, n_imu=300).items()]
        ).json()["id"]
        assert client.delete(f"/api/logs/{log_id}").status_code == 204
        assert client.get(f"/api/logs/{log_id}").status_code == 404


def test_ids_never_reused(client):
    files = make_bundle(seed=55, n_imu=300)
    a = client.post("/api/logs", files=[("files", (n, d, "x")) for n, d in files.items()]).json()["id"]
    url = client.app_state.database_url
    with session_scope(url) as s:
        j = Job(pipeline="height", log_ids=[a], parameters={}, status="failed", stage="failed", progress=0)
        s.add(j)
        s.flush()
        job_a = j.id
    assert client.delete(f"/api/logs/{a}").status_code == 204  # takes its job along
    b = client.post("/api/logs", files=[("files", (n, d, "x")) for n, d in files.items()]).json()["id"]
    with session_scope(url) as s:
        j = Job(pipeline="height", log_ids=[b], parameters={}, status="failed", stage="failed", progress=0)
        s.add(j)
        s.flush()
        job_b = j.id
    assert b > a and job_b > job_a


def test_deleting_a_log_stops_its_running_job(client, monkeypatch, capfd):
    """The job is running (inside the pipeline) when its log is deleted: it ends as cancelled,
    writes no results, and no foreign-key traceback is printed."""
    from ldvsurvey.jobs import runner
    from ldvsurvey.pipelines import base

    inside, release = threading.Event(), threading.Event()
    real = base.run_pipeline

    def slow(pipe, logs, params, progress=None):
        inside.set()
        release.wait(30)
        return real(pipe, logs, params, progress)

    monkeypatch.setattr(runner, "run_pipeline", slow)
    files = make_bundle(seed=56, n_imu=2000, rotating=True)  # tilt applies (the worker checks again)
    log_id = client.post("/api/logs", files=[("files", (n, d, "x")) for n, d in files.items()]).json()["id"]
    url = client.app_state.database_url
    with session_scope(url) as s:
        j = Job(
            pipeline="tilt",
            log_ids=[log_id],
            parameters={"output_rate_hz": 1},
            status="queued",
            stage="queued",
            progress=0,
        )
        s.add(j)
        s.flush()
        job_id = j.id
    out = {}
    t = threading.Thread(target=lambda: out.setdefault("status", client.app_state.runner.execute(job_id)))
    t.start()
    assert inside.wait(30)
    assert client.delete(f"/api/logs/{log_id}").status_code == 204
    release.set()
    t.join(60)
    assert out["status"] == "cancelled"
    with session_scope(url) as s:
        assert s.get(Job, job_id) is None
        assert s.query(JobFile).filter(JobFile.job_id == job_id).count() == 0
    err = capfd.readouterr().err
    assert "Traceback" not in err and "FOREIGN KEY" not in err


def test_unexpected_failure_tells_what_to_do(client, monkeypatch):
    from ldvsurvey.jobs import runner

    def broken(*a, **k):
        raise IndexError("index 5 is out of bounds for axis 0 with size 5")

    monkeypatch.setattr(runner, "run_pipeline", broken)
    files = make_bundle(seed=57, n_imu=300, rotating=True)  # tilt applies (the worker checks again)
    log_id = client.post("/api/logs", files=[("files", (n, d, "x")) for n, d in files.items()]).json()["id"]
    with session_scope(client.app_state.database_url) as s:
        j = Job(pipeline="tilt", log_ids=[log_id], parameters={}, status="queued", stage="queued", progress=0)
        s.add(j)
        s.flush()
        job_id = j.id
    assert client.app_state.runner.execute(job_id) == "failed"
    j = client.get(f"/api/jobs/{job_id}").json()
    assert not j["error"].startswith("internal error")
    assert "tilt pipeline" in j["error"] and "retry" in j["error"]
    assert [e["stage"] for e in j["stage_log"]][0] == "started" and j["stage_log"][-1]["stage"].startswith("failed")
    v = client.get(f"/api/jobs/{job_id}/views/attitude")
    assert v.status_code == 409 and "failed" in v.json()["detail"]
