"""People and access: projects one may see, one's password and API tokens; for admins users,
projects and memberships (the same operations as ``ldv-survey user|project``)."""

from __future__ import annotations

from typing import Annotated

from fastapi import APIRouter, Depends, HTTPException, Response
from pydantic import BaseModel, Field
from sqlalchemy.orm import Session

from ldvsurvey.api import models as m
from ldvsurvey.api.auth import CurrentUser, Principal, refuse_demo
from ldvsurvey.api.deps import BodyId, PathId, SessionDep
from ldvsurvey.store import users as ustore
from ldvsurvey.store.models import User

router = APIRouter(tags=["people"])
Id = BodyId


def _me(who: Principal) -> User:
    if who.user is None:
        raise HTTPException(400, "authentication is disabled: there are no accounts")
    return who.user


def admin(who: CurrentUser) -> Principal:
    """The request's principal when an admin (the dependency behind ``AdminUser``); 403 otherwise."""
    if who.user is None or not who.user.is_admin:
        raise HTTPException(403, "only an admin may do this")
    return who


#: the principal of the request, who must be an admin (403 otherwise)
AdminUser = Annotated[Principal, Depends(admin)]


@router.get("/api/projects", summary="The projects you may see (all of them for admins)")
def my_projects(who: CurrentUser, session: SessionDep) -> list[m.ProjectOut]:
    """The projects the caller may see (every one for admins, and with authentication off), with their members and
    number of logs."""
    return ustore.list_projects(session, who.projects)


class PasswordChange(BaseModel):
    """A password change: the current password and the new one."""

    old_password: str = Field(..., max_length=1000)
    new_password: str = Field(..., max_length=1000)


@router.post("/api/password", summary="Change your password (ends all your sessions: log in again)")
def change_password(body: PasswordChange, response: Response, who: CurrentUser, session: SessionDep) -> m.Ok:
    """Change the caller's password; every session of theirs ends (the cookie is cleared). 403 when the current password
    is wrong or for the demo account, 400 with authentication off, 422 for a password too short."""
    user = _me(who)
    refuse_demo(who, "change its password")
    if ustore.verify(session, user.username, body.old_password) is None:
        raise HTTPException(403, "the current password is wrong")
    ustore.set_password(session, user, body.new_password)
    session.commit()
    response.delete_cookie("ldvs_session")
    return {"ok": True}


class TokenRequest(BaseModel):
    """An API token to create: its name and days until it expires (null: never)."""

    name: str = Field("api", min_length=1, max_length=100)
    expires_days: float | None = Field(90, gt=0, le=3660, description="days until it stops working; null: never")


@router.get("/api/tokens", summary="Your API tokens (names and dates; never the secret)")
def list_tokens(who: CurrentUser, session: SessionDep) -> list[m.TokenOut]:
    """The caller's API tokens: name, creation, expiry and last use (ISO 8601, UTC), whether expired; never the secret.
    400 with authentication off."""
    return ustore.list_tokens(session, _me(who))


@router.post("/api/tokens", status_code=201, summary="Create an API token (the secret is shown once)")
def create_token(body: TokenRequest, who: CurrentUser, session: SessionDep) -> m.NewToken:
    """Create an API token for the caller; the answer holds its secret, shown this once. 403 for the demo account, 400
    with authentication off, 422 for a bad name or expiry."""
    refuse_demo(who, "hold API tokens")  # shared by every visitor, who needs none
    token = ustore.new_api_token(session, _me(who), body.name, expires_days=body.expires_days)
    session.commit()
    row = ustore.list_tokens(session, who.user)[-1]
    return {**row, "token": token}


@router.delete("/api/tokens/{token_id}", status_code=204, summary="Revoke one of your API tokens")
def revoke_token(token_id: PathId, who: CurrentUser, session: SessionDep) -> Response:
    """Revoke one of the caller's API tokens (204). 404 when they have no token of that id, 403 for the demo account."""
    refuse_demo(who, "revoke API tokens")
    if not ustore.revoke_token(session, _me(who), token_id):
        raise HTTPException(404, f"you have no token {token_id}")
    session.commit()
    return Response(status_code=204)


class NewUser(BaseModel):
    """A user to create: name, password, admin flag and the projects they join."""

    username: str = Field(..., min_length=1, max_length=100)
    password: str = Field(..., max_length=1000)
    is_admin: bool = False
    project_ids: list[Id] = Field(default_factory=list, max_length=100)


class UserChange(BaseModel):
    """Changes to a user: disabled, admin flag, new password (each optional)."""

    disabled: bool | None = None
    is_admin: bool | None = None
    password: str | None = Field(None, max_length=1000)


@router.get("/api/admin/users", summary="Users with their projects (admin)")
def admin_users(_: AdminUser, session: SessionDep) -> list[m.UserOut]:
    """Every user with their flags and projects (admin; 403 otherwise)."""
    return ustore.list_users(session)


