"""Database-backed cache of synthesized DOV grids (used by the ``dov`` pipeline)."""

from __future__ import annotations

import numpy as np
from sqlalchemy import select
from sqlalchemy.exc import IntegrityError

from ldvsurvey.nav.dovgrid import DovGrid
from ldvsurvey.store.blobs import from_parquet, to_parquet
from ldvsurvey.store.db import session_scope
from ldvsurvey.store.models import DovGridRow


class DbGridCache:
    """get(key) -> DovGrid | None; put(key, grid). One row per key."""

    def __init__(self, database_url: str):
        self.url = database_url

    def get(self, key: str) -> DovGrid | None:
        """The grid stored under ``key`` (nodes in deg, ξ and η in arcsec, Δg in mGal), or None."""
        with session_scope(self.url) as s:
            row = s.scalar(select(DovGridRow).where(DovGridRow.key == key))
            if row is None:
                return None
            a = from_parquet(row.parquet)
            n_lat, n_lon, source = row.n_lat, row.n_lon, row.source
        lat = a["lat_deg"].reshape(n_lat, n_lon)[:, 0]
        lon = a["lon_deg"].reshape(n_lat, n_lon)[0]
        return DovGrid(
            lat,
            lon,
            a["xi_arcsec"].reshape(n_lat, n_lon),
            a["eta_arcsec"].reshape(n_lat, n_lon),
            a["dg_mgal"].reshape(n_lat, n_lon) if "dg_mgal" in a else None,
            source=source,
        )

    def put(self, key: str, grid: DovGrid) -> None:
        """Store ``grid`` under ``key`` (as Parquet columns); a grid stored concurrently under the same key is kept."""
        gl, go = np.meshgrid(grid.lat_deg, grid.lon_deg, indexing="ij")
        cols = {
            "lat_deg": gl.ravel(),
            "lon_deg": go.ravel(),
            "xi_arcsec": grid.xi_arcsec.ravel(),
            "eta_arcsec": grid.eta_arcsec.ravel(),
        }
        if grid.dg_mgal is not None:
            cols["dg_mgal"] = grid.dg_mgal.ravel()
        try:
            with session_scope(self.url) as s:
                s.add(
                    DovGridRow(
                        key=key,
                        source=grid.source,
                        n_lat=len(grid.lat_deg),
                        n_lon=len(grid.lon_deg),
                        parquet=to_parquet(cols),
                    )
                )
        except IntegrityError:  # computed concurrently by another job: keep the first
            pass
