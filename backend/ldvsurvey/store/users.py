"""Users, projects, sessions and API tokens (argon2 password hashes, SHA-256 token hashes)."""

from __future__ import annotations

import datetime as dt
import hashlib
import secrets
import unicodedata

from argon2 import PasswordHasher
from argon2.exceptions import InvalidHashError, VerificationError
from sqlalchemy import delete, func, select
from sqlalchemy.orm import Session

from ldvsurvey.errors import InputError
from ldvsurvey.store.models import ApiToken, LoginFailure, Membership, Project, SessionRow, User

_ph = PasswordHasher()


def _h(token: str) -> str:
    return hashlib.sha256(token.encode()).hexdigest()


MIN_PASSWORD = 8


class AccountError(InputError):
    """A user, project or membership request that cannot be done as asked."""


class Conflict(AccountError):
    status_code = 409


def _now() -> dt.datetime:
    return dt.datetime.now(dt.UTC)


def _aware(t: dt.datetime | None) -> dt.datetime | None:
    return None if t is None else (t if t.tzinfo else t.replace(tzinfo=dt.UTC))


#: bidirectional controls: they make a name read differently from what it is (CVE-2021-42574 style)
BIDI_CONTROLS = frozenset("\u061c\u200e\u200f\u202a\u202b\u202c\u202d\u202e\u2066\u2067\u2068\u2069")


def check_name(name: str, field: str, what: str) -> None:
    """Refuse bidirectional and other control characters in a user, project or token name."""
    for i, c in enumerate(name):
        if c in BIDI_CONTROLS or unicodedata.category(c) == "Cc":
            raise AccountError(
                f"a {what} may not hold control characters: U+{ord(c):04X} "
                f"({unicodedata.name(c, 'control')}) at character {i + 1}",
                field=field,
            )


def check_password(password: str) -> None:
    """Refuse (:class:`AccountError` naming ``password``) a password shorter than ``MIN_PASSWORD`` characters."""
    if len(password) < MIN_PASSWORD:
        raise AccountError(f"a password needs at least {MIN_PASSWORD} characters", field="password")


def create_user(
    s: Session,
    username: str,
    password: str,
    *,
    is_admin=False,
    is_demo=False,
    project: str | None = None,
    own_project: bool = True,
) -> User:
    """A new user (flushed), member of a project unless ``own_project`` is false and no ``project`` is named.

    Parameters
    ----------
    s : Session
        The caller's session (committed by the caller).
    username : str
        1 to 100 characters without spaces (surrounding blanks stripped).
    password : str
        Stored as its argon2 hash (its length is checked by the callers, :func:`check_password`).
    is_admin, is_demo : bool
        The user's flags.
    project : str, optional
        The project they join (created when missing); default a project of their own,
        ``"<username>'s project"``.
    own_project : bool
        Whether a user without ``project`` gets a project of their own.

    Returns
    -------
    User
        The new row.

    Raises
    ------
    AccountError
        For a bad name (422, naming ``username``).
    Conflict
        When the name is taken (409).
    """
    username = username.strip()
    check_name(username, "username", "user name")
    if not username or len(username) > 100 or any(c.isspace() for c in username):
        raise AccountError("a user name is 1 to 100 characters without spaces", field="username")
    if s.scalar(select(User.id).where(User.username == username)) is not None:
        raise Conflict(f"user '{username}' already exists", field="username")
    u = User(username=username, password_hash=_ph.hash(password), is_admin=is_admin, is_demo=is_demo)
    s.add(u)
    s.flush()
    if own_project or project:
        p = get_or_create_project(s, project or f"{username}'s project")
        add_member(s, u.id, p.id)
    return u


def user_named(s: Session, username: str) -> User | None:
    """The user of that name, or None."""
    return s.scalar(select(User).where(User.username == username))


def demo_user(s: Session) -> User | None:
    """The demo account (made in demo mode), or None."""
    return s.scalar(select(User).where(User.is_demo.is_(True)))


def count_admins(s: Session) -> int:
    """How many admins may log in (not disabled)."""
    return s.scalar(select(func.count()).select_from(User).where(User.is_admin.is_(True), User.disabled.is_(False)))


def find_user(s: Session, username: str) -> User:
    """The user of that name; :class:`AccountError` naming it when there is none."""
    u = user_named(s, username)
    if u is None:
        raise AccountError(f"no user '{username}'", field="username")
    return u


def find_project(s: Session, name_or_id: str | int) -> Project:
    """The project of that id (digits) or name; :class:`AccountError` naming ``project`` when there is none."""
    p = s.get(Project, int(name_or_id)) if str(name_or_id).isdigit() else None
    p = p or s.scalar(select(Project).where(Project.name == str(name_or_id)))
    if p is None:
        raise AccountError(f"no project '{name_or_id}'", field="project")
    return p


