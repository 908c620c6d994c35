"""``/docs``: Swagger UI 5 served from this server (the ``swagger-ui-bundle-v2`` package):
no CDN, no inline script."""

from __future__ import annotations

from pathlib import Path

from fastapi import FastAPI
from fastapi.responses import HTMLResponse
from fastapi.staticfiles import StaticFiles

PAGE = """<!doctype html>
<html lang="en"><head><meta charset="utf-8"><title>ldv-survey API</title>
<link rel="icon" href="/favicon.svg" type="image/svg+xml">
<link rel="stylesheet" href="/vendor/swagger-ui/swagger-ui.css"></head>
<body><div id="swagger-ui"></div>
<script src="/vendor/swagger-ui/swagger-ui-bundle.js"></script>
<script src="/docs-init.js"></script></body></html>"""

INIT = """window.ui = SwaggerUIBundle({url: "/openapi.json", dom_id: "#swagger-ui", deepLinking: true,
  presets: [SwaggerUIBundle.presets.apis], layout: "BaseLayout"});
"""


def swagger_dir() -> Path:
    """The folder of the Swagger UI assets shipped by the ``swagger_ui_bundle`` package."""
    import swagger_ui_bundle

    return Path(swagger_ui_bundle.swagger_ui_path)


def mount_docs(app: FastAPI) -> None:
    """Routes for ``/docs`` and its assets (the app is created with ``docs_url=None``)."""
    app.mount("/vendor/swagger-ui", StaticFiles(directory=swagger_dir()), name="swagger-ui")

    @app.get("/docs", include_in_schema=False)
    def docs() -> HTMLResponse:
        return HTMLResponse(PAGE)

    @app.get("/docs-init.js", include_in_schema=False)
    def docs_init():
        from fastapi.responses import Response

        return Response(INIT, media_type="text/javascript")
