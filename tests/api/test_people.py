"""People and access: admin-managed users, projects and memberships (API and CLI), passwords,
API tokens, an admin's default project, and login throttling per account and per client."""

import datetime as dt

import pytest
from fastapi.testclient import TestClient

from ldvsurvey.api.app import create_app
from ldvsurvey.store.db import session_scope
from ldvsurvey.store.models import ApiToken
from tests.bundles import make_bundle

ADMIN = {"username": "root", "password": "first-admin-pw"}


def _files(seed):
    return [("files", (n, d, "x")) for n, d in make_bundle(seed=seed, n_imu=300).items()]


@pytest.fixture
def st(settings):
    return settings.model_copy(
        update={
            "auth_enabled": True,
            "admin_user": ADMIN["username"],
            "admin_password": ADMIN["password"],
            "login_failures_per_account": 5,
            "login_failures_per_client": 12,
        }
    )


def login(c, username, password):
    r = c.post("/api/login", json={"username": username, "password": password})
    return r, ({"X-CSRF-Token": r.json()["csrf"]} if r.status_code == 200 else {})


def test_admin_creates_user_and_project_user_sees_only_that(st):
    with TestClient(create_app(st)) as c:
        r, h = login(c, **ADMIN)
        assert r.status_code == 200
        p = c.post("/api/admin/projects", json={"name": "Levelling 2026"}, headers=h)
        assert p.status_code == 201, p.text
        pid = p.json()["id"]
        u = c.post(
            "/api/admin/users",
            json={"username": "carol", "password": "carol-password", "project_ids": [pid]},
            headers=h,
        )
        assert u.status_code == 201, u.text
        assert [x["name"] for x in u.json()["projects"]] == ["Levelling 2026"]
        assert (
            c.post("/api/admin/users", json={"username": "carol", "password": "another-pw"}, headers=h).status_code
            == 409
        )
        assert c.post("/api/admin/users", json={"username": "dave", "password": "short"}, headers=h).status_code == 422
        # an admin's upload without project_id goes to a project of theirs, not nowhere
        own = c.post("/api/logs", files=_files(60), headers=h)
        assert own.status_code == 201 and own.json()["project_id"] is not None
        assert own.json()["project_id"] != pid
        shared = c.post("/api/logs", files=_files(61), data={"project_id": str(pid)}, headers=h)
        assert shared.status_code == 201 and shared.json()["project_id"] == pid
        c.post("/api/logout", headers=h)

        r, h2 = login(c, "carol", "carol-password")
        assert r.status_code == 200
        assert [p["name"] for p in c.get("/api/projects").json()] == ["Levelling 2026"]
        assert [lg["id"] for lg in c.get("/api/logs").json()] == [shared.json()["id"]]
        assert c.get("/api/me").json()["admin"] is False
        assert c.get("/api/admin/users").status_code == 403
        assert c.post("/api/admin/projects", json={"name": "x"}, headers=h2).status_code == 403


def test_password_change_and_disable(st):
    with TestClient(create_app(st)) as c:
        _, h = login(c, **ADMIN)
        uid = c.post("/api/admin/users", json={"username": "erin", "password": "erin-password"}, headers=h).json()["id"]
        c.post("/api/logout", headers=h)
        _, he = login(c, "erin", "erin-password")
        assert (
            c.post(
                "/api/password", json={"old_password": "nope", "new_password": "erin-new-password"}, headers=he
            ).status_code
            == 403
        )
        assert (
            c.post(
                "/api/password", json={"old_password": "erin-password", "new_password": "erin-new-password"}, headers=he
            ).status_code
            == 200
        )
        assert c.get("/api/me").status_code == 401  # every session ended
        assert login(c, "erin", "erin-password")[0].status_code == 401
        r, he = login(c, "erin", "erin-new-password")
        assert r.status_code == 200
        tok = c.post("/api/tokens", json={"name": "laptop"}, headers=he).json()["token"]
        c.post("/api/logout", headers=he)
        _, h = login(c, **ADMIN)
        assert c.patch(f"/api/admin/users/{uid}", json={"disabled": True}, headers=h).status_code == 200
        c.post("/api/logout", headers=h)
        assert login(c, "erin", "erin-new-password")[0].status_code == 401
        assert c.get("/api/logs", headers={"Authorization": f"Bearer {tok}"}).status_code == 401


def test_tokens_listed_named_expiring_revocable(st):
    with TestClient(create_app(st)) as c:
        _, h = login(c, **ADMIN)
        made = c.post("/api/tokens", json={"name": "field laptop", "expires_days": 30}, headers=h)
        assert made.status_code == 201
        secret, tid = made.json()["token"], made.json()["id"]
        exp = dt.datetime.fromisoformat(made.json()["expires_at"])
        assert abs((exp - dt.datetime.now(dt.UTC)).total_seconds() - 30 * 86400) < 120
        listed = c.get("/api/tokens").json()
        assert [t["name"] for t in listed] == ["field laptop"] and "token" not in listed[0]
        bearer = {"Authorization": f"Bearer {secret}"}
        c.post("/api/logout", headers=h)
        assert c.get("/api/logs", headers=bearer).status_code == 200
        assert c.delete(f"/api/tokens/{tid}", headers=bearer).status_code == 204
        assert c.get("/api/logs", headers=bearer).status_code == 401
        # an expired token stops working
        _, h = login(c, **ADMIN)
        old = c.post("/api/tokens", json={"name": "old", "expires_days": 1}, headers=h).json()
        with session_scope(c.app.state.database_url) as s:
            s.get(ApiToken, old["id"]).expires_at = dt.datetime.now(dt.UTC) - dt.timedelta(seconds=1)
        assert c.get("/api/logs", headers={"Authorization": f"Bearer {old['token']}"}).status_code == 401
        assert [t["expired"] for t in c.get("/api/tokens").json()] == [True]


