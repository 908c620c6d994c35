"""A project's base stations (``/api/projects/{id}/ties``): entered once, offered to gravity jobs as
``base_ties``; refused input names the field and stores nothing; access as for the project's logs."""

import json

import pytest
from fastapi.testclient import TestClient
from sqlalchemy import func, select

from ldvsurvey.api.app import create_app
from ldvsurvey.pipelines.gravity.network import parse_ties, tie_sigmas_mgal
from ldvsurvey.pipelines.registry import get
from ldvsurvey.store.db import session_scope
from ldvsurvey.store.models import Project, ProjectTie, User
from ldvsurvey.store.users import create_user, get_or_create_project, new_api_token

STATION = {
    "name": "Changsha AG-1",
    "lat_deg": 28.4861,
    "lon_deg": 113.0623,
    "h_m": 120.5,
    "g_mgal": 979137.254,
    "sigma_mgal": 0.005,
    "note": "FG5 2021",
}


def _count(url):
    with session_scope(url) as s:
        return s.scalar(select(func.count()).select_from(ProjectTie))


@pytest.fixture
def open_app(client):
    with session_scope(client.app_state.database_url) as s:
        pid = get_or_create_project(s, "Survey").id
    return client, pid


def test_enter_list_change_delete(open_app):
    c, pid = open_app
    r = c.post(f"/api/projects/{pid}/ties", json=STATION)
    assert r.status_code == 201, r.text
    one = r.json()
    assert {k: one[k] for k in STATION} == STATION
    # a longitude east of 180° comes back as the navigation's negative longitude, as base_ties parses it
    r = c.post(f"/api/projects/{pid}/ties", json={**STATION, "name": "B2", "lon_deg": 250.0, "note": ""})
    assert r.status_code == 201 and r.json()["lon_deg"] == pytest.approx(-110.0)
    got = c.get(f"/api/projects/{pid}/ties").json()
    assert [t["name"] for t in got["ties"]] == ["Changsha AG-1", "B2"]
    # the base_ties text is the gravity pipeline's parameter: it validates, and parses back to the values
    assert get("gravity").validate({"base_ties": got["base_ties"]}).base_ties == got["base_ties"]
    assert parse_ties(got["base_ties"]) == [(t["lat_deg"], t["lon_deg"], t["h_m"], t["g_mgal"]) for t in got["ties"]]
    assert tie_sigmas_mgal(got["base_ties"]) == [t["sigma_mgal"] for t in got["ties"]]  # each station's own weight
    r = c.put(f"/api/projects/{pid}/ties/{one['id']}", json={**STATION, "h_m": 151.0})
    assert r.status_code == 200 and r.json()["h_m"] == 151.0
    assert c.delete(f"/api/projects/{pid}/ties/{one['id']}").status_code == 204
    assert [t["name"] for t in c.get(f"/api/projects/{pid}/ties").json()["ties"]] == ["B2"]
    assert c.delete(f"/api/projects/{pid}/ties/{one['id']}").status_code == 404
    assert c.get("/api/projects/999/ties").status_code == 404


@pytest.mark.parametrize(
    "change, field, words",
    [
        ({"lat_deg": 95.0}, "lat_deg", "latitude 95"),
        ({"lon_deg": -200.0}, "lon_deg", "longitude -200"),
        ({"h_m": 12000.0}, "h_m", "ellipsoidal height 12000"),
        ({"g_mgal": 13.2}, "g_mgal", "not an absolute gravity value"),
        ({"sigma_mgal": 0.0}, "sigma_mgal", "1-σ"),
        ({"sigma_mgal": 150.0}, "sigma_mgal", "1-σ"),
        ({"name": "  "}, "name", "name"),
        ({"name": "A;B"}, "name", "';'"),
    ],
)
def test_bad_station_refused_naming_the_field(open_app, change, field, words):
    c, pid = open_app
    r = c.post(f"/api/projects/{pid}/ties", json={**STATION, **change})
    assert r.status_code == 422, r.text
    err = r.json()["error"]
    assert err["field"] == field and words in err["message"], err
    assert _count(c.app_state.database_url) == 0  # nothing stored


