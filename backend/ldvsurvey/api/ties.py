"""``/api/projects/{id}/ties``: the base stations a project keeps for its gravity jobs.

Each station is checked by the gravity pipeline's own ``base_ties`` parser
(:func:`ldvsurvey.pipelines.ties.check_tie`): a refusal is a 422 naming the field, and nothing is
stored. Who may see the project's logs may see and change its stations; the demo account changes
only the stations it entered.
"""

from __future__ import annotations

from fastapi import APIRouter, HTTPException, Response
from pydantic import BaseModel, ConfigDict, Field
from sqlalchemy.orm import Session

from ldvsurvey.api import models as m
from ldvsurvey.api.auth import CurrentUser, Principal, refuse_demo
from ldvsurvey.api.deps import PathId, SessionDep
from ldvsurvey.pipelines.ties import NAME_MAX, NOTE_MAX, base_ties_text, check_tie
from ldvsurvey.store import ties as tstore
from ldvsurvey.store.models import Project, ProjectTie

router = APIRouter(tags=["ties"])


class TieIn(BaseModel):
    """A base station as entered (bounds: those of the ``base_ties`` parameter, checked by its parser;
    NaN and infinities pass here to be refused there, naming the field: pydantic's own refusal would
    echo a NaN that JSON cannot carry)."""

    model_config = ConfigDict(extra="forbid")

    name: str = Field(..., max_length=NAME_MAX, description="the station's name, unique in the project")
    lat_deg: float = Field(..., description="geodetic latitude (deg, -90 to 90)")
    lon_deg: float = Field(..., description="geodetic longitude (deg, -180 to 360)")
    h_m: float = Field(..., description="ellipsoidal height (m, WGS-84; not orthometric)")
    g_mgal: float = Field(..., description="absolute gravity (mGal, 976000 to 984000)")
    sigma_mgal: float = Field(..., description="1-σ of g_mgal (mGal, more than 0, at most 100)")
    note: str = Field("", max_length=NOTE_MAX, description="where the value comes from (free text)")


def _project(session: Session, who: Principal, project_id: int) -> Project:
    """The project if it exists and the principal may see it; 404 otherwise (no existence leak)."""
    p = session.get(Project, project_id)
    if p is None or (who.projects is not None and project_id not in who.projects):
        raise HTTPException(404, f"project {project_id} not found")
    return p


def _tie(session: Session, project_id: int, tie_id: int) -> ProjectTie:
    row = tstore.get_tie(session, project_id, tie_id)
    if row is None:
        raise HTTPException(404, f"base station {tie_id} not found in project {project_id}")
    return row


def _may_change(who: Principal, row: ProjectTie, what: str) -> None:
    """The demo account changes only the stations it entered (403 naming ``what`` otherwise)."""
    if who.user is not None and who.user.is_demo and row.user_id != who.user.id:
        refuse_demo(who, f"{what} a base station it did not enter")


@router.get("/api/projects/{project_id}/ties", summary="The project's base stations and their base_ties text")
def list_ties(project_id: PathId, session: SessionDep, who: CurrentUser) -> m.ProjectTies:
    """The project's base stations (lat/lon deg, ellipsoidal h m, absolute g and its 1-σ in mGal) and the
    ``base_ties`` text a gravity job takes (ties numbered T1… in this order). 404: no such project for you."""
    _project(session, who, project_id)
    rows = tstore.list_ties(session, project_id)
    return {"project_id": project_id, "ties": [tstore.tie_dict(r) for r in rows], "base_ties": base_ties_text(rows)}


@router.post(
    "/api/projects/{project_id}/ties",
    status_code=201,
    summary="Add a base station to the project",
    responses={409: {"description": "a station of that name is already in the project"}},
)
def add_tie(project_id: PathId, body: TieIn, session: SessionDep, who: CurrentUser) -> m.TieOut:
    """Add a station, checked as ``base_ties`` checks a tie. 422 naming the field, 409 a duplicate name,
    404 no such project for you; nothing is stored on an error."""
    _project(session, who, project_id)
    values = check_tie(**body.model_dump())
    row = tstore.add_tie(session, project_id, values, who.user.id if who.user is not None else None)
    return tstore.tie_dict(row)


@router.put("/api/projects/{project_id}/ties/{tie_id}", summary="Replace a base station's values")
def replace_tie(project_id: PathId, tie_id: PathId, body: TieIn, session: SessionDep, who: CurrentUser) -> m.TieOut:
    """Replace a station's values (checked as on add). 403 for the demo account on a station it did not
    enter, 404 no such station in the project, 409 a name another station has, 422 naming the field."""
    _project(session, who, project_id)
    row = _tie(session, project_id, tie_id)
    _may_change(who, row, "change")
    return tstore.tie_dict(tstore.update_tie(session, row, check_tie(**body.model_dump())))


@router.delete("/api/projects/{project_id}/ties/{tie_id}", status_code=204, summary="Remove a base station")
def delete_tie(project_id: PathId, tie_id: PathId, session: SessionDep, who: CurrentUser) -> Response:
    """Remove a station (204). 403 for the demo account on a station it did not enter, 404 no such
    station in the project. Jobs already run keep the ties they were given."""
    _project(session, who, project_id)
    row = _tie(session, project_id, tie_id)
    _may_change(who, row, "delete")
    tstore.delete_tie(session, row)
    return Response(status_code=204)
