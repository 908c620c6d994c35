"""Helpers of the browser tests."""

from pathlib import Path

ARTIFACTS = Path(__file__).resolve().parents[2] / "test-artifacts"

#: the first admin the ``auth_server`` fixture starts with (user, password)
ADMIN = ("admin", "first-admin-password")


def shot(page, name):
    """A full-page screenshot into test-artifacts/<name>.png."""
    ARTIFACTS.mkdir(exist_ok=True)
    page.screenshot(path=str(ARTIFACTS / f"{name}.png"), full_page=True)