def test_non_numbers_and_unknown_keys_refused(open_app):
    c, pid = open_app
    for body in ({**STATION, "g_mgal": "heavy"}, {**STATION, "colour": "red"}, {k: STATION[k] for k in ("name",)}):
        r = c.post(f"/api/projects/{pid}/ties", json=body)
        assert r.status_code == 422, r.text
    # NaN as Python's json writes it
    r = c.post(
        f"/api/projects/{pid}/ties",
        content='{"name":"N","lat_deg":NaN,"lon_deg":1,"h_m":1,"g_mgal":979000,"sigma_mgal":0.1}',
        headers={"content-type": "application/json"},
    )
    assert r.status_code == 422 and "lat_deg" in r.text
    assert _count(c.app_state.database_url) == 0


def test_a_second_station_of_the_same_name_is_refused(open_app):
    c, pid = open_app
    assert c.post(f"/api/projects/{pid}/ties", json=STATION).status_code == 201
    r = c.post(f"/api/projects/{pid}/ties", json={**STATION, "h_m": 3.0})
    assert r.status_code == 409 and r.json()["error"]["field"] == "name"
    other = c.post(f"/api/projects/{pid}/ties", json={**STATION, "name": "B2"}).json()
    r = c.put(f"/api/projects/{pid}/ties/{other['id']}", json=STATION)  # renamed onto the first
    assert r.status_code == 409
    assert _count(c.app_state.database_url) == 2
    assert [t["h_m"] for t in c.get(f"/api/projects/{pid}/ties").json()["ties"]] == [120.5, 120.5]


@pytest.fixture
def two_projects(settings):
    st = settings.model_copy(
        update={"auth_enabled": True, "demo_mode": True, "admin_user": "admin", "admin_password": "s3cret-admin"}
    )
    app = create_app(st)
    url = app.state.database_url
    with session_scope(url) as s:
        a = create_user(s, "alice", "alice-pw", project="Project A")
        b = create_user(s, "bob", "bob-pw", project="Project B")
        ha = {"Authorization": f"Bearer {new_api_token(s, a, 't')}"}
        hb = {"Authorization": f"Bearer {new_api_token(s, b, 't')}"}
        pa = s.scalar(select(Project).where(Project.name == "Project A")).id
        demo_p = s.scalar(select(Project).where(Project.name == "Demo survey")).id
        admin = s.scalar(select(User).where(User.username == "admin"))
        hadm = {"Authorization": f"Bearer {new_api_token(s, admin, 't')}"}
    with TestClient(app) as c:
        yield c, url, ha, hb, hadm, pa, demo_p


def test_other_projects_and_the_demo_account(two_projects):
    c, url, ha, hb, hadm, pa, demo_p = two_projects
    t = c.post(f"/api/projects/{pa}/ties", headers=ha, json=STATION)
    assert t.status_code == 201
    tid = t.json()["id"]
    # bob is no member of A: nothing to see or change, as for A's logs (404, no existence leak)
    assert c.get(f"/api/projects/{pa}/ties", headers=hb).status_code == 404
    assert c.post(f"/api/projects/{pa}/ties", headers=hb, json={**STATION, "name": "x"}).status_code == 404
    assert c.put(f"/api/projects/{pa}/ties/{tid}", headers=hb, json=STATION).status_code == 404
    assert c.delete(f"/api/projects/{pa}/ties/{tid}", headers=hb).status_code == 404
    assert _count(url) == 1
    # a visitor of the demo (no session) sees the demo project's stations, cannot touch the operator's …
    op = c.post(f"/api/projects/{demo_p}/ties", headers=hadm, json=STATION).json()
    assert c.get(f"/api/projects/{demo_p}/ties").json()["ties"][0]["name"] == STATION["name"]
    for r in (
        c.delete(f"/api/projects/{demo_p}/ties/{op['id']}"),
        c.put(f"/api/projects/{demo_p}/ties/{op['id']}", json={**STATION, "h_m": 1.0}),
    ):
        assert r.status_code == 403 and "read-only" in r.json()["detail"], r.text
    assert c.get(f"/api/projects/{demo_p}/ties").json()["ties"][0]["h_m"] == STATION["h_m"]
    # … and changes the ones it entered (creating is not changing what others made)
    mine = c.post(f"/api/projects/{demo_p}/ties", json={**STATION, "name": "visitor's"})
    assert mine.status_code == 201, mine.text
    assert c.delete(f"/api/projects/{demo_p}/ties/{mine.json()['id']}").status_code == 204
    assert c.get(f"/api/projects/{pa}/ties").status_code == 404  # the demo is no member of A


