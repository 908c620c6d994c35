"""Writers for the ``ldv-drive-log/1`` files (used by the simulator, the demo and tests)."""

from __future__ import annotations

import io
import json
import zipfile
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.csv as pacsv

from ldvsurvey.io.nmea import format_gga


def csv_bytes(columns: dict[str, np.ndarray], comment: str | None = None) -> bytes:
    """Numeric columns to CSV bytes (shortest round-trip float text), optional ``#`` comment first."""
    arrays = []
    for v in columns.values():  # from the buffers: pa.table/pa.array of a numpy array import pandas (0.2 s)
        c = np.ascontiguousarray(v, dtype=np.float64)
        if c.ndim != 1:
            raise ValueError(f"a column must be 1-D, got shape {c.shape}")
        arrays.append(pa.Array.from_buffers(pa.float64(), len(c), [None, pa.py_buffer(c)]))
    table = pa.Table.from_arrays(arrays, names=list(columns))
    buf = io.BytesIO()
    if comment:
        buf.write(f"# {comment}\n".encode())
    buf.write((",".join(table.column_names) + "\n").encode())
    pacsv.write_csv(table, buf, write_options=pacsv.WriteOptions(include_header=False, quoting_style="none"))
    return buf.getvalue()


def imu_csv(t_s, dtheta_rad, dvel_mps, turntable_deg=None, comment=None) -> bytes:
    """``imu.csv`` bytes (columns ``t``, ``dtheta_x..z``, ``dvel_x..z``, optional ``turntable_deg``).

    Parameters
    ----------
    t_s : (N,) array
        Times on the bundle clock, s.
    dtheta_rad, dvel_mps : (N, 3) arrays
        Angle increments (rad) and velocity increments (m/s) over (t_prev, t], bundle axes.
    turntable_deg : (N,) array, optional
        Turntable angle, deg (a rotating IMU).
    comment : str, optional
        A ``#`` comment line written first.

    Returns
    -------
    bytes
        The CSV text (shortest round-trip float text).
    """
    cols = {
        "t": t_s,
        "dtheta_x": dtheta_rad[:, 0],
        "dtheta_y": dtheta_rad[:, 1],
        "dtheta_z": dtheta_rad[:, 2],
        "dvel_x": dvel_mps[:, 0],
        "dvel_y": dvel_mps[:, 1],
        "dvel_z": dvel_mps[:, 2],
    }
    if turntable_deg is not None:
        cols["turntable_deg"] = turntable_deg
    return csv_bytes(cols, comment)


def ldv_csv(t_s, v_fwd_mps=None, v_up_mps=None, quality=None, fd_hz=None, comment=None) -> bytes:
    """``ldv.csv`` bytes; give either ``v_fwd_mps`` or ``fd_hz``.

    Parameters
    ----------
    t_s : (N,) array
        Times on the bundle clock, s.
    v_fwd_mps, v_up_mps : (N,) arrays, optional
        Forward and vertical velocity, m/s (``v_fwd`` is left out when ``fd_hz`` is given).
    quality : (N,) array, optional
        The LDV's signal quality figure.
    fd_hz : (N,) array, optional
        Doppler frequency, Hz (converted with the manifest optics when the bundle is read).
    comment : str, optional
        A ``#`` comment line written first.

    Returns
    -------
    bytes
        The CSV text.
    """
    cols = {"t": t_s}
    if fd_hz is not None:
        cols["fd_hz"] = fd_hz
    else:
        cols["v_fwd"] = v_fwd_mps
    if v_up_mps is not None:
        cols["v_up"] = v_up_mps
    if quality is not None:
        cols["quality"] = quality
    return csv_bytes(cols, comment)


