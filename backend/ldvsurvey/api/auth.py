"""Authentication and authorization: session cookies with CSRF for pages, bearer tokens for REST.

Every log belongs to a project; only the project's members (and admins) see or change it.
With ``auth_enabled`` off (local single-user use) everything is open. In demo mode a visitor
without a session acts as the clearly marked demo account.
"""

from __future__ import annotations

import math
import threading
import time
from collections import defaultdict, deque
from dataclasses import dataclass
from typing import Annotated

from fastapi import APIRouter, Depends, HTTPException, Request, Response
from pydantic import BaseModel, Field
from sqlalchemy.orm import Session

from ldvsurvey.api import models as m
from ldvsurvey.api.deps import SessionDep, SettingsDep
from ldvsurvey.api.throttle import client_address
from ldvsurvey.settings import Settings
from ldvsurvey.store import users as ustore
from ldvsurvey.store.jobs import count_active
from ldvsurvey.store.logs import get_log
from ldvsurvey.store.models import Job, Log, User

COOKIE = "ldvs_session"
UNSAFE = {"POST", "PUT", "PATCH", "DELETE"}
router = APIRouter(tags=["auth"])


@dataclass
class Principal:
    """Who sends a request: the user (None with authentication off), the projects they may see (None: every one) and the
    CSRF token of their session."""

    user: User | None  # None: authentication disabled
    projects: list[int] | None  # None: every project
    csrf: str | None = None

    def can_see(self, log: Log) -> bool:
        """Whether the log is in one of the principal's projects (every log when ``projects`` is None)."""
        return self.projects is None or log.project_id in self.projects


def principal(request: Request, session: SessionDep, st: SettingsDep) -> Principal:
    """Who sends the request: the user of a bearer token, of a session cookie, or the demo account.

    Parameters
    ----------
    request : Request
        Its ``Authorization`` header or session cookie, and for a write through the cookie its
        ``X-CSRF-Token`` header.
    session : Session
        The request's session.
    st : Settings
        ``auth_enabled`` (off: everyone may see everything) and ``demo_mode``.

    Returns
    -------
    Principal
        The user with the projects they may see (None for an admin: every one).

    Raises
    ------
    HTTPException
        401 without a valid login, for an invalid or expired token (saying when it expired); 403
        for a cookie write without the session's CSRF token.
    """
    if not st.auth_enabled:
        return Principal(None, None)
    user, csrf, via_cookie = None, None, False
    authz = request.headers.get("authorization", "")
    if authz.lower().startswith("bearer "):
        user = ustore.token_user(session, authz[7:].strip())
        if user is None:
            old = ustore.expired_token(session, authz[7:].strip())
            if old is not None:
                when = ustore._aware(old.expires_at).strftime("%Y-%m-%d %H:%M UTC")
                raise HTTPException(401, f"API token '{old.name}' expired on {when}: create a new one (Account page)")
            raise HTTPException(401, "invalid API token")
    elif request.cookies.get(COOKIE):
        found = ustore.session_user(session, request.cookies[COOKIE])
        if found is not None:
            user, csrf = found
            via_cookie = True
    if user is None and st.demo_mode:
        user = ustore.demo_user(session)
    if user is None:
        if request.method in UNSAFE:
            raise HTTPException(401, "log in (session cookie) or send an API token (Authorization: Bearer …)")
        raise HTTPException(401, "authentication required")
    if via_cookie and request.method in UNSAFE and request.headers.get("x-csrf-token") != csrf:
        raise HTTPException(403, "missing or wrong CSRF token (X-CSRF-Token header)")
    return Principal(user, None if user.is_admin else ustore.project_ids(session, user), csrf)


#: the principal of the request, for every route that needs one
CurrentUser = Annotated[Principal, Depends(principal)]


def visible_log(session: Session, who: Principal, log_id: int) -> Log:
    """The log if it exists and the principal may see it; 404 otherwise (no existence leak)."""
    row = get_log(session, log_id)
    if row is None or not who.can_see(row):
        raise HTTPException(404, f"log {log_id} not found")
    return row


