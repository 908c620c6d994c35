"""Any delimited text with a column map given in the partial manifest (``import.<role>.csv``).

Example (IMU rates in deg/s and accelerations in g, x forward, y left, z up, GPS week + seconds)::

    "import": {"imu": {"axes": "FLU", "csv": {
        "delimiter": ";", "header": true,
        "time": {"column": "tow", "kind": "gps", "week_column": "week", "unit": "s"},
        "columns": {"dtheta_x": {"column": "gx", "unit": "deg/s"}, "dtheta_y": {"column": "gy", "unit": "deg/s"},
                    "dtheta_z": {"column": "gz", "unit": "deg/s"}, "dvel_x": {"column": "ax", "unit": "g"},
                    "dvel_y": {"column": "ay", "unit": "g"}, "dvel_z": {"column": "az", "unit": "g", "scale": 1.0,
                    "sign": 1}}}}}

A column is a header name or a 1-based position. ``unit`` converts to the bundle's unit; ``scale``
multiplies and ``sign`` (+1/−1) flips after that; rates and accelerations (per second) are turned into
increments over (t_prev, t] by the interval to the previous sample.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from ldvsurvey.errors import BundleError
from ldvsurvey.io.csvtable import MAX_COLUMNS
from ldvsurvey.io.importers.common import GnssPart, ImuPart, LdvPart, Stamps, fix_from_sigma, text_reader, text_sniffer
from ldvsurvey.io.importers.contract import Importer, Option

NAME = "csv"
ROLES = ("imu", "gnss", "ldv")
G0 = 9.80665
#: unit -> (factor to the bundle unit, per second?)
ANGLE = {
    "rad": (1.0, False),
    "mrad": (1e-3, False),
    "urad": (1e-6, False),
    "deg": (math.pi / 180, False),
    "arcsec": (math.pi / 180 / 3600, False),
    "rad/s": (1.0, True),
    "deg/s": (math.pi / 180, True),
    "deg/h": (math.pi / 180 / 3600, True),
}
VELOCITY_INC = {
    "m/s": (1.0, False),
    "ft/s": (0.3048, False),
    "m/s2": (1.0, True),
    "m/s^2": (1.0, True),
    "g": (G0, True),
    "mg": (G0 * 1e-3, True),
    "ug": (G0 * 1e-6, True),
}
SPEED = {"m/s": (1.0, False), "km/h": (1 / 3.6, False), "kn": (1852 / 3600, False), "mm/s": (1e-3, False)}
UNITS = {
    "imu": {
        "dtheta_x": ANGLE,
        "dtheta_y": ANGLE,
        "dtheta_z": ANGLE,
        "dvel_x": VELOCITY_INC,
        "dvel_y": VELOCITY_INC,
        "dvel_z": VELOCITY_INC,
        "turntable_deg": {"deg": (1.0, False)},
    },
    "gnss": {
        "lat_deg": {"deg": (1.0, False), "rad": (180 / math.pi, False)},
        "lon_deg": {"deg": (1.0, False), "rad": (180 / math.pi, False)},
        "h_m": {"m": (1.0, False), "ft": (0.3048, False)},
        "sep_m": {"m": (1.0, False)},
        "fix": {"": (1.0, False)},
        "sigma_h_m": {"m": (1.0, False)},
        "n_sat": {"": (1.0, False)},
    },
    "ldv": {
        "v_fwd": SPEED,
        "v_up": SPEED,
        "quality": {"": (1.0, False)},
        "fd_hz": {"hz": (1.0, False), "khz": (1e3, False), "mhz": (1e6, False)},
    },
}
REQUIRED = {
    "imu": ["dtheta_x", "dtheta_y", "dtheta_z", "dvel_x", "dvel_y", "dvel_z"],
    "gnss": ["lat_deg", "lon_deg", "h_m"],
    "ldv": [],
}
TIME_KINDS = {"gps", "utc_tod", "unix", "bundle"}
TIME_UNITS = {"s": 1.0, "ms": 1e-3, "us": 1e-6, "ns": 1e-9}
CFG = "import.{role}.csv"


@text_sniffer
def sniff(data: bytes, name: str) -> str | None:
    """Never a role: a CSV file is read only with a column map given for it."""
    return None  # a column map is always needed


def _cfg_error(role, msg, key):
    return BundleError(msg, file="manifest (partial)", field=f"{CFG.format(role=role)}.{key}")


def _split(line: str, delim: str | None) -> list[str]:
    return line.split() if delim is None else [c.strip() for c in line.split(delim)]


@text_reader
def read(data: bytes, file: str, role: str, opts: dict):
    """Columns of delimited text, by the column map ``import.<role>.csv``, in the bundle's units.

    Parameters
    ----------
    data : bytes
        The file's content.
    file : str
        The file's name, for messages.
    role : str
        ``imu``, ``gnss`` or ``ldv``.
    opts : dict
        ``import.<role>`` of the partial manifest: ``csv`` (the column map), ``axes`` (IMU).

    Returns
    -------
    ImuPart or GnssPart or LdvPart
        IMU increments (rad, m/s over (t_prev, t]), GNSS fixes (deg, m; epochs without a fix left out) or
        LDV columns (m/s, Hz), stamped with the map's time kind.

    Raises
    ------
    BundleError
        A map key that is wrong (naming ``import.<role>.csv.<key>``), or a row naming its line and field.
    """
    cfg = opts.get("csv")
    if not isinstance(cfg, dict):
        raise _cfg_error(role, "the csv format needs a column map here (see the importer documentation)", "")
    delim = cfg.get("delimiter", ",")
    delim = None if delim in ("whitespace", " ", None) else str(delim)
    rows, header = _rows(data, file, cfg, delim)
    kind, unit_s = _time_of_map(cfg.get("time"), role)
    spec = _column_spec(cfg, role, file, header, rows)
    out, where = _values(rows, spec, delim, header, file)
    t_raw = out.pop("time")  # in the file's unit: differences of large integers (UNIX ms) stay exact
    week = out.pop("week", None)
    offset_s = 0
    if kind == "unix" and len(t_raw):
        offset_s = int(np.floor(t_raw[0] * unit_s / 86400.0)) * 86400
        t = (t_raw - offset_s / unit_s) * unit_s
    else:
        t = t_raw * unit_s
    dt_s = np.diff(t_raw, prepend=np.nan) * unit_s
    if len(t) > 1:
        dt_s[0] = np.median(np.diff(t_raw)) * unit_s
    for name, col in spec.items():
        if col.per_s and name in out:
            out[name] = out[name] * dt_s
    stamps = Stamps(kind, t, where, week=None if week is None else week.astype(np.int64), offset_s=offset_s)
    note = [f"{file}: read with the column map of {CFG.format(role=role)}"]
    if role == "imu":
        return ImuPart(
            stamps,
            np.column_stack([out["dtheta_x"], out["dtheta_y"], out["dtheta_z"]]),
            np.column_stack([out["dvel_x"], out["dvel_y"], out["dvel_z"]]),
            axes=opts.get("axes", "RFU"),
            turntable_deg=out.get("turntable_deg"),
            notes=note,
        )
    if role == "gnss":
        return _gnss_part(stamps, week, out, cfg, file, note)
    return LdvPart(stamps, {k: v for k, v in out.items()}, notes=note)


class _Column(NamedTuple):
    """Where a quantity sits in a row and how it turns into the bundle's unit."""

    index: int  #: 0-based field of the row
    factor: float  #: to the bundle's unit, with the map's scale and sign
    per_s: bool  #: a rate (per second): turned into an increment by the interval to the previous sample (s)


