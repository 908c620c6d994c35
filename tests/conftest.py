import os

import pytest

# no background compile in the servers the tests start (in-process apps and subprocesses): each would
# compile on the shared cores, and a complete one prunes other versions' code from a shared cache
os.environ.setdefault("LDVSURVEY_BACKGROUND_WARMUP", "0")


@pytest.fixture
def settings(tmp_path, monkeypatch):
    """Settings pointing at a fresh data directory (and the CI-selected database, if any)."""
    from ldvsurvey.settings import Settings

    url = os.environ.get("LDVSURVEY_TEST_DATABASE_URL")
    s = Settings(
        data_dir=tmp_path / "data",
        database_url=url or None,
        auth_enabled=False,
        max_upload_bytes=5 * 1024 * 1024,
        max_unzipped_bytes=50 * 1024 * 1024,
        uploads_per_minute=1000,
    )
    if url:  # a shared server database: start from empty tables
        from tests.helpers.db import reset_database

        reset_database(url)
    return s


@pytest.fixture
def client(settings):
    from fastapi.testclient import TestClient

    from ldvsurvey.api.app import create_app

    app = create_app(settings)
    with TestClient(app) as c:
        c.app_state = app.state
        yield c


@pytest.fixture
def db_counts(client):
    """Callable returning the row counts of the log tables."""
    from ldvsurvey.store.db import session_scope
    from ldvsurvey.store.logs import count_rows

    def counts():
        with session_scope(client.app_state.database_url) as s:
            return count_rows(s)

    return counts
