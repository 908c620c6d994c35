"""What a process killed mid-upload leaves on disk (the staging folder of the upload, a ``.part`` blob
being written) is removed when a server starts, periodically, and by ``ldv-survey clean``; what a
live process is still writing is kept; the removal is reported; leftovers never count as stored data."""

import logging
import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

from ldvsurvey.store import blobs

#: a process that does what an upload does up to the moment it is killed: members inflated into a
#: staging folder under <data>/tmp, one blob being written in the blob folder (its fsync never returns)
CRASHING_UPLOAD = r"""
import sys, time
from pathlib import Path
from ldvsurvey.io.drivelog import BundleFiles
from ldvsurvey.store import blobs
from ldvsurvey.store.db import session_scope, upgrade_head

data = Path(sys.argv[1])
staged = BundleFiles.in_temp_folder(data / "tmp")
staged.write("imu.csv", iter([b"t_s,x\n" * 100_000]))
blobs._fsync = lambda path: time.sleep(3600)
url = f"sqlite:///{(data / 'ldvsurvey.db').resolve()}"
upgrade_head(url)
with session_scope(url) as s:
    w = blobs.Writer(s, data / "blobs")
    w.file(b"x" * 300_000, suffix="-ldv.csv")
    print("READY", flush=True)
    time.sleep(3600)
"""


def _crash_an_upload(data: Path) -> None:
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)}
    p = subprocess.Popen(
        [sys.executable, "-c", CRASHING_UPLOAD, str(data)], stdout=subprocess.PIPE, env=env, start_new_session=True
    )
    try:
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline and p.poll() is None:
            if p.stdout.readline().strip() == b"READY":
                break
        assert p.poll() is None, "the upload process died before it was killed"
    finally:
        os.kill(p.pid, signal.SIGKILL)  # kill -9 mid-upload
        p.wait()
    p.stdout.close()


def _leftovers(data: Path) -> tuple[list[Path], list[Path]]:
    folders = sorted((data / "tmp").glob("ldvs-bundle-*")) if (data / "tmp").exists() else []
    parts = sorted((data / "blobs").rglob("*.part")) if (data / "blobs").exists() else []
    return folders, parts


def _age(paths, seconds: float) -> None:
    """Make the crash ``seconds`` old (a restart does not come within the same second)."""
    t = time.time() - seconds
    for p in paths:
        for q in [p, *p.rglob("*")] if p.is_dir() else [p]:
            os.utime(q, (t, t), follow_symlinks=False)


@pytest.fixture
def sqlite_settings(settings):
    if settings.database_url:
        pytest.skip("the crash is simulated against the SQLite data folder")
    return settings


def test_start_removes_what_a_killed_upload_left_and_keeps_live_uploads(sqlite_settings, monkeypatch, caplog):
    from fastapi.testclient import TestClient

    from ldvsurvey.api.app import create_app
    from ldvsurvey.io.drivelog import BundleFiles

    data = Path(sqlite_settings.data_dir)
    _crash_an_upload(data)
    folders, parts = _leftovers(data)
    assert len(folders) == 1 and len(parts) == 1  # what the crash left, as the probe found it
    _age(folders + parts, 120)

    # an upload of a live process in the same data folder, being staged and stored right now
    live = BundleFiles.in_temp_folder(data / "tmp")
    live.write("imu.csv", iter([b"t_s\n1\n"]))
    _age([live.folder.path], 120)  # even an old live one is kept: its process holds it
    gate = threading.Event()
    monkeypatch.setattr(blobs, "_fsync", lambda path: gate.wait(30))
    from ldvsurvey.store.db import session_scope

    url = sqlite_settings.resolved_database_url()
    try:
        with session_scope(url) as sess:
            w = blobs.Writer(sess, data / "blobs")
            w.file(b"y" * 1000, suffix="-gnss.nmea")
            live_part = next(p for p in (data / "blobs").rglob("*.part") if p not in parts)
            _age([live_part], 120)
            with caplog.at_level(logging.INFO, logger="ldvsurvey"):
                app = create_app(sqlite_settings)
            left_folders, left_parts = _leftovers(data)
            assert left_folders == [live.folder.path]
            assert left_parts == [live_part]
            gate.set()
            w.done()
            sess.rollback()
    finally:
        gate.set()
    said = [r.getMessage() for r in caplog.records if "left by a stopped process" in r.getMessage()]
    assert said and "1 staging folder" in said[0] and "1 .part blob" in said[0], said
    with TestClient(app) as c:
        r = c.get("/api/admin/storage")
        assert r.status_code == 200, r.text
        st = r.json()
        assert st["leftovers_removed"]["staging_folders"] == 1
        assert st["leftovers_removed"]["part_blobs"] == 1
        assert st["leftovers_removed"]["bytes"] >= 600_000 + 300_000  # the staged member and the blob
        assert st["stored_bytes"] == 0  # no log stored: leftovers are never counted as data
        assert st["leftovers_now"]["staging_folders"] == 1  # the live upload, named as in progress


