"""The API's shape: every JSON answer has a schema in OpenAPI, the ``ldvsurvey.api`` modules import
each other without a cycle, and the views come from one registry."""

import ast
from pathlib import Path

import pytest

API_DIR = Path(__file__).resolve().parents[2] / "backend" / "ldvsurvey" / "api"


@pytest.fixture(scope="module")
def app(tmp_path_factory):
    from ldvsurvey.api.app import create_app
    from ldvsurvey.settings import Settings

    return create_app(Settings(data_dir=tmp_path_factory.mktemp("shape"), auth_enabled=False, run_consumer=False))


def _empty(schema: dict) -> bool:
    return not schema or not ({"$ref", "type", "anyOf", "oneOf", "allOf", "properties", "items"} & set(schema))


def missing_response_schemas(spec: dict) -> list[str]:
    """Operations whose success answer is JSON without a schema (or that say nothing of their answer)."""
    bad = []
    for path, ops in spec["paths"].items():
        for method, op in ops.items():
            ok = {code: r for code, r in op.get("responses", {}).items() if code.startswith("2")}
            if not ok:
                bad.append(f"{method.upper()} {path}: no success response")
            for code, r in ok.items():
                content = r.get("content") or {}
                if code == "204":
                    continue
                if not content:
                    bad.append(f"{method.upper()} {path} {code}: no content")
                js = content.get("application/json")
                if js is not None and _empty(js.get("schema") or {}):
                    bad.append(f"{method.upper()} {path} {code}: JSON without a schema")
    return bad


def test_every_json_route_has_a_response_schema(app):
    spec = app.openapi()
    assert len(spec["paths"]) >= 25
    assert missing_response_schemas(spec) == []
    # the check itself finds a JSON route without a model
    from fastapi import FastAPI

    probe = FastAPI()

    @probe.get("/untyped")
    def untyped():
        return {"a": 1}

    assert missing_response_schemas(probe.openapi()) == ["GET /untyped 200: JSON without a schema"]


def test_response_models_document_fields(app):
    schemas = app.openapi()["components"]["schemas"]
    assert {"id", "status", "progress", "views", "inputs"} <= set(schemas["JobDetail"]["properties"])
    assert {"id", "sha256", "badges", "manifest", "files"} <= set(schemas["LogDetail"]["properties"])
    assert {"data", "layout"} <= set(schemas["Figure"]["properties"])


def api_imports() -> dict[str, set[str]]:
    """``ldvsurvey.api`` module -> the ``ldvsurvey.api`` modules it imports anywhere (also inside functions)."""
    graph = {}
    for f in API_DIR.glob("*.py"):
        mod = f.stem
        deps = set()
        for node in ast.walk(ast.parse(f.read_text())):
            if isinstance(node, ast.ImportFrom) and node.module:
                if node.module.startswith("ldvsurvey.api."):
                    deps.add(node.module.split(".")[2])
                elif node.module == "ldvsurvey.api":
                    deps |= {a.name for a in node.names}
            elif isinstance(node, ast.Import):
                deps |= {a.name.split(".")[2] for a in node.names if a.name.startswith("ldvsurvey.api.")}
        graph[mod] = deps - {mod}
    return graph


def find_cycle(graph: dict[str, set[str]]) -> list[str] | None:
    state, stack = {}, []

    def visit(n):
        state[n] = "open"
        stack.append(n)
        for d in sorted(graph.get(n, ())):
            if state.get(d) == "open":
                return stack[stack.index(d) :] + [d]
            if d not in state and (c := visit(d)):
                return c
        stack.pop()
        state[n] = "done"
        return None

    for n in sorted(graph):
        if n not in state and (c := visit(n)):
            return c
    return None


def test_no_import_cycle_among_api_modules():
    graph = api_imports()
    assert {"app", "jobs", "views", "deps", "models"} <= set(graph)
    assert "views" in graph["jobs"]  # the graph sees the imports
    assert find_cycle(graph) is None, " -> ".join(find_cycle(graph))
    assert find_cycle({"jobs": {"views"}, "views": {"jobs"}}) == ["jobs", "views", "jobs"]


def test_views_come_from_the_registry(client):
    from ldvsurvey.api.views import VIEWS, DictTables, ViewInput, view
    from ldvsurvey.pipelines.registry import PIPELINES

    listed = client.get("/api/views").json()
    assert [v["name"] for v in listed] == list(VIEWS)
    assert {v["pipeline"] for v in listed} <= set(PIPELINES)
    assert all(v["title"] and v["units"] and v["files"] for v in listed)
    assert [v["name"] for v in client.get("/api/views", params={"pipeline": "height"}).json()] == [
        "height",
        "height_error",
    ]
    with pytest.raises(ValueError):
        view("height", "height", "again", "m", ("height.csv",))(lambda v: {})
    with pytest.raises(RuntimeError, match="without declaring"):
        VIEWS["height"].build(ViewInput(DictTables({}), {}, None, None, 100, ("attitude.csv",)))


def test_the_frontend_has_no_table_of_views():
    js = (API_DIR.parents[2] / "frontend" / "js" / "job.js").read_text()
    assert "height_error" not in js and "j.views" in js