def nmea_text(
    t_s, lat_deg, lon_deg, h_ell_m, fix, sep_m: float = -16.0, talker: str = "GP", extra_sentences: bool = True
) -> bytes:
    """``gnss.nmea`` bytes: one GGA per epoch (altitude = ellipsoidal height − separation), CRLF.

    Parameters
    ----------
    t_s : (N,) array
        UTC times, s of day (past 86400 after midnight; written modulo one day).
    lat_deg, lon_deg : (N,) arrays
        WGS-84 latitude and longitude, deg.
    h_ell_m : (N,) array
        Ellipsoidal height, m.
    fix : (N,) array
        GGA fix quality.
    sep_m : float
        Geoid separation written in every sentence, m.
    talker : str
        Talker ID of the sentences.
    extra_sentences : bool
        A GSA sentence after every GGA (as receivers write; the reader skips it).

    Returns
    -------
    bytes
        The NMEA text.
    """
    lines = []
    for k in range(len(t_s)):
        lines.append(
            format_gga(
                float(t_s[k]),
                float(lat_deg[k]),
                float(lon_deg[k]),
                float(h_ell_m[k]) - sep_m,
                sep_m,
                int(fix[k]),
                talker=talker,
            )
        )
        if extra_sentences:
            body = f"{talker}GSA,A,3,01,02,03,04,05,06,07,08,,,,,1.5,0.9,1.2"
            acc = 0
            for ch in body.encode():
                acc ^= ch
            lines.append(f"${body}*{acc:02X}")
    return ("\r\n".join(lines) + "\r\n").encode()


def manifest_json(manifest: dict) -> bytes:
    """``manifest.json`` bytes: the manifest as indented JSON with a final line end."""
    return (json.dumps(manifest, indent=2) + "\n").encode()


def write_bundle(files: dict[str, bytes], path: str | Path) -> Path:
    """Write ``{name: bytes}`` as a folder, or as a zip when ``path`` ends in ``.zip``."""
    p = Path(path)
    if p.suffix.lower() == ".zip":
        p.parent.mkdir(parents=True, exist_ok=True)
        with zipfile.ZipFile(p, "w", compression=zipfile.ZIP_DEFLATED, compresslevel=1) as zf:
            for name, data in files.items():
                zf.writestr(name, data)
    else:
        p.mkdir(parents=True, exist_ok=True)
        for name, data in files.items():
            (p / name).write_bytes(data)
    return p


# --- GIS exports: GeoJSON (RFC 7946) and KML 2.2 of the result tables ---------------------------------

GEO_FORMATS = ("geojson", "kml")
#: tables drawn as one line (a track); others are points with their values
TRACK_TABLES = ("trajectory", "calibration_track")
MAX_FEATURES = 20000
KML_NS = "http://www.opengis.net/kml/2.2"


def read_result_table(data: bytes) -> dict[str, np.ndarray]:
    """A result CSV (header row, numbers or text, empty = missing) as columns."""
    import pandas as pd

    df = pd.read_csv(io.BytesIO(data), comment="#")
    return {c: df[c].to_numpy() for c in df.columns}


def provenance(summary: dict) -> dict:
    """What every export carries: the keys of ``summary.json`` that trace a result to its inputs."""
    keys = ("pipeline", "software_version", "format_version", "started_at", "inputs", "parameters")
    return {k: summary.get(k) for k in keys if k in summary}


def _positions(cols: dict, track: dict | None):
    """lon, lat, h (h may be None) of each row; rows without a position are NaN.

    Tables without positions (``height.csv``) are placed on ``track`` (t_s, lat_deg, lon_deg of the
    log's GNSS fixes), linearly interpolated in time.
    """
    if "lat_deg" in cols and "lon_deg" in cols:
        lat = np.asarray(cols["lat_deg"], float)
        lon = np.asarray(cols["lon_deg"], float)
    elif track is not None and "t_s" in cols and len(track["t_s"]) > 1:
        t = np.asarray(cols["t_s"], float)
        inside = (t >= track["t_s"][0]) & (t <= track["t_s"][-1])
        lat = np.where(inside, np.interp(t, track["t_s"], track["lat_deg"]), np.nan)
        lon = np.where(inside, np.interp(t, track["t_s"], track["lon_deg"]), np.nan)
    else:
        return None
    h = np.asarray(cols["h_m"], float) if "h_m" in cols else None
    return lon, lat, h


