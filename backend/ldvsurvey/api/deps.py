"""Request-scoped dependencies: settings and database sessions."""

from __future__ import annotations

from collections.abc import Iterator

from fastapi import Request
from sqlalchemy.orm import Session

from ldvsurvey.store.db import session_factory


def get_session(request: Request) -> Iterator[Session]:
    s = session_factory(request.app.state.database_url)()
    try:
        yield s
        s.commit()
    except BaseException:
        s.rollback()
        raise
    finally:
        s.close()
