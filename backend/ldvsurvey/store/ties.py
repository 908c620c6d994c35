"""Queries of a project's base stations (:class:`ldvsurvey.store.models.ProjectTie`).

The values are checked before they come here (:func:`ldvsurvey.pipelines.ties.check_tie`); a
second station of the same name in a project is refused here, naming the field, before anything
is written.
"""

from __future__ import annotations

from sqlalchemy import select
from sqlalchemy.orm import Session

from ldvsurvey.errors import InputError
from ldvsurvey.store.models import ProjectTie


class DuplicateTie(InputError):
    """A station name already used in the project (HTTP 409)."""

    status_code = 409


def list_ties(s: Session, project_id: int) -> list[ProjectTie]:
    """The project's stations in the order they were entered (the n-th is a job's Tn)."""
    return list(s.scalars(select(ProjectTie).where(ProjectTie.project_id == project_id).order_by(ProjectTie.id)))


def get_tie(s: Session, project_id: int, tie_id: int) -> ProjectTie | None:
    """The station ``tie_id`` if it belongs to the project."""
    row = s.get(ProjectTie, tie_id)
    return row if row is not None and row.project_id == project_id else None


def _unique(s: Session, project_id: int, name: str, tie_id: int | None = None) -> None:
    other = s.scalar(select(ProjectTie).where(ProjectTie.project_id == project_id, ProjectTie.name == name))
    if other is not None and other.id != tie_id:
        raise DuplicateTie(f"the project already has a station named {name!r} (id {other.id})", field="name")


def add_tie(s: Session, project_id: int, values: dict, user_id: int | None = None) -> ProjectTie:
    """Store a checked station (``values`` from ``check_tie``) in the project."""
    _unique(s, project_id, values["name"])
    row = ProjectTie(project_id=project_id, user_id=user_id, **values)
    s.add(row)
    s.flush()
    return row


def update_tie(s: Session, row: ProjectTie, values: dict) -> ProjectTie:
    """Replace a station's values by checked ones."""
    _unique(s, row.project_id, values["name"], row.id)
    for k, v in values.items():
        setattr(row, k, v)
    s.flush()
    return row


def delete_tie(s: Session, row: ProjectTie) -> None:
    """Remove a station."""
    s.delete(row)
    s.flush()


def tie_dict(row: ProjectTie) -> dict:
    """A station as the API and the CLI show it."""
    return {
        "id": row.id,
        "project_id": row.project_id,
        "name": row.name,
        "lat_deg": row.lat_deg,
        "lon_deg": row.lon_deg,
        "h_m": row.h_m,
        "g_mgal": row.g_mgal,
        "sigma_mgal": row.sigma_mgal,
        "note": row.note,
        "created_at": row.created_at.isoformat(timespec="seconds") if row.created_at else None,
    }