def _thin(n: int) -> np.ndarray:
    step = max(1, int(np.ceil(n / MAX_FEATURES)))
    idx = np.arange(0, n, step)
    if n and idx[-1] != n - 1:
        idx = np.append(idx, n - 1)
    return idx


def _jsonval(v):
    if isinstance(v, (np.floating, float)):
        return float(v) if np.isfinite(v) else None
    if isinstance(v, (np.integer,)):
        return int(v)
    if isinstance(v, (np.bool_,)):
        return bool(v)
    if v is None or (isinstance(v, float) and not np.isfinite(v)):
        return None
    return v if isinstance(v, (str, int, bool)) else str(v)


def geo_features(table: str, cols: dict, summary: dict, track: dict | None = None) -> list[dict]:
    """GeoJSON features of one result table (positions WGS-84 lon, lat; heights ellipsoidal, m).

    Track tables become one LineString; tables with a ``line`` column add one LineString per survey
    line (with that line's summary figures); every other row becomes a Point with all its values.
    """
    pos = _positions(cols, track)
    if pos is None:
        from ldvsurvey.errors import InputError

        raise InputError(
            f"'{table}' has no positions (no lat_deg/lon_deg and no GNSS track to place it on)", file=f"{table}.csv"
        )
    lon, lat, h = pos
    ok = np.isfinite(lon) & np.isfinite(lat)

    def coord(i):
        c = [round(float(lon[i]), 9), round(float(lat[i]), 9)]
        if h is not None and np.isfinite(h[i]):
            c.append(round(float(h[i]), 4))
        return c

    feats = []
    good = np.flatnonzero(ok)
    if table in TRACK_TABLES:
        idx = good[_thin(len(good))]
        if len(idx) < 2:  # RFC 7946: a line has two positions at least
            return feats
        t = np.asarray(cols.get("t_s", np.full(len(lon), np.nan)), float)
        props = {"name": table, "kind": "track", "t_start_s": _jsonval(t[idx[0]]), "t_end_s": _jsonval(t[idx[-1]])}
        if "gps_week" in cols and "gps_sow_s" in cols:  # the same two instants in GPS time
            for end, i in (("start", idx[0]), ("end", idx[-1])):
                props[f"gps_week_{end}"] = _jsonval(np.asarray(cols["gps_week"])[i])
                props[f"gps_sow_{end}_s"] = _jsonval(np.asarray(cols["gps_sow_s"])[i])
        feats.append(
            {
                "type": "Feature",
                "geometry": {"type": "LineString", "coordinates": [coord(i) for i in idx]},
                "properties": props,
            }
        )
        return feats
    if "line" in cols:
        by_name = {ln.get("name"): ln for ln in (summary.get("lines") or []) if isinstance(ln, dict)}
        names = np.asarray(cols["line"]).astype(str)
        for name in dict.fromkeys(names[good]):
            sel = good[names[good] == name]
            idx = sel[_thin(len(sel))]
            if len(idx) < 2:
                continue
            props = {"name": str(name), "kind": "survey_line"}
            props.update({k: _jsonval(v) for k, v in by_name.get(name, {}).items() if k != "name"})
            feats.append(
                {
                    "type": "Feature",
                    "properties": props,
                    "geometry": {"type": "LineString", "coordinates": [coord(i) for i in idx]},
                }
            )
    for i in good[_thin(len(good))]:
        props = {k: _jsonval(np.asarray(v)[i]) for k, v in cols.items()}
        feats.append({"type": "Feature", "geometry": {"type": "Point", "coordinates": coord(i)}, "properties": props})
    return feats


