"""Request-scoped dependencies: the settings, the database session, and typed path/body ids.

Routes take ``settings: SettingsDep`` and ``session: SessionDep`` (and ``who: CurrentUser`` from
:mod:`ldvsurvey.api.auth`); nothing else reads ``request.app.state.settings``.
"""

from __future__ import annotations

from collections.abc import Iterator
from typing import Annotated

from fastapi import Depends, Path, Request
from pydantic import Field
from sqlalchemy.orm import Session

from ldvsurvey.jobs.runner import JobRunner
from ldvsurvey.settings import Settings
from ldvsurvey.store.db import session_scope

#: a database id: positive and within what every engine stores (SQLite, PostgreSQL integer)
ID_MAX = 2**31 - 1
LogId = Annotated[int, Path(ge=1, le=ID_MAX, description="log id")]
JobId = Annotated[int, Path(ge=1, le=ID_MAX, description="job id")]
PathId = Annotated[int, Path(ge=1, le=ID_MAX, description="id")]
BodyId = Annotated[int, Field(ge=1, le=ID_MAX)]


def app_settings(request: Request) -> Settings:
    """The settings the app was created with (:func:`ldvsurvey.api.app.create_app`)."""
    return request.app.state.settings


def database_url(request: Request) -> str:
    """The SQLAlchemy URL the app was created on (``Settings.resolved_database_url()``, migrated)."""
    return request.app.state.database_url


def get_session(url: Annotated[str, Depends(database_url)]) -> Iterator[Session]:
    """One session per request (shared by every dependency of the request): committed when the
    route returns, rolled back when it raises (:func:`ldvsurvey.store.db.session_scope`)."""
    with session_scope(url) as s:
        yield s


SettingsDep = Annotated[Settings, Depends(app_settings)]
DatabaseUrlDep = Annotated[str, Depends(database_url)]
SessionDep = Annotated[Session, Depends(get_session)]


def job_runner(request: Request) -> JobRunner:
    """The app's job runner (its queue): :class:`ldvsurvey.jobs.runner.JobRunner`."""
    return request.app.state.runner


RunnerDep = Annotated[JobRunner, Depends(job_runner)]