def test_login_throttle_per_account_not_fooled_by_forwarded_for(st):
    with TestClient(create_app(st)) as c:
        _, h = login(c, **ADMIN)
        c.post("/api/admin/users", json={"username": "frank", "password": "frank-password"}, headers=h)
        c.post("/api/logout", headers=h)
        # failures below the limit do not stop the right password (good logins are not counted)
        for _ in range(3):
            assert login(c, "frank", "wrong-password")[0].status_code == 401
        r, hf = login(c, "frank", "frank-password")
        assert r.status_code == 200
        c.post("/api/logout", headers=hf)
        # a rotating X-Forwarded-For does not reset anything
        codes = [
            c.post(
                "/api/login",
                json={"username": "frank", "password": f"guess{k}"},
                headers={"X-Forwarded-For": f"10.0.{k}.1"},
            ).status_code
            for k in range(8)
        ]
        assert codes[:5] == [401] * 5 and set(codes[5:]) == {429}
        assert login(c, "frank", "frank-password")[0].status_code == 429  # the account waits
        assert login(c, **ADMIN)[0].status_code == 200  # other accounts do not


def test_login_throttle_per_client_shared_between_processes(st):
    app1, app2 = create_app(st), create_app(st)  # two API processes on one database
    with TestClient(app1) as c1, TestClient(app2) as c2:
        for k in range(12):  # spread over many accounts: only the client counter fills
            c = c1 if k % 2 else c2
            assert c.post("/api/login", json={"username": f"user{k}", "password": "x"}).status_code == 401
        assert c1.post("/api/login", json=ADMIN).status_code == 429
        assert c2.post("/api/login", json=ADMIN).status_code == 429


def test_forwarded_for_believed_only_from_configured_proxy(st):
    trusted = st.model_copy(update={"trusted_proxies": "127.0.0.1"})
    with TestClient(create_app(trusted), client=("127.0.0.1", 50000)) as c:
        for k in range(12):
            c.post(
                "/api/login", json={"username": f"u{k}", "password": "x"}, headers={"X-Forwarded-For": "203.0.113.7"}
            )
        blocked = c.post("/api/login", json=ADMIN, headers={"X-Forwarded-For": "203.0.113.7"})
        other = c.post("/api/login", json=ADMIN, headers={"X-Forwarded-For": "198.51.100.2"})
        assert blocked.status_code == 429 and other.status_code == 200
    with TestClient(create_app(st), client=("127.0.0.1", 50000)) as c:  # no proxy configured: header ignored
        for k in range(12):
            c.post(
                "/api/login", json={"username": f"v{k}", "password": "x"}, headers={"X-Forwarded-For": f"203.0.113.{k}"}
            )
        assert c.post("/api/login", json=ADMIN, headers={"X-Forwarded-For": "198.51.100.9"}).status_code == 429


def test_cli_users_and_projects(tmp_path, monkeypatch, capsys):
    from ldvsurvey.cli import main
    from ldvsurvey.settings import get_settings

    monkeypatch.setenv("LDVSURVEY_DATA_DIR", str(tmp_path / "d"))
    monkeypatch.delenv("LDVSURVEY_DATABASE_URL", raising=False)
    monkeypatch.setenv("PW", "grace-password")
    get_settings.cache_clear()
    try:
        assert main(["project", "add", "Gravity 2026"]) == 0
        assert main(["user", "add", "grace", "--password-env", "PW", "--project", "Gravity 2026"]) == 0
        assert main(["user", "add", "grace", "--password-env", "PW"]) == 2  # exists
        assert main(["user", "add", "heidi", "--admin", "--password-env", "PW"]) == 0
        assert main(["project", "member", "Gravity 2026", "heidi"]) == 0
        capsys.readouterr()
        assert main(["user", "list"]) == 0
        out = capsys.readouterr().out
        assert "grace\t-\tGravity 2026" in out and "heidi\tadmin\t" in out
        assert main(["user", "disable", "grace"]) == 0
        assert main(["project", "list"]) == 0
        assert "Gravity 2026\tgrace, heidi" in capsys.readouterr().out
        st = get_settings().model_copy(update={"auth_enabled": True})
        with TestClient(create_app(st)) as c:
            assert login(c, "grace", "grace-password")[0].status_code == 401  # disabled
            r, _ = login(c, "heidi", "grace-password")
            assert r.status_code == 200 and c.get("/api/me").json()["admin"] is True
    finally:
        get_settings.cache_clear()


def test_login_throttle_in_redis_when_configured(st):
    """With LDVSURVEY_REDIS_URL the counters live in Redis: two API processes see the same counts."""
    import os

    import redis

    url = os.environ.get("LDVSURVEY_TEST_REDIS_URL", "redis://127.0.0.1:6379/15")
    try:
        redis.Redis.from_url(url, socket_connect_timeout=1).ping()
    except redis.RedisError:
        pytest.skip(f"no Redis at {url}")
    rst = st.model_copy(update={"redis_url": url, "run_consumer": False})
    app1, app2 = create_app(rst), create_app(rst)
    with TestClient(app1) as c1, TestClient(app2) as c2:
        for k in range(5):
            (c1 if k % 2 else c2).post("/api/login", json={"username": ADMIN["username"], "password": f"no{k}"})
        assert c1.post("/api/login", json=ADMIN).status_code == 429
        assert c2.post("/api/login", json=ADMIN).status_code == 429
        with session_scope(app1.state.database_url) as s:  # nothing was counted in the database
            from ldvsurvey.store.models import LoginFailure

            assert s.query(LoginFailure).count() == 0