def table_geojson(table: str, csv_data: bytes, summary: dict, track: dict | None = None) -> bytes:
    """A result table as an RFC 7946 FeatureCollection carrying the result's provenance."""
    feats = geo_features(table, read_result_table(csv_data), summary, track)
    fc = {
        "type": "FeatureCollection",
        "name": table,
        "provenance": provenance(summary),  # a foreign member (RFC 7946 §6.1): ignored by readers that don't know it
        "features": feats,
    }
    return (json.dumps(fc, allow_nan=False, separators=(",", ":")) + "\n").encode()


def table_kml(table: str, csv_data: bytes, summary: dict, track: dict | None = None) -> bytes:
    """A result table as a KML 2.2 document (lines and placemarks, values and provenance as ExtendedData).

    Coordinates carry longitude and latitude only and are clamped to the ground: KML altitudes are
    above mean sea level, our heights ellipsoidal, so heights go into ExtendedData (``h_m``).
    """
    from xml.sax.saxutils import escape

    feats = geo_features(table, read_result_table(csv_data), summary, track)
    prov = provenance(summary)

    def data(items):
        return (
            "<ExtendedData>"
            + "".join(
                f'<Data name="{escape(str(k))}">'
                f"<value>{escape(v if isinstance(v, str) else json.dumps(v))}</value></Data>"
                for k, v in items.items()
            )
            + "</ExtendedData>"
        )

    def coords(cs):
        return " ".join(f"{c[0]!r},{c[1]!r}" for c in cs)

    out = [
        '<?xml version="1.0" encoding="UTF-8"?>',
        f'<kml xmlns="{KML_NS}">',
        "<Document>",
        f"<name>{escape(table)}</name>",
        "<description>"
        + escape(
            f"ldv-survey {prov.get('pipeline', '')} result {table}; heights are "
            "ellipsoidal (WGS-84), in ExtendedData h_m"
        )
        + "</description>",
        '<Style id="line"><LineStyle><color>ff0000ff</color><width>3</width></LineStyle></Style>',
        '<Style id="point"><IconStyle><scale>0.4</scale></IconStyle></Style>',
        data(prov),
    ]  # the KML 2.2 schema's order: name, description, styles, ExtendedData, then features
    points = []
    for f in feats:
        g, p = f["geometry"], f["properties"]
        if g["type"] == "LineString":
            out.append(
                f"<Placemark><name>{escape(str(p.get('name', table)))}</name><styleUrl>#line</styleUrl>"
                f"{data(p)}<LineString><tessellate>1</tessellate><coordinates>{coords(g['coordinates'])}"
                f"</coordinates></LineString></Placemark>"
            )
        else:
            points.append(
                f"<Placemark><styleUrl>#point</styleUrl>{data(p)}<Point><coordinates>"
                f"{coords([g['coordinates']])}</coordinates></Point></Placemark>"
            )
    if points:
        out.append(f"<Folder><name>{escape(table)} values</name>{''.join(points)}</Folder>")
    out += ["</Document>", "</kml>"]
    return ("\n".join(out) + "\n").encode()


def geo_export(fmt: str, table: str, csv_data: bytes, summary: dict, track: dict | None = None) -> tuple[str, bytes]:
    """(file name, bytes) of ``table`` in ``fmt`` (``geojson`` or ``kml``)."""
    if fmt == "geojson":
        return f"{table}.geojson", table_geojson(table, csv_data, summary, track)
    if fmt == "kml":
        return f"{table}.kml", table_kml(table, csv_data, summary, track)
    from ldvsurvey.errors import ParameterError

    raise ParameterError(f"unknown export format '{fmt}' (known: csv, {', '.join(GEO_FORMATS)})", field="format")


def gnss_track(log) -> dict | None:
    """t_s, lat_deg, lon_deg of a log's GNSS fixes (to place tables without positions)."""
    g = getattr(log, "gnss", None)
    if g is None:
        return None
    ok = (g.fix > 0) & np.isfinite(g.lat_deg)
    return {"t_s": g.t_s[ok], "lat_deg": g.lat_deg[ok], "lon_deg": g.lon_deg[ok]}