def test_periodic_clean_and_cli(sqlite_settings, capsys):
    from ldvsurvey.cli import main
    from ldvsurvey.jobs.runner import Consumer, JobRunner

    data = Path(sqlite_settings.data_dir)
    _crash_an_upload(data)
    _age([p for group in _leftovers(data) for p in group], 120)
    url = sqlite_settings.resolved_database_url()
    from ldvsurvey.store.leftovers import clean_leftovers

    cleaned = []
    c = Consumer(
        JobRunner(url, sqlite_settings),
        consume=False,
        housekeeping=lambda: cleaned.append(clean_leftovers(sqlite_settings)),
        housekeeping_every_s=0.05,
    )

    c.start()
    try:
        deadline = time.monotonic() + 10
        while time.monotonic() < deadline and not cleaned:
            time.sleep(0.05)
    finally:
        c.stop()
    assert cleaned and cleaned[0].staging_folders == 1 and cleaned[0].part_blobs == 1
    assert _leftovers(data) == ([], [])

    _crash_an_upload(data)
    _age([p for group in _leftovers(data) for p in group], 120)
    os.environ["LDVSURVEY_DATA_DIR"] = str(data)
    try:
        from ldvsurvey.settings import get_settings

        get_settings.cache_clear()
        assert main(["clean"]) == 0
    finally:
        del os.environ["LDVSURVEY_DATA_DIR"]
        get_settings.cache_clear()
    out = capsys.readouterr().out
    assert "removed 1 staging folder" in out and "1 .part blob" in out, out
    assert _leftovers(data) == ([], [])


def test_a_lock_decides_and_only_lockless_leftovers_wait_for_their_age(sqlite_settings):
    """A crashed upload's staging folder goes at the next clean however young (its lock is free at
    once). A staging folder without a lock (an older version's, or one created a moment ago, just
    before its lock) is kept until older than GRACE_S; a ``.part`` nobody holds until older than
    PART_GRACE_S (it is created a moment before its writer locks it)."""
    from ldvsurvey.store.leftovers import GRACE_S, PART_GRACE_S, clean_leftovers

    data = Path(sqlite_settings.data_dir)
    _crash_an_upload(data)
    crashed_part = _leftovers(data)[1]
    old_folder = data / "tmp" / "ldvs-bundle-oldformat"
    old_folder.mkdir()
    (old_folder / "0-imu.csv").write_bytes(b"1" * 1000)
    old_part = data / "blobs" / "ab" / "ab12-imu.csv.part"
    old_part.parent.mkdir(parents=True, exist_ok=True)
    old_part.write_bytes(b"2" * 500)
    _age([old_folder], GRACE_S / 2)
    _age(crashed_part, 2 * PART_GRACE_S)
    first = clean_leftovers(sqlite_settings)
    assert (first.staging_folders, first.part_blobs) == (1, 1)  # the crash's
    assert _leftovers(data) == ([old_folder], [old_part])
    _age([old_folder, old_part], GRACE_S + 1)
    second = clean_leftovers(sqlite_settings)
    assert (second.staging_folders, second.part_blobs, second.bytes) == (1, 1, 1500)
    assert _leftovers(data) == ([], [])


#: a process that stores a log (its blobs written and renamed) and is killed before the commit
KILLED_BEFORE_COMMIT = r"""
import sys, time
from pathlib import Path
from ldvsurvey.io.drivelog import parse_files
from ldvsurvey.io.quality import quality_report
from ldvsurvey.store import blobs
from ldvsurvey.store.db import session_scope
from ldvsurvey.store.logs import store_log
from tests.bundles import make_bundle

blobs.INLINE_MAX_BYTES = 0
url = f"sqlite:///{(Path(sys.argv[1]) / 'ldvsurvey.db').resolve()}"
log = parse_files(make_bundle(seed=int(sys.argv[2])))
with session_scope(url) as s:
    store_log(s, log, quality_report(log))
    print("READY", flush=True)
    time.sleep(3600)
"""


def test_blobs_of_a_store_killed_before_its_commit_go_once_old(sqlite_settings, monkeypatch):
    from ldvsurvey.io.drivelog import parse_files
    from ldvsurvey.io.quality import quality_report
    from ldvsurvey.store.db import session_scope, upgrade_head
    from ldvsurvey.store.leftovers import UNREFERENCED_GRACE_S, clean_leftovers
    from ldvsurvey.store.logs import load_drivelog, store_log
    from tests.bundles import make_bundle

    data = Path(sqlite_settings.data_dir)
    url = sqlite_settings.resolved_database_url()
    upgrade_head(url)
    monkeypatch.setattr(blobs, "INLINE_MAX_BYTES", 0)
    kept = parse_files(make_bundle(seed=91))
    with session_scope(url) as s:
        kept_id = store_log(s, kept, quality_report(kept))[0].id
    stored = sorted(p for p in (data / "blobs").rglob("*") if p.is_file())
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)}
    p = subprocess.Popen([sys.executable, "-c", KILLED_BEFORE_COMMIT, str(data), "92"], stdout=subprocess.PIPE, env=env)
    try:
        assert p.stdout.readline().strip() == b"READY"
    finally:
        os.kill(p.pid, signal.SIGKILL)
        p.wait()
        p.stdout.close()
    orphans = sorted(set(q for q in (data / "blobs").rglob("*") if q.is_file()) - set(stored))
    assert len(orphans) == 7  # four originals and three arrays, complete, named by no row
    _age(orphans, UNREFERENCED_GRACE_S / 2)
    assert clean_leftovers(sqlite_settings).unreferenced_blobs == 0  # maybe a commit still to come
    _age(orphans + stored, UNREFERENCED_GRACE_S + 60)
    size = sum(q.stat().st_size for q in orphans)
    gone = clean_leftovers(sqlite_settings)
    assert gone.unreferenced_blobs == 7 and gone.bytes == size
    assert sorted(q for q in (data / "blobs").rglob("*") if q.is_file()) == stored  # the stored log's stay
    with session_scope(url) as s:
        assert load_drivelog(s, kept_id).sha256 == kept.sha256
