"""Request-scoped dependencies: settings and database sessions."""

from __future__ import annotations

from collections.abc import Iterator

from typing import Annotated

from fastapi import Path, Request
from pydantic import Field

#: a database id: positive and within what every engine stores (SQLite, PostgreSQL integer)
ID_MAX = 2**31 - 1
LogId = Annotated[int, Path(ge=1, le=ID_MAX, description="log id")]
JobId = Annotated[int, Path(ge=1, le=ID_MAX, description="job id")]
PathId = Annotated[int, Path(ge=1, le=ID_MAX, description="id")]
BodyId = Annotated[int, Field(ge=1, le=ID_MAX)]
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
