"""``ldv-survey serve`` hands its settings to the app as an object: it writes no environment variable."""

import os

from ldvsurvey import cli


def test_serve_demo_passes_settings_not_environment(tmp_path, monkeypatch):
    import uvicorn

    import ldvsurvey.api.app as app_module
    import ldvsurvey.demo as demo
    from ldvsurvey.settings import get_settings

    monkeypatch.setenv("LDVSURVEY_DATA_DIR", str(tmp_path / "data"))
    monkeypatch.delenv("LDVSURVEY_DATABASE_URL", raising=False)
    monkeypatch.delenv("LDVSURVEY_DEMO_MODE", raising=False)
    get_settings.cache_clear()
    seen = {}

    class FakeApp:
        class state:  # stands in for app.state
            database_url = "sqlite://"

            class runner:
                @staticmethod
                def enqueue(job_id):
                    pass

    def fake_create_app(settings=None):
        seen["settings"] = settings
        return FakeApp

    monkeypatch.setattr(app_module, "create_app", fake_create_app)
    monkeypatch.setattr(demo, "load_demo_survey", lambda url, data_dir, enqueue: seen.setdefault("demo", data_dir))
    monkeypatch.setattr(uvicorn, "run", lambda app, **kw: seen.setdefault("ran", app))
    before = dict(os.environ)
    try:
        assert cli.main(["serve", "--demo", "--port", "1"]) == 0
    finally:
        get_settings.cache_clear()
    assert dict(os.environ) == before
    assert seen["settings"].demo_mode is True
    assert seen["settings"].data_dir == tmp_path / "data"
    assert seen["demo"] == tmp_path / "data" and seen["ran"] is FakeApp
    assert get_settings().demo_mode is False  # the process-wide settings are untouched
