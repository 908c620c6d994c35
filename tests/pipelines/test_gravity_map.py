"""The gridded map (pipelines/gravity/map.py): a known field sampled along a grid of crossing roads."""

import io

import numpy as np
import pytest

from ldvsurvey.nav.earth import radii
from ldvsurvey.pipelines.gravity.map import survey_grid

LAT0, LON0 = 28.5, 113.0


def field(e, n):
    return 5.0 + 8.0 * np.sin(2 * np.pi * (0.6 * e + 0.8 * n) / 20000.0) + 2.0 * np.cos(2 * np.pi * e / 12000.0)


def tracks():
    """Six east-west and six north-south roads, 2 km apart, 10 km long, a sample every 15 m."""
    s = np.arange(-5000.0, 5000.0, 15.0)
    e = np.concatenate([s for _ in range(6)] + [np.full_like(s, x) for x in np.linspace(-5000, 5000, 6)])
    n = np.concatenate([np.full_like(s, y) for y in np.linspace(-5000, 5000, 6)] + [s for _ in range(6)])
    rm, rn = radii(np.radians(LAT0))
    lat = LAT0 + np.degrees(n / rm)
    lon = LON0 + np.degrees(e / (rn * np.cos(np.radians(LAT0))))
    return lat, lon, e, n


def test_map_reproduces_the_field_inside_the_hull():
    xr = pytest.importorskip("xarray")
    lat, lon, e, n = tracks()
    data, info = survey_grid(lat, lon, field(e, n), resolution_m=2000.0, provenance={"software_version": "x"})
    assert info["gridded"] and info["cv_rmse_mgal"] < 1.0
    ds = xr.open_dataset(io.BytesIO(data), engine="scipy")
    g = ds["dg_mgal"].values
    assert ds["dg_mgal"].attrs["units"] == "mGal" and ds.attrs["cv_rmse_mgal"] == pytest.approx(info["cv_rmse_mgal"])
    rm, rn = radii(np.radians(LAT0))
    glat, glon = np.meshgrid(ds["lat"].values, ds["lon"].values, indexing="ij")
    ge = np.radians(glon - LON0) * rn * np.cos(np.radians(LAT0))
    gn = np.radians(glat - LAT0) * rm
    inside = np.isfinite(g)
    assert inside.sum() > 0.6 * g.size
    err = g[inside] - field(ge[inside], gn[inside])
    # between roads 2 km apart on a 3-mGal/km field: within a few times the cross-validated error
    assert np.sqrt(np.mean(err**2)) < 3 * info["cv_rmse_mgal"] + 0.1
    # outside the hull: no values
    assert not np.isfinite(g[(np.abs(ge) > 5200) | (np.abs(gn) > 5200)]).any()


def test_too_few_values_give_no_map():
    data, info = survey_grid(np.array([28.5, 28.6]), np.array([113.0, 113.1]), np.array([1.0, 2.0]), 2000.0)
    assert data is None and not info["gridded"]
