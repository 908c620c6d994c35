"""REST API (FastAPI) and the static dashboard."""