def create_project(s: Session, name: str) -> Project:
    """A new project of that name (flushed); :class:`AccountError` for a bad name, :class:`Conflict` for a name
    taken."""
    name = name.strip()
    check_name(name, "name", "project name")
    if not name or len(name) > 200:
        raise AccountError("a project name is 1 to 200 characters", field="name")
    if s.scalar(select(Project.id).where(Project.name == name)) is not None:
        raise Conflict(f"project '{name}' already exists", field="name")
    p = Project(name=name)
    s.add(p)
    s.flush()
    return p


def set_password(s: Session, user: User, password: str) -> None:
    """New password; every session of the user ends (they log in again)."""
    check_password(password)
    user.password_hash = _ph.hash(password)
    s.execute(delete(SessionRow).where(SessionRow.user_id == user.id))


def set_disabled(s: Session, user: User, disabled: bool) -> None:
    """A disabled user can not log in; their sessions and API tokens stop working at once."""
    user.disabled = disabled
    if disabled:
        s.execute(delete(SessionRow).where(SessionRow.user_id == user.id))


def set_admin(s: Session, user: User, is_admin: bool) -> None:
    """Grant or drop the admin right (an admin sees every project and manages users and projects)."""
    user.is_admin = is_admin


def remove_member(s: Session, user_id: int, project_id: int) -> None:
    """End the user's membership of the project (nothing when not a member)."""
    s.execute(delete(Membership).where(Membership.user_id == user_id, Membership.project_id == project_id))


def default_project(s: Session, user: User) -> int:
    """The project an upload without ``project_id`` goes to: the user's first, or a new one of their own."""
    pid = s.scalar(
        select(Membership.project_id).where(Membership.user_id == user.id).order_by(Membership.project_id).limit(1)
    )
    if pid is None:
        p = get_or_create_project(s, f"{user.username}'s project")
        add_member(s, user.id, p.id)
        pid = p.id
    return pid


def list_users(s: Session) -> list[dict]:
    """Every user by name: id, flags, creation time (ISO 8601) and projects (id, name)."""
    names = dict(s.execute(select(Project.id, Project.name)).all())
    members: dict[int, list] = {}
    for uid, pid in s.execute(select(Membership.user_id, Membership.project_id)):
        members.setdefault(uid, []).append({"id": pid, "name": names[pid]})
    return [
        {
            "id": u.id,
            "username": u.username,
            "is_admin": u.is_admin,
            "is_demo": u.is_demo,
            "disabled": u.disabled,
            "created_at": u.created_at.isoformat(),
            "projects": members.get(u.id, []),
        }
        for u in s.scalars(select(User).order_by(User.username))
    ]


def list_projects(s: Session, ids: list[int] | None = None) -> list[dict]:
    """Projects (all, or those with the given ids) with their members' user names."""
    users = dict(s.execute(select(User.id, User.username)).all())
    members: dict[int, list] = {}
    for uid, pid in s.execute(select(Membership.user_id, Membership.project_id)):
        members.setdefault(pid, []).append(users[uid])
    q = select(Project).order_by(Project.name)
    if ids is not None:
        q = q.where(Project.id.in_(ids))
    from ldvsurvey.store.models import Log

    n_logs = dict(s.execute(select(Log.project_id, func.count(Log.id)).group_by(Log.project_id)).all())
    return [
        {"id": p.id, "name": p.name, "members": sorted(members.get(p.id, [])), "n_logs": n_logs.get(p.id, 0)}
        for p in s.scalars(q)
    ]


#: what deleting a user does to the data (said by the API, the CLI and the admin page)
USER_DELETE_EFFECT = (
    "their sessions, API tokens and memberships are deleted; the logs they uploaded and the jobs they "
    "started stay in their projects (a project of their own stays too: delete it separately)"
)


def delete_user(s: Session, user: User) -> dict:
    """Delete a user (:data:`USER_DELETE_EFFECT`); what was deleted."""
    n_tokens = len(s.scalars(select(ApiToken.id).where(ApiToken.user_id == user.id)).all())
    n_member = len(s.scalars(select(Membership.project_id).where(Membership.user_id == user.id)).all())
    s.execute(delete(SessionRow).where(SessionRow.user_id == user.id))
    s.execute(delete(ApiToken).where(ApiToken.user_id == user.id))
    s.execute(delete(Membership).where(Membership.user_id == user.id))
    name = user.username
    s.delete(user)
    s.flush()
    return {"deleted": name, "tokens_deleted": n_tokens, "memberships_deleted": n_member, "effect": USER_DELETE_EFFECT}


