"""ICGEM calculation-service ``.gdf`` grids: keyword header ending in ``end_of_head``, then rows
``lon lat value`` (or ``lon lat h value``), longitude fastest, latitude from north to south."""

from __future__ import annotations

import numpy as np

from ldvsurvey.errors import BundleError

REQUIRED = (
    "latitude_parallels",
    "longitude_parallels",
    "latlimit_north",
    "latlimit_south",
    "longlimit_west",
    "longlimit_east",
)


def parse_gdf(data: bytes, name: str = "grid.gdf"):
    """Parse a ``.gdf`` file into (header dict, lat ascending, lon ascending, values (n_lat, n_lon)).

    Raises
    ------
    BundleError
        Missing ``end_of_head`` or keywords, wrong point count, rows out of grid order,
        non-numeric values, gap values inside the grid.
    """
    if not data.strip():
        raise BundleError("file is empty", file=name, line=1)
    text = data.decode("utf-8", "replace")
    lines = text.splitlines()
    end = next((i for i, ln in enumerate(lines) if ln.strip().startswith("end_of_head")), None)
    if end is None:
        raise BundleError("no 'end_of_head' line: not an ICGEM .gdf grid", file=name)
    header = {}
    for ln in lines[:end]:
        parts = ln.split()
        if len(parts) >= 2 and parts[0][0].isalpha() and parts[0] not in header:
            header[parts[0]] = " ".join(parts[1:])
    for k in REQUIRED:
        if k not in header:
            raise BundleError(f"keyword '{k}' missing from the header", file=name, field=k)
    try:
        n_lat = int(header["latitude_parallels"].split()[0])
        n_lon = int(header["longitude_parallels"].split()[0])
        north, south = float(header["latlimit_north"].split()[0]), float(header["latlimit_south"].split()[0])
        west, east = float(header["longlimit_west"].split()[0]), float(header["longlimit_east"].split()[0])
    except ValueError:
        raise BundleError("a grid keyword is not a number", file=name, field="latitude_parallels") from None
    gap = float(header.get("gapvalue", "nan").split()[0]) if "gapvalue" in header else None
    rows = []
    for i, ln in enumerate(lines[end + 1 :], start=end + 2):
        parts = ln.split()
        if not parts:
            continue
        try:
            vals = [float(x) for x in parts]
        except ValueError:
            raise BundleError(f"'{ln.strip()[:40]}' is not numeric", file=name, line=i) from None
        if len(vals) not in (3, 4):
            raise BundleError(f"expected 3 or 4 columns (lon lat [h] value), found {len(vals)}", file=name, line=i)
        rows.append((vals[0], vals[1], vals[-1], i))
    expected = n_lat * n_lon
    if "number_of_gridpoints" in header and int(header["number_of_gridpoints"].split()[0]) != expected:
        raise BundleError(
            f"number_of_gridpoints {header['number_of_gridpoints']} ≠ {n_lat}×{n_lon}",
            file=name,
            field="number_of_gridpoints",
        )
    if len(rows) != expected:
        raise BundleError(
            f"{len(rows)} grid points but the header promises {n_lat}×{n_lon} = {expected}",
            file=name,
            field="latitude_parallels",
        )
    a = np.array([r[:3] for r in rows])
    lon = a[:n_lon, 0]
    lat_desc = a[::n_lon, 1]
    grid_lon = np.tile(lon, n_lat)
    grid_lat = np.repeat(lat_desc, n_lon)
    bad = np.flatnonzero((np.abs(a[:, 0] - grid_lon) > 1e-6) | (np.abs(a[:, 1] - grid_lat) > 1e-6))
    if len(bad) or not np.all(np.diff(lon) > 0) or not np.all(np.diff(lat_desc) < 0):
        line = rows[int(bad[0])][3] if len(bad) else end + 2
        raise BundleError(
            "rows are not a regular grid with longitude fastest and latitude from north to south", file=name, line=line
        )
    if (
        abs(lat_desc[0] - north) > 1e-6
        or abs(lat_desc[-1] - south) > 1e-6
        or abs(lon[0] - west) > 1e-6
        or abs(lon[-1] - east) > 1e-6
    ):
        raise BundleError(
            "grid rows do not match latlimit_*/longlimit_* of the header", file=name, field="latlimit_north"
        )
    values = a[:, 2].reshape(n_lat, n_lon)
    if gap is not None and np.any(values == gap):
        k = int(np.flatnonzero(values.ravel() == gap)[0])
        raise BundleError("gap value inside the grid", file=name, line=rows[k][3])
    return header, lat_desc[::-1].copy(), lon.copy(), values[::-1].copy()


def write_gdf(lat_deg, lon_deg, values, functional: str, unit: str) -> bytes:
    """A ``.gdf`` file (for tests and for exporting grids).

    Parameters
    ----------
    lat_deg, lon_deg : (n_lat,), (n_lon,) arrays
        The grid's WGS-84 latitudes and longitudes, deg, ascending.
    values : (n_lat, n_lon) array
        The grid's values in ``unit``.
    functional : str
        What the values are (the ``functional`` keyword, e.g. ``gravity_disturbance``).
    unit : str
        Their unit (the ``unit`` keyword, e.g. ``mGal``).

    Returns
    -------
    bytes
        The file's text: ICGEM header, then one ``lon lat value`` row per point, north to south.
    """
    lat = np.asarray(lat_deg)
    lon = np.asarray(lon_deg)
    head = [
        "generating_institute     ldv-survey",
        f"functional               {functional}",
        f"unit                     {unit}",
        "refsysname               WGS84",
        f"latlimit_north           {lat[-1]:.6f}",
        f"latlimit_south           {lat[0]:.6f}",
        f"longlimit_west           {lon[0]:.6f}",
        f"longlimit_east           {lon[-1]:.6f}",
        f"gridstep                 {np.median(np.diff(lat)):.8f}",
        f"latitude_parallels       {len(lat)}",
        f"longitude_parallels      {len(lon)}",
        f"number_of_gridpoints     {len(lat) * len(lon)}",
        "gapvalue                 9999999",
        "",
        "  longitude    latitude    value",
        "   [deg.]       [deg.]     [" + unit + "]",
        "end_of_head " + "=" * 40,
    ]
    body = []
    for i in range(len(lat) - 1, -1, -1):
        for j in range(len(lon)):
            body.append(f"{lon[j]:11.6f} {lat[i]:11.6f} {values[i, j]:14.8f}")
    return ("\n".join(head + body) + "\n").encode()