def _rows(data: bytes, file: str, cfg: dict, delim: str | None) -> tuple[list[tuple[int, str]], list[str] | None]:
    """(line, text) of the data rows (skipped lines, blank lines and comments left out) and the header's names."""
    comment = str(cfg.get("comment", "#"))
    skip = int(cfg.get("skip_lines", 0))
    lines = data.decode("utf-8-sig", "replace").splitlines()
    rows = [
        (i + 1, ln) for i, ln in enumerate(lines) if i >= skip and ln.strip() and not ln.lstrip().startswith(comment)
    ]
    header = None
    if cfg.get("header", True):
        if not rows:
            raise BundleError("file holds no header row", file=file, line=1)
        first = rows[0][1]
        if (first.count(delim) + 1 if delim else len(first.split(None, MAX_COLUMNS))) > MAX_COLUMNS:
            raise BundleError(
                f"header has more than {MAX_COLUMNS} columns; at most {MAX_COLUMNS} are accepted",
                file=file,
                line=rows[0][0],
            )
        header = _split(first, delim)
        rows = rows[1:]
    if not rows:
        raise BundleError("file holds no data rows", file=file, line=1)
    return rows, header


def _time_of_map(tcfg, role: str) -> tuple[str, float]:
    """The time's kind and its unit in s, from the map's ``time``."""
    if not isinstance(tcfg, dict) or "column" not in tcfg:
        raise _cfg_error(role, 'give the time column: {"column": ..., "kind": gps|utc_tod|unix|bundle}', "time")
    kind = tcfg.get("kind", "gps")
    if kind not in TIME_KINDS:
        raise _cfg_error(role, f"time kind '{kind}' is not one of {', '.join(sorted(TIME_KINDS))}", "time.kind")
    tunit = tcfg.get("unit", "s")
    if tunit not in TIME_UNITS:
        raise _cfg_error(role, f"time unit '{tunit}' is not one of {', '.join(TIME_UNITS)}", "time.unit")
    return kind, TIME_UNITS[tunit]


def _index_of(ref, key: str, role: str, header: list[str] | None, file: str, header_line: int) -> int:
    """The 0-based field of a column the map names by its header name or 1-based position."""
    if isinstance(ref, int) and not isinstance(ref, bool):
        if ref < 1:
            raise _cfg_error(role, f"column positions start at 1, got {ref}", key)
        return ref - 1
    if header is None:
        raise _cfg_error(role, f"column '{ref}' named but the map says header: false", key)
    if ref not in header:
        raise BundleError(
            f"no column '{ref}' in the header (has: {', '.join(header)})", file=file, line=header_line, field=str(ref)
        )
    return header.index(ref)


