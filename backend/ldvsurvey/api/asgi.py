"""ASGI entry for process managers: ``uvicorn ldvsurvey.api.asgi:app --workers N`` (settings from the environment)."""

from ldvsurvey.api.app import create_app

app = create_app()
