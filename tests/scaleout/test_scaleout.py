"""Failure and concurrency tests on real PostgreSQL + Redis (and SQLite for comparison)."""

import concurrent.futures as cf
import os
import signal
import threading
import time

import httpx
import pytest
from sqlalchemy import create_engine, text

from ldvsurvey.sim import catalog
from ldvsurvey.sim.scenario import bundle_files, simulate
from tests.bundles import make_bundle, zip_bytes
from tests.scaleout.helpers import Stack


def _wait(base, job_id, until=("succeeded", "failed", "cancelled"), timeout=300, pred=None):
    t0 = time.time()
    while time.time() - t0 < timeout:
        j = httpx.get(f"{base}/api/jobs/{job_id}", timeout=10).json()
        if (pred and pred(j)) or (not pred and j["status"] in until):
            return j
        time.sleep(0.3)
    raise TimeoutError(job_id)


def _count(db_url, table):
    with create_engine(db_url).connect() as c:
        return c.execute(text(f"SELECT count(*) FROM {table}")).scalar()


@pytest.fixture(scope="module")
def gravity_zip():
    return zip_bytes(bundle_files(simulate(catalog.gravity(n_lines=3, line_km=4.0), seed=21)))


def test_worker_sigkill_mid_gravity_job_requeued_and_finished_once(pg_fresh, tmp_path, gravity_zip):
    db, rd = pg_fresh
    st = Stack(tmp_path, db, rd, LDVSURVEY_HEARTBEAT_S="0.5", LDVSURVEY_STALE_S="4", LDVSURVEY_REAP_EVERY_S="1")
    try:
        st.start_api()
        w1 = st.start_worker()
        log_id = httpx.post(st.base + "/api/logs", files={"files": ("g.zip", gravity_zip)}, timeout=120).json()["id"]
        job = httpx.post(f"{st.base}/api/logs/{log_id}/jobs", json={"pipeline": "gravity"}).json()["id"]
        _wait(st.base, job, pred=lambda j: j["status"] == "running" and j["progress"] > 5)
        os.killpg(w1.pid, signal.SIGKILL)  # the worker dies in the middle of the job
        w1.wait()
        st.start_worker()
        j = _wait(st.base, job)
        assert j["status"] == "succeeded", j["error"]
        assert j["attempts"] == 2
        files = httpx.get(f"{st.base}/api/jobs/{job}/files").json()
        assert sorted(f["name"] for f in files) == ["coincidence.csv", "gravity.csv", "summary.json"]
        assert _count(db, "job_files") == 3  # exactly once: no duplicate results
    finally:
        st.stop()


def test_api_restart_during_upload_leaves_no_partial_log(pg_fresh, tmp_path):
    db, rd = pg_fresh
    st = Stack(tmp_path, db, rd, api_workers=1)
    big = zip_bytes(make_bundle(seed=40, n_imu=200_000))
    try:
        st.start_api()
        st.start_worker()
        boundary = "xyzBOUNDARY"
        head = (
            f'--{boundary}\r\nContent-Disposition: form-data; name="files"; filename="b.zip"\r\n'
            f"Content-Type: application/zip\r\n\r\n"
        ).encode()
        tail = f"\r\n--{boundary}--\r\n".encode()
        body = head + big + tail

        def slow_body():
            for i in range(0, len(body), 256 * 1024):
                yield body[i : i + 256 * 1024]
                time.sleep(0.05)

        def send():
            try:
                httpx.post(
                    st.base + "/api/logs",
                    content=slow_body(),
                    timeout=60,
                    headers={"Content-Type": f"multipart/form-data; boundary={boundary}"},
                )
            except httpx.HTTPError:
                pass

        th = threading.Thread(target=send)
        th.start()
        time.sleep(0.6)  # part of the body is in flight
        st.kill_api()
        th.join()
        st.start_api()
        assert httpx.get(st.base + "/api/logs").json() == []
        for table in ("logs", "log_files", "log_arrays"):
            assert _count(db, table) == 0
        # and the upload works after the restart
        r = httpx.post(st.base + "/api/logs", files={"files": ("b.zip", big)}, timeout=120)
        assert r.status_code == 201
    finally:
        st.stop()


@pytest.mark.parametrize("engine", ["sqlite", "postgresql"])
def test_ten_concurrent_uploads_and_jobs(engine, pg_fresh, tmp_path):
    db, rd = pg_fresh
    url = db if engine == "postgresql" else f"sqlite:///{tmp_path}/c.db"
    st = Stack(tmp_path, url, rd if engine == "postgresql" else None, api_workers=2)
    bundles = [make_bundle(seed=100 + i, n_imu=3000) for i in range(10)]
    drive = bundle_files(simulate(catalog.drive(minutes=6, static_s=120), seed=3))
    try:
        st.start_api()
        if engine == "postgresql":
            st.start_worker()
            st.start_worker()

        def up(files):
            return httpx.post(st.base + "/api/logs", files=[("files", (n, d)) for n, d in files.items()], timeout=120)

        with cf.ThreadPoolExecutor(10) as ex:
            results = list(ex.map(up, bundles))
        assert [r.status_code for r in results] == [201] * 10, [r.text for r in results if r.status_code != 201]
        assert len({r.json()["id"] for r in results}) == 10
        log_id = up(drive).json()["id"]

        def start(_):
            return httpx.post(
                f"{st.base}/api/logs/{log_id}/jobs",
                json={"pipeline": "navigate", "parameters": {"calibration": "nominal"}},
                timeout=60,
            )

        with cf.ThreadPoolExecutor(10) as ex:
            jobs = [r.json()["id"] for r in ex.map(start, range(10))]
        finals = [_wait(st.base, j, timeout=600) for j in jobs]
        assert [j["status"] for j in finals] == ["succeeded"] * 10, [j["error"] for j in finals]
        logs = "".join(p.read_text() for p in tmp_path.glob("*.log"))
        assert "database is locked" not in logs
    finally:
        st.stop()
