"""Users, projects, sessions and API tokens (argon2 password hashes, SHA-256 token hashes)."""

from __future__ import annotations

import datetime as dt
import hashlib
import secrets

from argon2 import PasswordHasher
from argon2.exceptions import InvalidHashError, VerificationError
from sqlalchemy import delete, select
from sqlalchemy.orm import Session

from ldvsurvey.store.models import ApiToken, Membership, Project, SessionRow, User

_ph = PasswordHasher()


def _h(token: str) -> str:
    return hashlib.sha256(token.encode()).hexdigest()


def create_user(s: Session, username: str, password: str, *, is_admin=False, is_demo=False,
                project: str | None = None) -> User:
    """A user and, unless given, a project of their own that they are a member of."""
    u = User(username=username, password_hash=_ph.hash(password), is_admin=is_admin, is_demo=is_demo)
    s.add(u)
    s.flush()
    p = get_or_create_project(s, project or f"{username}'s project")
    add_member(s, u.id, p.id)
    return u


def get_or_create_project(s: Session, name: str) -> Project:
    p = s.scalar(select(Project).where(Project.name == name))
    if p is None:
        p = Project(name=name)
        s.add(p)
        s.flush()
    return p


def add_member(s: Session, user_id: int, project_id: int) -> None:
    if s.get(Membership, (user_id, project_id)) is None:
        s.add(Membership(user_id=user_id, project_id=project_id))
        s.flush()


def verify(s: Session, username: str, password: str) -> User | None:
    u = s.scalar(select(User).where(User.username == username))
    if u is None:
        _ph.hash(password)  # same work whether or not the user exists
        return None
    try:
        _ph.verify(u.password_hash, password)
    except (VerificationError, InvalidHashError):
        return None
    return u


def project_ids(s: Session, user: User) -> list[int]:
    if user.is_admin:
        return list(s.scalars(select(Project.id)))
    return list(s.scalars(select(Membership.project_id).where(Membership.user_id == user.id)))


def new_session(s: Session, user: User, hours: float) -> tuple[str, str]:
    """(cookie token, CSRF token) of a new server-side session."""
    token, csrf = secrets.token_urlsafe(32), secrets.token_urlsafe(24)
    s.add(SessionRow(token_hash=_h(token), user_id=user.id, csrf=csrf,
                     expires_at=dt.datetime.now(dt.timezone.utc) + dt.timedelta(hours=hours)))
    return token, csrf


def session_user(s: Session, token: str) -> tuple[User, str] | None:
    row = s.get(SessionRow, _h(token))
    if row is None:
        return None
    exp = row.expires_at if row.expires_at.tzinfo else row.expires_at.replace(tzinfo=dt.timezone.utc)
    if exp < dt.datetime.now(dt.timezone.utc):
        s.delete(row)
        return None
    return s.get(User, row.user_id), row.csrf


def end_session(s: Session, token: str) -> None:
    s.execute(delete(SessionRow).where(SessionRow.token_hash == _h(token)))


def new_api_token(s: Session, user: User, name: str) -> str:
    token = "ldvs_" + secrets.token_urlsafe(32)
    s.add(ApiToken(token_hash=_h(token), user_id=user.id, name=name))
    return token


def token_user(s: Session, token: str) -> User | None:
    row = s.scalar(select(ApiToken).where(ApiToken.token_hash == _h(token)))
    return None if row is None else s.get(User, row.user_id)
