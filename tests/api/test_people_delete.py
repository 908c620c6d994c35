"""Deleting users and projects (API and CLI, saying what happens to their logs), names with
bidirectional controls refused, and an expired API token refused as expired."""

import datetime as dt

import pytest
from fastapi.testclient import TestClient

from ldvsurvey.api.app import create_app
from ldvsurvey.store.db import session_scope
from ldvsurvey.store.models import ApiToken, Job, Log, LogFile
from tests.api.test_people import ADMIN, _files, login


@pytest.fixture
def st(settings):
    return settings.model_copy(
        update={"auth_enabled": True, "admin_user": ADMIN["username"], "admin_password": ADMIN["password"]}
    )


def _count(url, model, **where):
    from sqlalchemy import func, select

    with session_scope(url) as s:
        q = select(func.count()).select_from(model)
        for k, v in where.items():
            q = q.where(getattr(model, k) == v)
        return s.scalar(q)


def test_delete_user_keeps_their_logs_in_the_project(st):
    with TestClient(create_app(st)) as c:
        _, h = login(c, **ADMIN)
        pid = c.post("/api/admin/projects", json={"name": "Lines 2026"}, headers=h).json()["id"]
        uid = c.post(
            "/api/admin/users",
            json={"username": "ivan", "password": "ivan-password", "project_ids": [pid]},
            headers=h,
        ).json()["id"]
        c.post("/api/logout", headers=h)
        _, hi = login(c, "ivan", "ivan-password")
        log = c.post("/api/logs", files=_files(61), data={"project_id": str(pid)}, headers=hi)
        assert log.status_code == 201, log.text
        tok = c.post("/api/tokens", json={"name": "car"}, headers=hi).json()["token"]
        c.post("/api/logout", headers=hi)
        _, h = login(c, **ADMIN)
        me = c.get("/api/me").json()
        admin_id = next(u["id"] for u in c.get("/api/admin/users").json() if u["username"] == me["user"])
        assert c.delete(f"/api/admin/users/{admin_id}", headers=h).status_code == 409  # not oneself
        r = c.delete(f"/api/admin/users/{uid}", headers=h)
        assert r.status_code == 200, r.text
        assert r.json()["deleted"] == "ivan" and r.json()["tokens_deleted"] == 1
        assert "stay in their projects" in r.json()["effect"]
        assert "ivan" not in [u["username"] for u in c.get("/api/admin/users").json()]
        assert c.get("/api/logs", headers={"Authorization": f"Bearer {tok}"}).status_code == 401
        # the log stays, in its project, seen by the admin
        assert c.get(f"/api/logs/{log.json()['id']}").status_code == 200
        proj = next(p for p in c.get("/api/admin/projects").json() if p["id"] == pid)
        assert proj["members"] == [] and proj["n_logs"] == 1
        assert c.delete(f"/api/admin/users/{uid}", headers=h).status_code == 404


def test_delete_project_deletes_its_logs_files_and_jobs_only(st):
    with TestClient(create_app(st)) as c:
        _, h = login(c, **ADMIN)
        a = c.post("/api/admin/projects", json={"name": "Gone"}, headers=h).json()["id"]
        b = c.post("/api/admin/projects", json={"name": "Kept"}, headers=h).json()["id"]
        la = c.post("/api/logs", files=_files(62), data={"project_id": str(a)}, headers=h).json()["id"]
        lb = c.post("/api/logs", files=_files(63), data={"project_id": str(b)}, headers=h).json()["id"]
        url = c.app.state.database_url
        with session_scope(url) as s:  # a finished job on each log (what a worker would leave)
            s.add_all(
                [
                    Job(pipeline="height", log_ids=[la], parameters={}, status="succeeded"),
                    Job(pipeline="height", log_ids=[lb], parameters={}, status="succeeded"),
                ]
            )
        files_a = _count(url, LogFile, log_id=la)
        assert files_a > 0
        assert next(p for p in c.get("/api/admin/projects").json() if p["id"] == a)["n_logs"] == 1
        r = c.delete(f"/api/admin/projects/{a}", headers=h)
        assert r.status_code == 200, r.text
        assert r.json() == {
            "deleted": "Gone",
            "logs_deleted": 1,
            "jobs_deleted": 1,
            "effect": r.json()["effect"],
        }
        assert "logs are deleted" in r.json()["effect"]
        assert c.get(f"/api/logs/{la}").status_code == 404 and c.get(f"/api/logs/{lb}").status_code == 200
        assert _count(url, LogFile, log_id=la) == 0 and _count(url, Log, id=lb) == 1
        assert _count(url, Job) == 1
        assert [p["name"] for p in c.get("/api/admin/projects").json()].count("Gone") == 0
        assert c.delete(f"/api/admin/projects/{a}", headers=h).status_code == 404