def visible_job(session: Session, who: Principal, job_id: int) -> Job:
    """The job if it exists and the principal may see every log it read; 404 otherwise (no existence leak)."""
    j = session.get(Job, job_id)
    if j is None:
        raise HTTPException(404, f"job {job_id} not found")
    for lid in j.log_ids:
        row = get_log(session, lid)
        if row is not None and not who.can_see(row):
            raise HTTPException(404, f"job {job_id} not found")
    return j


def visible_jobs(session: Session, who: Principal, jobs: list[Job]) -> list[Job]:
    """Those of ``jobs`` whose every log exists and the principal may see (each log looked up once)."""
    if who.projects is None:
        return jobs
    seen: dict[int, bool] = {}

    def ok(j: Job) -> bool:
        for i in j.log_ids:
            if i not in seen:
                row = get_log(session, i)
                seen[i] = row is not None and who.can_see(row)
            if not seen[i]:
                return False
        return True

    return [j for j in jobs if ok(j)]


def refuse_demo(who: Principal, what: str) -> None:
    """403 when the principal is the demo account, which every visitor of a demo shares: it is
    read-only for data it did not create. ``what`` completes "the demo account cannot …"."""
    if who.user is not None and who.user.is_demo:
        raise HTTPException(
            403, f"the demo account cannot {what}: it is read-only for data it did not create (log in to do this)"
        )


def check_job_owner(who: Principal, job: Job, what: str) -> None:
    """The demo account changes only the jobs it started (403 naming ``what`` otherwise)."""
    if who.user is not None and who.user.is_demo and job.user_id != who.user.id:
        refuse_demo(who, f"{what} a job it did not start")


class RateLimiter:
    """Sliding-window count per key (per process)."""

    def __init__(self):
        self._hits: dict = defaultdict(deque)
        self._lock = threading.Lock()

    def allow(self, key, limit: int, *, window_s: float = 60.0) -> bool:
        """Count one hit of ``key`` unless it already had ``limit`` hits within the last ``window_s``.

        Parameters
        ----------
        key : hashable
            What is counted (e.g. ``("upload", user id)``).
        limit : int
            Hits allowed per window.
        window_s : float
            The sliding window, s.

        Returns
        -------
        bool
            True when the hit is allowed (and counted), False when refused (not counted).
        """
        now = time.monotonic()
        with self._lock:
            q = self._hits[key]
            while q and q[0] < now - window_s:
                q.popleft()
            if len(q) >= limit:
                return False
            q.append(now)
            return True

    def wait_s(self, key, limit: int, *, window_s: float = 60.0) -> int:
        """Whole seconds until ``key`` is allowed again (``Retry-After``; at least 1)."""
        now = time.monotonic()
        with self._lock:
            q = self._hits[key]
            if len(q) < limit:
                return 1
            return max(1, math.ceil(q[len(q) - limit] + window_s - now))


def check_upload_rate(request: Request, who: Principal, st: Settings) -> None:
    """Refuse (429 with ``Retry-After``, s) an upload past ``uploads_per_minute`` for the user, or for the client's
    address with authentication off."""
    key = who.user.id if who.user is not None else client_address(request, st)
    limiter = request.app.state.rate_limiter
    if not limiter.allow(("upload", key), st.uploads_per_minute):
        raise HTTPException(
            429,
            f"more than {st.uploads_per_minute} uploads a minute: slow down",
            headers={"Retry-After": str(limiter.wait_s(("upload", key), st.uploads_per_minute))},
        )


#: ``Retry-After`` of a refusal over the job limit: jobs end at their own pace (s)
JOB_QUOTA_RETRY_S = 30