#: what deleting a project does to the data
PROJECT_DELETE_EFFECT = (
    "its logs are deleted with their stored files and every job computed from them (results "
    "included), and its base stations; its members lose access to it, their accounts stay"
)


def delete_project(s: Session, project: Project) -> dict:
    """Delete a project with its logs (:data:`PROJECT_DELETE_EFFECT`); what was deleted."""
    from ldvsurvey.store.logs import delete_log
    from ldvsurvey.store.models import Job, Log, ProjectTie

    log_ids = list(s.scalars(select(Log.id).where(Log.project_id == project.id)))
    ids = set(log_ids)
    n_jobs = sum(1 for j in s.scalars(select(Job)) if ids & set(j.log_ids or []))
    for lid in log_ids:
        delete_log(s, lid)
    s.execute(delete(Membership).where(Membership.project_id == project.id))
    s.execute(delete(ProjectTie).where(ProjectTie.project_id == project.id))
    name = project.name
    s.delete(project)
    s.flush()
    return {
        "deleted": name,
        "logs_deleted": len(log_ids),
        "jobs_deleted": n_jobs,
        "effect": PROJECT_DELETE_EFFECT,
    }


def get_or_create_project(s: Session, name: str) -> Project:
    """The project of that name, created (and flushed) when missing."""
    p = s.scalar(select(Project).where(Project.name == name))
    if p is None:
        p = Project(name=name)
        s.add(p)
        s.flush()
    return p


def add_member(s: Session, user_id: int, project_id: int) -> None:
    """Make the user a member of the project (nothing when already one)."""
    if s.get(Membership, (user_id, project_id)) is None:
        s.add(Membership(user_id=user_id, project_id=project_id))
        s.flush()


def verify(s: Session, username: str, password: str) -> User | None:
    """The user when the name and password match and the user is not disabled, else None (the same hashing work either
    way)."""
    u = user_named(s, username)
    if u is None or u.disabled:
        _ph.hash(password)  # same work whether or not the user exists
        return None
    try:
        _ph.verify(u.password_hash, password)
    except (VerificationError, InvalidHashError):
        return None
    return u


def project_ids(s: Session, user: User) -> list[int]:
    """The ids of the projects the user may see: every one for an admin, else their memberships."""
    if user.is_admin:
        return list(s.scalars(select(Project.id)))
    return list(s.scalars(select(Membership.project_id).where(Membership.user_id == user.id)))


def new_session(s: Session, user: User, hours: float) -> tuple[str, str]:
    """(cookie token, CSRF token) of a new server-side session."""
    token, csrf = secrets.token_urlsafe(32), secrets.token_urlsafe(24)
    s.add(
        SessionRow(
            token_hash=_h(token),
            user_id=user.id,
            csrf=csrf,
            expires_at=dt.datetime.now(dt.UTC) + dt.timedelta(hours=hours),
        )
    )
    return token, csrf


def session_user(s: Session, token: str) -> tuple[User, str] | None:
    """(user, CSRF token) of a live session cookie token, or None (an expired session is deleted; a disabled user has
    none)."""
    row = s.get(SessionRow, _h(token))
    if row is None:
        return None
    exp = row.expires_at if row.expires_at.tzinfo else row.expires_at.replace(tzinfo=dt.UTC)
    if exp < dt.datetime.now(dt.UTC):
        s.delete(row)
        return None
    u = s.get(User, row.user_id)
    return None if u is None or u.disabled else (u, row.csrf)


def end_session(s: Session, token: str) -> None:
    """Delete the session of that cookie token."""
    s.execute(delete(SessionRow).where(SessionRow.token_hash == _h(token)))


def new_api_token(s: Session, user: User, name: str, *, expires_days: float | None = None) -> str:
    """A new bearer token of the user (flushed); only its SHA-256 is kept.

    Parameters
    ----------
    s : Session
        The caller's session (committed by the caller).
    user : User
        Whose token it is.
    name : str
        1 to 100 characters, to tell the user's tokens apart.
    expires_days : float, optional
        Days until it stops working (more than 0, at most 3660); None: never.

    Returns
    -------
    str
        The token (``ldvs_…``), shown to the user this once.

    Raises
    ------
    AccountError
        For a bad name or expiry, naming the field.
    """
    name = (name or "").strip()
    check_name(name, "name", "token name")
    if not name or len(name) > 100:
        raise AccountError("a token name is 1 to 100 characters", field="name")
    if expires_days is not None and not 0 < expires_days <= 3660:
        raise AccountError("a token expires after more than 0 and at most 3660 days", field="expires_days")
    token = "ldvs_" + secrets.token_urlsafe(32)
    exp = None if expires_days is None else _now() + dt.timedelta(days=expires_days)
    s.add(ApiToken(token_hash=_h(token), user_id=user.id, name=name, expires_at=exp))
    s.flush()
    return token


