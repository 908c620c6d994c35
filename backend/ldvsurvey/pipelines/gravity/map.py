"""The gridded map of an adjusted gravity survey (verde), inside the survey's hull, as netCDF.

The adjusted δg (1 Hz along the lines) is block-averaged at half the survey's half-wavelength
resolution (neighbouring samples of a line are correlated over the filter anyway), interpolated by
verde's biharmonic spline (the damping chosen by blocked cross-validation among a few values) on a
grid at half the resolution, masked outside the convex hull of the tracks, and written with the
cross-validated RMS error (blocks of twice the resolution left out in turn: the interpolation's error
across gaps of that size, not the error on a track) and each node's distance to the nearest data.
The grid is regular in a local east/north frame about the survey's centre, which for a survey of tens
of km is regular in latitude and longitude too (the small-area projection is linear in both).
"""

from __future__ import annotations

import numpy as np

from ldvsurvey.nav.earth import radii

#: fewer blocks than this: no map (a spline through a handful of points maps nothing)
MIN_BLOCKS = 10
#: damping values the cross-validation chooses from
DAMPINGS = (1e-6, 1e-4, 1e-2)


def survey_grid(lat_deg, lon_deg, dg_mgal, resolution_m: float, provenance: dict | None = None):
    """(netCDF bytes, summary dict) of the gridded map; (None, dict with the reason) when too few data."""
    import warnings

    import verde as vd
    import xarray as xr
    from scipy.spatial import cKDTree

    with warnings.catch_warnings():  # verde's Spline warns of its own deprecated mindist when sklearn clones it
        warnings.simplefilter("ignore", FutureWarning)
        return _grid(vd, xr, cKDTree, lat_deg, lon_deg, dg_mgal, resolution_m, provenance)


def _grid(vd, xr, cKDTree, lat_deg, lon_deg, dg_mgal, resolution_m, provenance):
    ok = np.isfinite(lat_deg) & np.isfinite(lon_deg) & np.isfinite(dg_mgal)
    la, lo, v = np.asarray(lat_deg)[ok], np.asarray(lon_deg)[ok], np.asarray(dg_mgal)[ok]
    if len(v) < MIN_BLOCKS:
        return None, {"gridded": False, "reason": "too few adjusted values"}
    lat0, lon0 = np.radians(np.mean(la)), np.radians(np.mean(lo))
    rm, rn = radii(lat0)
    ke, kn = rn * np.cos(lat0) * np.pi / 180.0, rm * np.pi / 180.0  # metres per degree
    e, n = (lo - np.degrees(lon0)) * ke, (la - np.degrees(lat0)) * kn
    block = resolution_m / 2.0
    (be, bn), bv = vd.BlockReduce(np.mean, spacing=block).filter((e, n), v)
    if len(bv) < MIN_BLOCKS:
        return None, {"gridded": False, "reason": f"fewer than {MIN_BLOCKS} blocks of {block:.0f} m"}
    cv = vd.BlockKFold(spacing=2.0 * resolution_m, n_splits=5, shuffle=True, random_state=0)
    scores = {}
    for d in DAMPINGS:
        s = vd.cross_val_score(vd.Spline(damping=d), (be, bn), bv, cv=cv, scoring="neg_root_mean_squared_error")
        scores[d] = float(-np.mean(s))
    damping = min(scores, key=scores.get)
    spline = vd.Spline(damping=damping).fit((be, bn), bv)
    step = resolution_m / 2.0
    region = vd.get_region((e, n))
    ge, gn = vd.grid_coordinates(region, spacing=step)
    g = spline.predict((ge, gn))
    inside = vd.convexhull_mask((e, n), coordinates=(ge, gn))
    g = np.where(inside, g, np.nan)
    dist, _ = cKDTree(np.column_stack([e, n])).query(np.column_stack([ge.ravel(), gn.ravel()]))
    dist = np.where(inside, dist.reshape(ge.shape), np.nan)
    lat_nodes = np.degrees(lat0) + gn[:, 0] / kn
    lon_nodes = np.degrees(lon0) + ge[0, :] / ke
    attrs = {
        "title": "adjusted gravity disturbance, gridded inside the survey's hull",
        "method": f"verde block mean ({block:.0f} m), biharmonic spline (damping {damping:g}, chosen by "
        "blocked cross-validation), convex-hull mask",
        "cv_rmse_mgal": scores[damping],
        "cv_block_m": 2.0 * resolution_m,
        "resolution_m": resolution_m,
        "grid_step_m": step,
        "crs": "WGS-84 geodetic latitude, longitude (degrees)",
    }
    for k, val in (provenance or {}).items():
        attrs[f"provenance_{k}"] = str(val)
    ds = xr.Dataset(
        {
            "dg_mgal": (("lat", "lon"), g, {"units": "mGal", "long_name": "gravity disturbance (adjusted)"}),
            "distance_to_data_m": (("lat", "lon"), dist, {"units": "m", "long_name": "distance to the nearest track"}),
        },
        coords={
            "lat": ("lat", lat_nodes, {"units": "degrees_north"}),
            "lon": ("lon", lon_nodes, {"units": "degrees_east"}),
        },
        attrs=attrs,
    )
    data = bytes(ds.to_netcdf(engine="scipy"))
    summary = {
        "gridded": True,
        "file": "gravity_grid.nc",
        "n_blocks": int(len(bv)),
        "nodes": [int(g.shape[0]), int(g.shape[1])],
        "nodes_inside_hull": int(np.count_nonzero(inside)),
        "grid_step_m": step,
        "resolution_m": resolution_m,
        "damping": damping,
        "cv_rmse_mgal": scores[damping],
        "cv_block_m": 2.0 * resolution_m,
        "cv_rmse_by_damping_mgal": {f"{d:g}": s for d, s in scores.items()},
        "note": "cross-validated error: whole blocks of twice the resolution left out in turn, so it is the "
        "interpolation's error across gaps of that size (between roads it is larger still; see "
        "distance_to_data_m), not the error on the tracks",
    }
    return data, summary