def check_job_quota(session: Session, who: Principal, st: Settings) -> None:
    """Refuse (429) one more queued or running job for the user past ``max_active_jobs_per_user``.

    Counts under the user's write lock (:func:`ldvsurvey.store.users.lock_user`), held until the
    session commits: the caller adds its job and commits, so concurrent submissions by one user are
    counted one after the other.
    """
    if who.user is None:
        return
    ustore.lock_user(session, who.user.id)
    active = count_active(session, who.user.id)
    if active >= st.max_active_jobs_per_user:
        raise HTTPException(
            429,
            f"{active} jobs already queued or running (limit {st.max_active_jobs_per_user})",
            headers={"Retry-After": str(JOB_QUOTA_RETRY_S)},
        )


class Login(BaseModel):
    """A login: user name and password."""

    username: str = Field(..., max_length=200)
    password: str = Field(..., max_length=1000)


@router.post(
    "/api/login",
    summary="Start a session (sets an HttpOnly cookie; returns the CSRF token)",
    responses={
        401: {"description": "wrong user name or password"},
        429: {"description": "too many failed logins for the account or the client"},
    },
)
def login(body: Login, request: Request, response: Response, session: SessionDep, st: SettingsDep) -> m.LoginOut:
    """Start a session: sets the HttpOnly session cookie and answers the user name and the CSRF token
    that page writes send as ``X-CSRF-Token``. 401 for a wrong user name or password (or a disabled
    user), 429 with ``Retry-After`` after too many failed logins for the account or the client.
    """
    throttle = request.app.state.login_throttle
    client = client_address(request, st)
    refused, ticket = throttle.attempt(body.username, client)  # counted as a failure until proven right
    if refused:
        reason, wait_s = refused
        raise HTTPException(429, reason, headers={"Retry-After": str(wait_s)})
    user = ustore.verify(session, body.username, body.password)
    session.commit()  # the request's connection goes back to the pool before the throttle takes one
    if user is None:
        raise HTTPException(401, "wrong user name or password")
    throttle.succeeded(body.username, client, ticket)
    token, csrf = ustore.new_session(session, user, st.session_hours)
    session.commit()  # the cookie works on the very next request
    response.set_cookie(
        COOKIE, token, httponly=True, samesite="lax", secure=st.cookie_secure, max_age=int(st.session_hours * 3600)
    )
    return {"user": user.username, "csrf": csrf}


@router.post("/api/logout", summary="End the session")
def logout(request: Request, response: Response, session: SessionDep) -> m.Ok:
    """End the session of the cookie (if any) and clear the cookie. Always answers ok."""
    if request.cookies.get(COOKIE):
        ustore.end_session(session, request.cookies[COOKIE])
        session.commit()
    response.delete_cookie(COOKIE)
    return {"ok": True}


@router.get("/api/me", summary="Who am I (user, projects, CSRF token for page writes)")
def me(who: CurrentUser, session: SessionDep) -> m.Me:
    """Who the caller is: user name, whether authentication is on, the CSRF token for page writes,
    the demo and admin flags, the ids of the projects they may see (null: every one) and those
    projects. 401 without a login when authentication is on (and no demo mode).
    """
    if who.user is None:
        return {
            "user": None,
            "auth": False,
            "csrf": None,
            "demo": False,
            "admin": False,
            "projects": None,
            "project_list": ustore.list_projects(session),
        }
    return {
        "user": who.user.username,
        "auth": True,
        "csrf": who.csrf,
        "demo": who.user.is_demo,
        "admin": who.user.is_admin,
        "projects": who.projects,
        "project_list": ustore.list_projects(session, who.projects),
    }


def bootstrap_users(database_url: str, settings) -> None:
    """Create the first admin from the environment and the demo account in demo mode."""
    from ldvsurvey.store.db import session_scope

    with session_scope(database_url) as s:
        if settings.admin_user and settings.admin_password:
            if ustore.user_named(s, settings.admin_user) is None:
                ustore.create_user(s, settings.admin_user, settings.admin_password, is_admin=True)
        if settings.demo_mode and ustore.demo_user(s) is None:
            import secrets

            ustore.create_user(s, "demo", secrets.token_urlsafe(16), is_demo=True, project="Demo survey")