@pytest.mark.parametrize("ch", ["\u202e", "\u2066", "\u200f", "\u061c", "\x07"])
def test_names_with_bidi_controls_refused(st, ch):
    with TestClient(create_app(st)) as c:
        _, h = login(c, **ADMIN)
        r = c.post("/api/admin/users", json={"username": f"eve{ch}lin", "password": "eve-password"}, headers=h)
        assert r.status_code == 422, r.text
        assert f"U+{ord(ch):04X}" in r.text and "username" in r.text
        r = c.post("/api/admin/projects", json={"name": f"Survey {ch}2026"}, headers=h)
        assert r.status_code == 422 and f"U+{ord(ch):04X}" in r.text
        r = c.post("/api/tokens", json={"name": f"lap{ch}top"}, headers=h)
        assert r.status_code == 422 and f"U+{ord(ch):04X}" in r.text
        assert [u["username"] for u in c.get("/api/admin/users").json()] == [ADMIN["username"]]
    # an ordinary non-Latin name is fine
    with TestClient(create_app(st)) as c:
        _, h = login(c, **ADMIN)
        assert c.post("/api/admin/projects", json={"name": "Съёмка 2026 עברית"}, headers=h).status_code == 201


def test_expired_token_is_called_expired(st):
    with TestClient(create_app(st)) as c:
        _, h = login(c, **ADMIN)
        old = c.post("/api/tokens", json={"name": "old laptop", "expires_days": 1}, headers=h).json()
        with session_scope(c.app.state.database_url) as s:
            s.get(ApiToken, old["id"]).expires_at = dt.datetime(2026, 1, 2, 3, 4, tzinfo=dt.UTC)
        c.post("/api/logout", headers=h)
        r = c.get("/api/logs", headers={"Authorization": f"Bearer {old['token']}"})
        assert r.status_code == 401
        assert "API token 'old laptop' expired on 2026-01-02 03:04 UTC" in r.json()["detail"]
        r = c.get("/api/logs", headers={"Authorization": "Bearer ldvs_not-a-token"})
        assert r.status_code == 401 and "expired" not in r.text


def test_cli_deletes_users_and_projects(tmp_path, monkeypatch, capsys):
    from ldvsurvey.cli import main
    from ldvsurvey.settings import get_settings

    monkeypatch.setenv("LDVSURVEY_DATA_DIR", str(tmp_path / "d"))
    monkeypatch.delenv("LDVSURVEY_DATABASE_URL", raising=False)
    monkeypatch.setenv("PW", "judy-password")
    get_settings.cache_clear()
    try:
        assert main(["project", "add", "Old lines"]) == 0
        assert main(["user", "add", "judy", "--password-env", "PW", "--project", "Old lines"]) == 0
        capsys.readouterr()
        assert main(["user", "delete", "judy"]) == 2  # says what would happen, does nothing
        err = capsys.readouterr().err
        assert "stay in their projects" in err and "--yes" in err
        assert main(["user", "delete", "judy", "--yes"]) == 0
        assert "user 'judy' deleted" in capsys.readouterr().out
        assert main(["user", "delete", "judy", "--yes"]) == 2  # no such user
        assert main(["project", "delete", "Old lines"]) == 2
        assert "(0 logs)" in capsys.readouterr().err
        assert main(["project", "delete", "Old lines", "--yes"]) == 0
        assert "deleted with 0 logs and 0 jobs" in capsys.readouterr().out
        assert main(["project", "list"]) == 0
        assert "Old lines" not in capsys.readouterr().out
        assert main(["user", "add", "mal\u202elory", "--password-env", "PW"]) == 2
        assert "U+202E" in capsys.readouterr().err
    finally:
        get_settings.cache_clear()