def list_tokens(s: Session, user: User) -> list[dict]:
    """The user's API tokens by id: name, creation, expiry and last use (ISO 8601, UTC) and whether expired."""

    def iso(t):
        return None if t is None else _aware(t).isoformat()

    now = _now()
    return [
        {
            "id": t.id,
            "name": t.name,
            "created_at": iso(t.created_at),
            "expires_at": iso(t.expires_at),
            "last_used_at": iso(t.last_used_at),
            "expired": t.expires_at is not None and _aware(t.expires_at) <= now,
        }
        for t in s.scalars(select(ApiToken).where(ApiToken.user_id == user.id).order_by(ApiToken.id))
    ]


def revoke_token(s: Session, user: User, token_id: int) -> bool:
    """Delete one of the user's tokens; False when they have no token with that id."""
    r = s.execute(delete(ApiToken).where(ApiToken.id == token_id, ApiToken.user_id == user.id))
    return r.rowcount > 0


def token_user(s: Session, token: str) -> User | None:
    """The user of a valid, unexpired API token (not disabled), or None; notes its last use (at most every 5 min)."""
    row = s.scalar(select(ApiToken).where(ApiToken.token_hash == _h(token)))
    if row is None or (row.expires_at is not None and _aware(row.expires_at) <= _now()):
        return None
    u = s.get(User, row.user_id)
    if u is None or u.disabled:
        return None
    if row.last_used_at is None or _now() - _aware(row.last_used_at) > dt.timedelta(minutes=5):
        row.last_used_at = _now()  # coarse, so that reads do not write on every request
    return u


def expired_token(s: Session, token: str) -> ApiToken | None:
    """The token's row when it exists but has expired (so that the refusal can say so); else None."""
    row = s.scalar(select(ApiToken).where(ApiToken.token_hash == _h(token)))
    if row is not None and row.expires_at is not None and _aware(row.expires_at) <= _now():
        return row
    return None


def record_login_failure(s: Session, keys: list[str]) -> list[int]:
    """One failure per key, now; their row ids."""
    rows = [LoginFailure(key=k[:300], at=_now()) for k in keys]
    s.add_all(rows)
    s.flush()
    return [r.id for r in rows]


def forget_login_failure_ids(s: Session, ids: list[int]) -> None:
    """Delete the login failures of these row ids."""
    s.execute(delete(LoginFailure).where(LoginFailure.id.in_(ids)))


def login_failures(s: Session, key: str, window_s: float) -> int:
    """How many failed logins ``key`` had within the last ``window_s`` seconds."""
    since = _now() - dt.timedelta(seconds=window_s)
    return s.scalar(
        select(func.count()).select_from(LoginFailure).where(LoginFailure.key == key[:300], LoginFailure.at >= since)
    )


def lock_user(s: Session, user_id: int) -> None:
    """Take the write lock for one user's rows until the session's transaction ends, so that a
    count followed by an insert (the active-job limit) cannot interleave with another session's.

    PostgreSQL (and other servers): the user's row, ``SELECT … FOR UPDATE``. SQLite locks the whole
    database instead: what the session read so far is committed and a new transaction starts with
    ``BEGIN IMMEDIATE`` (waiting up to the busy timeout for other writers), so that the count that
    follows sees every committed job.
    """
    if s.get_bind().dialect.name == "sqlite":
        s.commit()
        s.connection().exec_driver_sql("BEGIN IMMEDIATE")
        return
    s.execute(select(User.id).where(User.id == user_id).with_for_update())


def login_failure_times(s: Session, key: str, window_s: float) -> list[float]:
    """The times (Unix s, oldest first) of the key's failed logins within the last ``window_s``."""
    since = _now() - dt.timedelta(seconds=window_s)
    rows = s.scalars(
        select(LoginFailure.at).where(LoginFailure.key == key[:300], LoginFailure.at >= since).order_by(LoginFailure.at)
    )
    # SQLite gives back naive times: they were written in UTC (_now)
    return [(t if t.tzinfo else t.replace(tzinfo=dt.UTC)).timestamp() for t in rows]


def forget_login_failures(s: Session, keys: list[str]) -> None:
    """Delete every login failure of these keys."""
    s.execute(delete(LoginFailure).where(LoginFailure.key.in_([k[:300] for k in keys])))


def prune_login_failures(s: Session, older_than_s: float) -> None:
    """Delete the login failures older than ``older_than_s`` seconds."""
    s.execute(delete(LoginFailure).where(LoginFailure.at < _now() - dt.timedelta(seconds=older_than_s)))