def test_cli_ties(tmp_path, monkeypatch, capsys):
    """``ldv-survey ties list|add|delete``: the same checks (exit 2 naming the field, nothing stored)."""
    from ldvsurvey.cli import main
    from ldvsurvey.settings import get_settings

    monkeypatch.setenv("LDVSURVEY_DATA_DIR", str(tmp_path / "d"))
    monkeypatch.delenv("LDVSURVEY_DATABASE_URL", raising=False)
    get_settings.cache_clear()
    try:
        assert main(["project", "add", "Gravity 2026"]) == 0
        args = ["28.4861", "113.0623", "120.5", "979137.254", "0.005"]
        assert main(["ties", "add", "Gravity 2026", "AG-1", *args, "--note", "FG5 2021"]) == 0
        assert main(["ties", "add", "Gravity 2026", "AG-2", "28.5", "113.1", "120.5", "13.2", "0.005"]) == 2
        assert "g_mgal" in capsys.readouterr().err
        assert main(["ties", "add", "Gravity 2026", "AG-1", *args]) == 2  # the name is taken
        assert main(["ties", "add", "Nowhere", "AG-3", *args]) == 2
        capsys.readouterr()
        assert main(["ties", "list", "Gravity 2026"]) == 0
        out = capsys.readouterr().out
        assert out.count("\n") == 2 and "T1\t" in out and "AG-1" in out
        text = out.splitlines()[-1].removeprefix("base_ties=")
        assert parse_ties(text) == [(28.4861, 113.0623, 120.5, 979137.254)]
        assert main(["ties", "delete", "Gravity 2026", "AG-1"]) == 0
        assert main(["ties", "delete", "Gravity 2026", "AG-1"]) == 2
        capsys.readouterr()
        assert main(["ties", "list", "Gravity 2026"]) == 0
        assert "no base station" in capsys.readouterr().out
    finally:
        get_settings.cache_clear()


def test_any_numbers_are_stored_within_the_bounds_or_refused_naming_a_field(open_app):
    """Random values (huge, tiny, NaN, infinite, out of every bound): never a server error; what is
    stored lies within the bounds of base_ties, and every refusal names one of the station's fields."""
    from hypothesis import HealthCheck, given, settings
    from hypothesis import strategies as st

    c, pid = open_app
    num = st.one_of(
        st.floats(allow_nan=True, allow_infinity=True), st.integers(-(10**20), 10**20), st.floats(-200.0, 400.0)
    )

    @given(lat=num, lon=num, h=num, g=st.one_of(num, st.floats(975000, 985000)), sig=num)
    @settings(max_examples=60, deadline=None, suppress_health_check=list(HealthCheck), database=None)
    def check(lat, lon, h, g, sig):
        body = {"name": "X", "lat_deg": lat, "lon_deg": lon, "h_m": h, "g_mgal": g, "sigma_mgal": sig}
        r = c.post(f"/api/projects/{pid}/ties", content=json.dumps(body), headers={"content-type": "application/json"})
        assert r.status_code in (201, 422), r.text
        if r.status_code == 422:
            err = r.json().get("error") or {}
            fields = {"lat_deg", "lon_deg", "h_m", "g_mgal", "sigma_mgal"}
            assert err.get("field") in fields or any(d["loc"][-1] in fields for d in r.json()["detail"]), r.text
            return
        t = r.json()
        assert -90 <= t["lat_deg"] <= 90 and -180 <= t["lon_deg"] <= 180 and -500 <= t["h_m"] <= 9000
        assert 976000 <= t["g_mgal"] <= 984000 and 0 < t["sigma_mgal"] <= 100
        assert c.delete(f"/api/projects/{pid}/ties/{t['id']}").status_code == 204

    check()


def test_deleting_the_project_deletes_its_stations(two_projects):
    c, url, ha, _, hadm, pa, _ = two_projects
    assert c.post(f"/api/projects/{pa}/ties", headers=ha, json=STATION).status_code == 201
    r = c.delete(f"/api/admin/projects/{pa}", headers=hadm)
    assert r.status_code == 200 and "base stations" in r.json()["effect"], r.text
    assert _count(url) == 0