def _column_spec(cfg: dict, role: str, file: str, header: list[str] | None, rows: list) -> dict[str, _Column]:
    """Quantity (``time``, ``week`` and the map's ``columns``) -> its :class:`_Column`; the map's mistakes refused."""
    tcfg = cfg["time"]
    at = rows[0][0] - 1  # the header's line

    def index_of(ref, key):
        return _index_of(ref, key, role, header, file, at)

    spec = {"time": _Column(index_of(tcfg["column"], "time.column"), 1.0, False)}
    if tcfg.get("week_column") is not None:
        spec["week"] = _Column(index_of(tcfg["week_column"], "time.week_column"), 1.0, False)
    units = UNITS[role]
    for name, c in (cfg.get("columns") or {}).items():
        if name not in units:
            raise _cfg_error(role, f"unknown quantity '{name}' (known: {', '.join(units)})", f"columns.{name}")
        c = c if isinstance(c, dict) else {"column": c}
        unit = str(c.get("unit", next(iter(units[name])))).lower() if units[name] else ""
        table = {k.lower(): v for k, v in units[name].items()}
        if unit not in table:
            raise _cfg_error(
                role, f"unit '{unit}' not known for {name} (known: {', '.join(units[name])})", f"columns.{name}.unit"
            )
        factor, per_s = table[unit]
        sign = c.get("sign", 1)
        if sign not in (1, -1):
            raise _cfg_error(role, f"sign must be 1 or -1, got {sign!r}", f"columns.{name}.sign")
        spec[name] = _Column(
            index_of(c.get("column"), f"columns.{name}.column"), factor * float(c.get("scale", 1.0)) * sign, per_s
        )
    missing = [n for n in REQUIRED[role] if n not in spec]
    if role == "ldv" and not ({"v_fwd", "fd_hz"} & set(spec)):
        missing.append("v_fwd or fd_hz")
    if missing:
        raise _cfg_error(role, f"the column map lacks {', '.join(missing)}", "columns")
    return spec


def _values(rows: list, spec: dict[str, _Column], delim: str | None, header: list[str] | None, file: str):
    """Quantity -> (N,) values in the bundle's unit (``time`` and ``week`` as the file has them), and the line of
    each row; a field that is missing or not a finite number names its line and field."""
    out = {k: np.empty(len(rows)) for k in spec}
    where = np.empty(len(rows), dtype=np.int64)
    for r, (lineno, ln) in enumerate(rows):
        cells = _split(ln, delim)
        where[r] = lineno
        for name, (j, factor, _per) in spec.items():
            if j >= len(cells):
                raise BundleError(
                    f"row has {len(cells)} fields, the column map needs field {j + 1}",
                    file=file,
                    line=lineno,
                    field=name,
                )
            try:
                v = float(cells[j])
            except ValueError:
                raise BundleError(
                    f"'{cells[j]}' is not a number",
                    file=file,
                    line=lineno,
                    field=header[j] if header else f"column {j + 1}",
                ) from None
            if not math.isfinite(v):
                raise BundleError(
                    f"'{cells[j]}' is not a finite number",
                    file=file,
                    line=lineno,
                    field=header[j] if header else f"column {j + 1}",
                )
            out[name][r] = v * factor
    return out, where


def _gnss_part(stamps: Stamps, week, out: dict, cfg: dict, file: str, note: list) -> GnssPart:
    """The fixes with a fix quality > 0 (from a ``fix`` column, a ``sigma_h_m`` column (m) or the map's ``fix``)."""
    if "fix" in out:
        fix = out["fix"].astype(np.int16)
    elif "sigma_h_m" in out:
        fix = fix_from_sigma(out["sigma_h_m"])
    else:
        fix = np.full(len(stamps.values), int(cfg.get("fix", 1)), dtype=np.int16)
        note.append(f"{file}: no fix or sigma_h_m column: fix quality {int(cfg.get('fix', 1))} for every epoch")
    keep = fix > 0
    s = Stamps(
        stamps.kind,
        stamps.values[keep],
        stamps.where[keep],
        week=None if week is None else week[keep].astype(np.int64),
        offset_s=stamps.offset_s,
    )
    return GnssPart(
        s,
        out["lat_deg"][keep],
        out["lon_deg"][keep],
        out["h_m"][keep],
        fix[keep],
        sep_m=out["sep_m"][keep] if "sep_m" in out else None,
        n_sat=out["n_sat"][keep] if "n_sat" in out else None,
        notes=note,
    )


IMPORTER = Importer(
    NAME,
    ROLES,
    read,
    sniff,
    options=(Option("csv", (dict,), "the column map (delimiter, header, time, columns)"),),
    summary="any delimited text, with a column map in the partial manifest",
)
