"""``/api/grids``: upload ICGEM ``.gdf`` deflection grids (ξ, η in arcsec, optionally Δg in mGal) for
the pipelines' ``dov=grid``; a job names the upload by ``dov_grid_id``.

The grids are validated on upload (errors name file, line and field; nothing is stored then) and
kept in the database's grid table under the key ``upload:<id>``; the id is a random token.
"""

from __future__ import annotations

import secrets

import numpy as np
from fastapi import APIRouter, File, HTTPException, Request, UploadFile

from ldvsurvey.api import models as m
from ldvsurvey.api.auth import CurrentUser, check_upload_rate
from ldvsurvey.api.deps import DatabaseUrlDep, SettingsDep
from ldvsurvey.errors import BundleError
from ldvsurvey.io.gdf import parse_gdf
from ldvsurvey.nav.dovgrid import DovGrid

router = APIRouter(prefix="/api/grids", tags=["grids"])
KEY_PREFIX = "upload:"


def _read(up: UploadFile | None, field: str, required: bool):
    if up is None:
        if required:
            raise BundleError(
                f"the '{field}' grid is missing (send xi, eta and optionally dg as .gdf files)", field=field
            )
        return None
    name = (up.filename or f"{field}.gdf").replace("\\", "/").rsplit("/", 1)[-1]
    data = up.file.read()
    return name, parse_gdf(data, name)


@router.post("", status_code=201, summary="Upload ξ, η (and Δg) .gdf grids for dov=grid")
def upload_grids(
    request: Request,
    xi: UploadFile | None = File(None, description="ξ grid, arcsec"),
    eta: UploadFile | None = File(None, description="η grid, arcsec"),
    dg: UploadFile | None = File(None, description="Δg grid, mGal (optional)"),
    *,
    who: CurrentUser,
    st: SettingsDep,
    url: DatabaseUrlDep,
) -> m.GridUploaded:
    """Store uploaded ``.gdf`` grids of the deflection of the vertical (ξ, η, arcsec; optionally the
    gravity disturbance Δg, mGal) on one set of nodes, for jobs run with ``dov=grid``. Answers the
    grid's id, its extent (deg), node spacing (arcmin) and the parameters that use it. 422 naming the
    file and field for a missing or malformed grid or nodes that differ between grids; 429 past the
    upload rate.
    """
    check_upload_rate(request, who, st)
    parts = [(f, _read(up, f, f != "dg")) for f, up in (("xi", xi), ("eta", eta), ("dg", dg))]
    parts = [(f, p) for f, p in parts if p is not None]
    (_, (name0, (_, lat, lon, v_xi))) = parts[0]
    for f, (name, (_, la, lo, v)) in parts[1:]:
        if v.shape != v_xi.shape or not (np.allclose(la, lat) and np.allclose(lo, lon)):
            raise BundleError(f"the grid's nodes differ from those of {name0}", file=name, field=f)
    vals = {f: p[1][3] for f, p in parts}
    grid = DovGrid(lat, lon, vals["xi"], vals["eta"], vals.get("dg"), source=", ".join(p[0] for _, p in parts))
    gid = secrets.token_hex(12)
    from ldvsurvey.store.gridcache import DbGridCache

    DbGridCache(url).put(KEY_PREFIX + gid, grid)
    return {
        "id": gid,
        "source": grid.source,
        "lat_deg": [float(lat[0]), float(lat[-1])],
        "lon_deg": [float(lon[0]), float(lon[-1])],
        "step_arcmin": grid.step_arcmin,
        "has_dg": grid.dg_mgal is not None,
        "use": {"dov": "grid", "dov_grid_id": gid},
    }


@router.get("/{grid_id}", summary="An uploaded grid's extent")
def grid_info(grid_id: str, who: CurrentUser, url: DatabaseUrlDep) -> m.GridInfo:
    """An uploaded grid's source, extent (deg), node spacing (arcmin) and whether it holds Δg. 404 when there is no such
    grid."""
    from ldvsurvey.store.gridcache import DbGridCache

    g = DbGridCache(url).get(KEY_PREFIX + grid_id) if grid_id.isalnum() else None
    if g is None:
        raise HTTPException(404, f"grid {grid_id} not found")
    return {
        "id": grid_id,
        "source": g.source,
        "lat_deg": [float(g.lat_deg[0]), float(g.lat_deg[-1])],
        "lon_deg": [float(g.lon_deg[0]), float(g.lon_deg[-1])],
        "step_arcmin": g.step_arcmin,
        "has_dg": g.dg_mgal is not None,
    }