@router.post("/api/admin/users", status_code=201, summary="Create a user (admin)")
def admin_add_user(body: NewUser, _: AdminUser, session: SessionDep) -> m.UserOut:
    """Create a user, member of the given projects; answers the user. 403 for a non-admin, 409 for a name taken, 422 for
    a bad name or a password too short or an unknown project."""
    ustore.check_password(body.password)
    for pid in body.project_ids:
        ustore.find_project(session, pid)
    u = ustore.create_user(session, body.username, body.password, is_admin=body.is_admin, own_project=False)
    for pid in body.project_ids:
        ustore.add_member(session, u.id, pid)
    session.commit()
    return next(x for x in ustore.list_users(session) if x["id"] == u.id)


@router.patch("/api/admin/users/{user_id}", summary="Disable/enable a user, make admin, set a password (admin)")
def admin_change_user(user_id: PathId, body: UserChange, who: AdminUser, session: SessionDep) -> m.UserOut:
    """Disable or enable a user, grant or drop the admin right, set a password; answers the user. 403 for a non-admin,
    404 for no such user, 409 when admins would disable themselves or drop their own right."""
    u = session.get(User, user_id)
    if u is None:
        raise HTTPException(404, f"user {user_id} not found")
    if u.id == who.user.id and (body.disabled or body.is_admin is False):
        raise HTTPException(409, "you can not disable yourself or drop your own admin right")
    if body.disabled is not None:
        ustore.set_disabled(session, u, body.disabled)
    if body.is_admin is not None:
        ustore.set_admin(session, u, body.is_admin)
    if body.password is not None:
        ustore.set_password(session, u, body.password)
    session.commit()
    return next(x for x in ustore.list_users(session) if x["id"] == u.id)


@router.delete(
    "/api/admin/users/{user_id}",
    summary="Delete a user (admin): sessions, tokens, memberships go; their logs and jobs stay in their projects",
)
def admin_delete_user(user_id: PathId, who: AdminUser, session: SessionDep) -> m.UserDeleted:
    """Delete a user: their sessions, tokens and memberships go, their logs and jobs stay in their projects. Answers
    what was deleted. 403 for a non-admin, 404 for no such user, 409 for oneself."""
    u = session.get(User, user_id)
    if u is None:
        raise HTTPException(404, f"user {user_id} not found")
    if u.id == who.user.id:
        raise HTTPException(409, "you can not delete yourself")
    out = ustore.delete_user(session, u)
    session.commit()
    return out


class NewProject(BaseModel):
    """A project to create: its name."""

    name: str = Field(..., min_length=1, max_length=200)


@router.get("/api/admin/projects", summary="All projects with their members (admin)")
def admin_projects(_: AdminUser, session: SessionDep) -> list[m.ProjectOut]:
    """Every project with its members and number of logs (admin; 403 otherwise)."""
    return ustore.list_projects(session)


@router.post("/api/admin/projects", status_code=201, summary="Create a project (admin)")
def admin_add_project(body: NewProject, _: AdminUser, session: SessionDep) -> m.ProjectOut:
    """Create a project; answers it. 403 for a non-admin, 409 for a name taken, 422 for a bad name."""
    p = ustore.create_project(session, body.name)
    session.commit()
    return {"id": p.id, "name": p.name, "members": [], "n_logs": 0}


@router.delete(
    "/api/admin/projects/{project_id}",
    summary="Delete a project (admin) with its logs, their stored files and every job computed from them",
)
def admin_delete_project(project_id: PathId, _: AdminUser, session: SessionDep) -> m.ProjectDeleted:
    """Delete a project with its logs, their stored files and every job computed from them; answers what was deleted.
    403 for a non-admin, 404 for no such project."""
    from ldvsurvey.store.models import Project

    p = session.get(Project, project_id)
    if p is None:
        raise HTTPException(404, f"project {project_id} not found")
    out = ustore.delete_project(session, p)
    session.commit()
    return out


@router.put("/api/admin/projects/{project_id}/members/{user_id}", summary="Add a member (admin)")
def admin_add_member(project_id: PathId, user_id: PathId, _: AdminUser, session: SessionDep) -> m.ProjectOut:
    """Make a user a member of a project; answers the project with its members. 403 for a non-admin, 404 for no such
    project or user."""
    return _change_member(session, project_id, user_id, ustore.add_member)


@router.delete("/api/admin/projects/{project_id}/members/{user_id}", summary="Remove a member (admin)")
def admin_remove_member(project_id: PathId, user_id: PathId, _: AdminUser, session: SessionDep) -> m.ProjectOut:
    """End a user's membership of a project; answers the project with its members. 403 for a non-admin, 404 for no such
    project or user."""
    return _change_member(session, project_id, user_id, ustore.remove_member)


def _change_member(session: Session, project_id: int, user_id: int, change) -> dict:
    """``change(session, user_id, project_id)`` after checking both exist; the project with its members."""
    from ldvsurvey.store.models import Project

    if session.get(Project, project_id) is None:
        raise HTTPException(404, f"project {project_id} not found")
    if session.get(User, user_id) is None:
        raise HTTPException(404, f"user {user_id} not found")
    change(session, user_id, project_id)
    session.commit()
    return next(p for p in ustore.list_projects(session, [project_id]))
