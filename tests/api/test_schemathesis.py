"""Property-based run of every operation in the OpenAPI schema: no input may produce a 5xx."""

import pytest
import schemathesis
from hypothesis import HealthCheck, given, settings

from ldvsurvey.api.app import create_app
from ldvsurvey.settings import Settings

try:
    from schemathesis.checks import not_a_server_error
except ImportError:  # schemathesis 3
    from schemathesis.specs.openapi.checks import not_a_server_error  # type: ignore


@pytest.fixture(scope="module")
def api_schema(tmp_path_factory):
    d = tmp_path_factory.mktemp("schema")
    app = create_app(
        Settings(
            data_dir=d,
            auth_enabled=False,
            run_consumer=False,
            uploads_per_minute=100000,
            max_upload_bytes=2 * 1024 * 1024,
        )
    )
    return schemathesis.openapi.from_asgi("/openapi.json", app)


def test_no_server_error_on_any_operation(api_schema):
    ops = [r.ok() for r in api_schema.get_all_operations()]
    assert len(ops) >= 15
    for op in ops:

        @given(case=op.as_strategy())
        @settings(max_examples=25, deadline=None, suppress_health_check=list(HealthCheck), database=None)
        def check(case):
            case.call_and_validate(checks=[not_a_server_error])

        check()
