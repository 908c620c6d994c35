"""What the server stores and what it cleaned up: ``GET /api/admin/storage`` (admins; everyone when
authentication is off)."""

from __future__ import annotations

from fastapi import APIRouter, HTTPException, Request

from ldvsurvey.api import models as m
from ldvsurvey.api.auth import CurrentUser
from ldvsurvey.api.deps import DatabaseUrlDep, SettingsDep

router = APIRouter(tags=["people"])


@router.get("/api/admin/storage", summary="Stored data, and leftovers of stopped uploads removed (admin)")
def storage(request: Request, who: CurrentUser, settings: SettingsDep, url: DatabaseUrlDep) -> m.StorageOut:
    """What the server stores (bytes of the stored logs' original files), the leftovers of stopped uploads this
    process removed since it started and when it last cleaned, and those found now (in progress).
    403 for a non-admin when authentication is on.
    """
    if settings.auth_enabled and (who.user is None or not who.user.is_admin):
        raise HTTPException(403, "only an admin may do this")
    from ldvsurvey.store.leftovers import folders_of, scan, stored_bytes

    report = request.app.state.leftovers
    _, busy = scan(*folders_of(settings), remove=False)
    return {
        "stored_bytes": stored_bytes(url),
        "leftovers_removed": report.total.as_dict(),
        "last_clean_at": report.last_at,
        "leftovers_now": busy.as_dict(),
    }
