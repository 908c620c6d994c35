"""Assemble a validated ``ldv-drive-log/1`` bundle from imported recordings and a partial manifest."""

from __future__ import annotations

import copy
import datetime as dt
import hashlib
import json
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np

from ldvsurvey import FORMAT_VERSION, __version__
from ldvsurvey.errors import BundleError
from ldvsurvey.io.importers import gpstime
from ldvsurvey.io.importers.axes import c_rfu_sensor, check_static_up, require_axes
from ldvsurvey.io.importers.checks import (
    OVERLAP_WARN,
    RATE_WARN,
    check_dates,
    check_overlap,
    judge_static,
    measure_imu_rate,
    static_figures,
)
from ldvsurvey.io.importers.common import GnssPart, ImuPart, LdvPart, Stamps, check_increasing

MANIFEST_FILE = "manifest (partial)"


@dataclass
class Source:
    """One recording to import: role (imu, gnss, ldv), format name, file name and bytes."""

    role: str
    format: str
    name: str
    data: bytes


@dataclass
class ImportResult:
    """The bundle's files, what the import had to say, and a summary for previews."""

    files: dict[str, bytes]
    warnings: list[str]
    summary: dict = field(default_factory=dict)
    #: files kept beside the bundle, not in it (the bundle format has no place for them): a receiver's
    #: own INS solution as ``reference.csv`` (see :func:`reference_csv`)
    beside: dict[str, bytes] = field(default_factory=dict)


def reference_csv(ref, t: np.ndarray) -> bytes:
    """A receiver's own INS solution (:class:`~.common.Reference`) on the bundle clock, as CSV."""
    head = (
        f"# reference trajectory: {ref.source} (the receiver's own solution, to compare against; not an input)\n"
        "t,lat_deg,lon_deg,h_ell_m,v_east_mps,v_north_mps,v_up_mps,roll_deg,pitch_deg,azimuth_deg,status\n"
    )
    rows = (
        f"{t[k]:.9f},{ref.lat_deg[k]:.11f},{ref.lon_deg[k]:.11f},{ref.h_ell_m[k]:.4f},"
        f"{ref.v_enu_mps[k, 0]:.4f},{ref.v_enu_mps[k, 1]:.4f},{ref.v_enu_mps[k, 2]:.4f},"
        f"{ref.rpy_deg[k, 0]:.9f},{ref.rpy_deg[k, 1]:.9f},{ref.rpy_deg[k, 2]:.9f},{ref.status[k]}"
        for k in range(len(t))
    )
    return (head + "\n".join(rows) + "\n").encode()


def parse_partial_manifest(data: bytes | str | dict | None, file: str = MANIFEST_FILE) -> dict:
    """The partial manifest as a dict (the keys no recording holds: LDV kind/mounting, lever arms...)."""
    if data is None:
        return {}
    if isinstance(data, dict):
        return copy.deepcopy(data)
    text = data.decode("utf-8-sig", "replace") if isinstance(data, bytes) else data
    if not text.strip():
        return {}
    try:
        raw = json.loads(text)
    except json.JSONDecodeError as exc:
        raise BundleError(f"invalid JSON: {exc.msg}", file=file, line=exc.lineno) from None
    if not isinstance(raw, dict):
        raise BundleError("top level must be a JSON object", file=file, line=1)
    return raw


def _options(manifest: dict, role: str) -> dict:
    opts = (manifest.get("import") or {}).get(role) or {}
    if not isinstance(opts, dict):
        raise BundleError("must be an object", file=MANIFEST_FILE, field=f"import.{role}")
    return opts


def _date_of(parts: dict, manifest: dict) -> dt.date:
    if manifest.get("date") is not None:
        try:
            return dt.date.fromisoformat(str(manifest["date"]))
        except ValueError:
            raise BundleError(
                f"'{manifest['date']}' is not a date (YYYY-MM-DD)", file=MANIFEST_FILE, field="date"
            ) from None
    for role in ("imu", "gnss", "ldv"):
        p = parts.get(role)
        if p is None or not len(p.stamps.values):
            continue
        st = p.stamps
        if st.kind == "gps" and st.week is not None:
            return gpstime.utc_day_of_gps(int(st.week[0]), float(st.values[0]))
        if st.kind == "utc_tod" and st.day is not None:
            return st.day
        if st.kind == "unix":
            return dt.datetime.fromtimestamp(float(st.values[0]) + st.offset_s, dt.UTC).date()
    raise BundleError(
        "no recording states the calendar day (GPS seconds of week or UTC time of day only): "
        'give it as "date": "YYYY-MM-DD" in the partial manifest',
        file=MANIFEST_FILE,
        field="date",
    )


def to_bundle_time(st: Stamps, day: dt.date, leap_s: int, near_week: int) -> np.ndarray:
    """Any :class:`Stamps` to the bundle clock of ``day``.

    Parameters
    ----------
    st : Stamps
        The times as a recording states them.
    day : datetime.date
        The bundle's date; its clock counts s from 00:00 UTC of it.
    leap_s : int
        GPS − UTC, s.
    near_week : int
        The GPS week of ``day``, to resolve 10-bit week numbers.

    Returns
    -------
    (N,) array
        s on the bundle clock, rounded to the nanosecond.
    """
    return np.round(_to_bundle_time(st, day, leap_s, near_week), 9)  # time tags are kept to the nanosecond


def _to_bundle_time(st: Stamps, day: dt.date, leap_s: int, near_week: int) -> np.ndarray:
    if st.kind == "bundle":
        return np.asarray(st.values, dtype=np.float64)
    if st.kind == "gps":
        week = None
        if st.week is not None:
            week = np.array([gpstime.resolve_week(int(w), near_week) for w in np.unique(st.week)])
            week = np.asarray(st.week, dtype=np.int64) + (week[0] - int(np.unique(st.week)[0]))
        return gpstime.gps_to_bundle(st.values, day, leap_s, week)
    if st.kind == "unix":
        return gpstime.unix_to_bundle(st.values, day, st.offset_s)
    if st.kind == "utc_tod":
        return gpstime.tod_to_bundle(st.values, st.day or day, day)
    raise ValueError(st.kind)


def _rate_hz(t: np.ndarray) -> float:
    return float(1.0 / np.median(np.diff(t))) if len(t) > 1 else 0.0


def _round_rate(r: float) -> float:
    return float(round(r)) if abs(r - round(r)) < 0.01 * r else round(r, 3)


def _gga_lines(t, g: GnssPart, sep_default: float | None) -> tuple[bytes, str]:
    from ldvsurvey.io.nmea import format_gga

    if g.sep_m is not None:
        sep = np.asarray(g.sep_m, dtype=np.float64)
        how = "geoid separation as the recording states it"
    elif sep_default is not None:
        sep = np.full(len(t), float(sep_default))
        how = f"geoid separation {sep_default} m from the partial manifest (import.gnss.geoid_separation_m)"
    else:
        sep = np.zeros(len(t))
        how = (
            "the recording gives ellipsoidal heights only: GGA altitude holds the ellipsoidal height and the "
            "separation field 0 (ellipsoidal height = altitude + separation stays exact)"
        )
    nsat = g.n_sat if g.n_sat is not None else np.full(len(t), 12.0)
    hdop = g.hdop if g.hdop is not None else np.full(len(t), 0.9)
    out = []
    for k in range(len(t)):
        n = int(nsat[k]) if np.isfinite(nsat[k]) else 0
        hd = float(hdop[k]) if np.isfinite(hdop[k]) else 0.0
        out.append(
            format_gga(
                float(t[k]),
                float(g.lat_deg[k]),
                float(g.lon_deg[k]),
                float(g.h_ell_m[k] - sep[k]),
                float(sep[k]),
                int(g.fix[k]),
                n_sat=min(n, 99),
                hdop=hd,
                talker="GN",
            )
        )
    return ("\r\n".join(out) + "\r\n").encode(), how


def _jsonable(x):
    """Plain JSON types (numpy scalars to float/int) for the import report."""
    if isinstance(x, dict):
        return {k: _jsonable(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_jsonable(v) for v in x]
    if isinstance(x, np.integer):
        return int(x)
    if isinstance(x, np.floating):
        return float(x)
    return x


def build_bundle(sources: list[Source], partial_manifest: dict) -> ImportResult:
    """Read every source with its importer, put all on the bundle clock and axes, write and validate.

    Parameters
    ----------
    sources : list of Source
        The recordings: an IMU and a GNSS or an LDV, each with its format.
    partial_manifest : dict
        What no recording holds (LDV kind and mounting, lever arms in m...) and the importers' options under
        ``import.<role>`` (``import.time.gps_utc_s``: GPS−UTC in s).

    Returns
    -------
    ImportResult
        The bundle's files (times in s on the bundle clock, increments in rad and m/s in the bundle's axes), the
        warnings, a summary for previews and the files kept beside the bundle.

    Raises
    ------
    BundleError
        Naming the source file, the line or message number and the field; nothing is returned then.
    """
    from ldvsurvey.io.drivelog import parse_files
    from ldvsurvey.io.writers import manifest_json

    m = copy.deepcopy(partial_manifest)
    warnings: list[str] = []
    parts, by_role = _read_sources(sources, m, warnings)
    names = {role: src.name for role, src in by_role.items()}
    day = _date_of(parts, m)
    checks = {"dates": check_dates(parts, names, day if m.get("date") is not None else None)}
    clock = _clock(day, parts, m, warnings)
    t = {role: to_bundle_time(p.stamps, *clock) for role, p in parts.items()}
    _check_time_tags(t, parts, by_role, checks, warnings)
    rfu = _imu_in_rfu(parts, t["imu"], m, by_role["imu"], checks, warnings)
    rates = _complete_manifest(m, day, parts, t, by_role["imu"].name, warnings)
    files, how = _data_files(m, parts, t, by_role, rfu)
    m.setdefault("import", {})
    if isinstance(m["import"], dict):
        m["import"]["provenance"] = _provenance(sources, clock, rfu, how, checks)
    files["manifest.json"] = manifest_json(m)
    files = {k: files[k] for k in ("manifest.json", "imu.csv", "ldv.csv", "gnss.nmea") if k in files}
    log = parse_files(files)  # the same validation as any upload
    warnings += log.warnings
    summary = _summary(sources, parts, t, rates, day, rfu, checks)
    beside = {}
    refs = [p.reference for p in parts.values() if getattr(p, "reference", None) is not None]
    if refs:  # the bundle format has no place for a reference trajectory: it goes beside the bundle
        beside["reference.csv"] = reference_csv(refs[0], to_bundle_time(refs[0].stamps, *clock))
        summary["reference"] = {"source": refs[0].source, "epochs": len(refs[0].lat_deg)}
    return ImportResult(files=files, warnings=warnings, summary=summary, beside=beside)


class _Clock(NamedTuple):
    """What puts a recording's time tags on the bundle clock (the arguments of :func:`to_bundle_time` after the
    stamps)."""

    day: dt.date  #: the bundle's date (UTC)
    gps_minus_utc_s: int  #: leap seconds, s
    near_week: int  #: the GPS week of ``day``, to resolve a recording's truncated week numbers


class _RfuImu(NamedTuple):
    """The IMU increments turned into the bundle's axes (right, forward, up)."""

    axes: str  #: the sensor's axis code they were turned from
    dtheta_rad: np.ndarray  #: (N, 3) rad
    dvel_mps: np.ndarray  #: (N, 3) m/s
    static_tilt_deg: float  #: tilt of gravity's reaction in the static start, deg


def _read_sources(sources: list[Source], m: dict, warnings: list[str]) -> tuple[dict, dict]:
    """Role -> part read by the source's importer, and role -> source; an IMU and a GNSS or LDV are required."""
    from ldvsurvey.io.importers import get_importer

    parts, by_role = {}, {}
    for src in sources:
        if src.role in parts:
            raise BundleError(f"two {src.role} recordings given", file=src.name)
        imp = get_importer(src.format, src.name)
        if src.role not in imp.roles:
            raise BundleError(
                f"the {imp.name} format has no {src.role} data (it has: {', '.join(imp.roles)})", file=src.name
            )
        parts[src.role] = imp.read(src.data, src.name, src.role, _options(m, src.role))
        by_role[src.role] = src
        warnings += parts[src.role].notes
    if "imu" not in parts:
        raise BundleError("an IMU recording is required (--imu FORMAT:FILE)", field="imu")
    if "ldv" not in parts and "gnss" not in parts:
        raise BundleError(
            "an IMU needs a GNSS or an LDV recording beside it (--gnss or --ldv FORMAT:FILE)", field="gnss"
        )
    return parts, by_role


def _clock(day: dt.date, parts: dict, m: dict, warnings: list[str]) -> _Clock:
    """The bundle clock of ``day``: GPS−UTC (s) from ``import.time.gps_utc_s`` or the leap-second table (a warning
    past the table's end when a recording counts GPS time), and the GPS week of the day."""
    time_opts = (m.get("import") or {}).get("time") or {}
    if time_opts.get("gps_utc_s") is not None:
        leap = time_opts["gps_utc_s"]
        if not isinstance(leap, int) or isinstance(leap, bool):
            raise BundleError(
                f"expected a whole number of seconds, got {leap!r}", file=MANIFEST_FILE, field="import.time.gps_utc_s"
            )
    else:
        leap = gpstime.gps_minus_utc_s(day)
        uses_gps = any(p.stamps.kind == "gps" for p in parts.values())
        if uses_gps and day > gpstime.LEAP_TABLE_VALID_TO:
            warnings.append(
                f"the built-in leap-second table is known complete to {gpstime.LEAP_TABLE_VALID_TO}; "
                f"{day} is later: GPS−UTC = {leap} s assumed (set import.time.gps_utc_s if a leap "
                "second was inserted since)"
            )
    return _Clock(day, leap, gpstime.gps_week_of(day, leap)[0])


def _check_time_tags(t: dict, parts: dict, by_role: dict, checks: dict, warnings: list[str]) -> None:
    """Refuse time tags (s, bundle clock) that do not increase; measure how far the GNSS fixes cover the IMU."""
    for role, p in parts.items():
        check_increasing(
            t[role],
            p.stamps.where,
            by_role[role].name,
            unit="line" if by_role[role].format not in ("ubx", "novatel") else "message",
        )
    checks["time_tags"] = "strictly increasing in every recording"
    checks["overlap"] = check_overlap(t, {role: src.name for role, src in by_role.items()})
    if checks["overlap"] and checks["overlap"]["share"] < OVERLAP_WARN:
        warnings.append(
            f"the GNSS fixes cover {checks['overlap']['share'] * 100:.0f} % of the IMU's time span "
            f"({checks['overlap']['overlap_s']:.1f} of {t['imu'][-1] - t['imu'][0]:.1f} s)"
        )


def _imu_in_rfu(parts: dict, t_imu: np.ndarray, m: dict, src: Source, checks: dict, warnings: list[str]) -> _RfuImu:
    """The IMU increments in the bundle's axes, after the static start's checks (gravity up, its size and the gyro
    at rest against the Earth's rotation) and the rate's (Hz, against the partial manifest's)."""
    imu: ImuPart = parts["imu"]
    static_s = float(((m.get("initial") or {}).get("static_s")) or 10.0)
    code = _options(m, "imu").get("axes") or imu.axes
    if not code:  # a format without a fixed sensor frame (u-blox): say what the data show
        require_axes(imu.dvel_mps, t_imu, min(static_s, 60.0), src.name, src.format)
    c = c_rfu_sensor(code, file=MANIFEST_FILE, field="import.imu.axes")
    dth = imu.dtheta_rad @ c.T
    dv = imu.dvel_mps @ c.T
    max_tilt = float(_options(m, "imu").get("max_static_tilt_deg", 5.0))
    tilt = check_static_up(dv, t_imu, code, min(static_s, 60.0), src.name, max_tilt)
    if "gnss" in parts:
        where = (float(parts["gnss"].lat_deg[0]), float(parts["gnss"].h_ell_m[0]))
    else:
        init = m.get("initial") or {}
        where = (init.get("lat_deg"), init.get("h_m"))
    checks["static_gravity"] = static_figures(dth, dv, t_imu, min(static_s, 60.0), *where)
    judge_static(
        checks["static_gravity"],
        (m.get("imu") or {}).get("gyro_bias_dph"),
        src.name,
        warnings,
        _options(m, "imu").get("static_gravity_tolerance"),
    )
    checks["imu_rate"] = measure_imu_rate(t_imu, (m.get("imu") or {}).get("rate_hz"))
    if abs(checks["imu_rate"].get("error_rel", 0.0)) > RATE_WARN:
        warnings.append(
            f"{src.name}: the IMU samples come at {checks['imu_rate']['measured_hz']:.3f} Hz, the partial "
            f"manifest declares {checks['imu_rate']['declared_hz']} Hz"
        )
    if imu.report:
        checks["imu_source"] = imu.report
    return _RfuImu(code, dth, dv, tilt)


def _complete_manifest(m: dict, day: dt.date, parts: dict, t: dict, imu_name: str, warnings: list[str]) -> tuple:
    """Fill in what the recordings tell and the partial manifest left out (date, rates in Hz, LDV kind); the
    rounded IMU and LDV rates (Hz, None without an LDV)."""
    m.setdefault("format", FORMAT_VERSION)
    m["date"] = day.isoformat()
    m.setdefault("name", f"Imported {imu_name}")
    m.setdefault("platform", "vehicle")
    m.setdefault("imu", {})
    imu_rate = _round_rate(_rate_hz(t["imu"]))
    m["imu"].setdefault("rate_hz", imu_rate)
    m["imu"].setdefault("rotating", parts["imu"].turntable_deg is not None)
    ldv: LdvPart | None = parts.get("ldv")
    ldv_rate = None
    if ldv is not None:
        m.setdefault("ldv", {})
        ldv_rate = _round_rate(_rate_hz(t["ldv"]))
        m["ldv"].setdefault("rate_hz", ldv_rate)
        if "kind" not in m["ldv"]:
            m["ldv"]["kind"] = "2d" if "v_up" in ldv.columns else "1d"
            warnings.append(f"ldv.kind not in the partial manifest: '{m['ldv']['kind']}' assumed from the columns")
    elif m.pop("ldv", None) is not None:  # a template's LDV section describes no recording here
        warnings.append(
            "no LDV recording given: the partial manifest's ldv section was left out (a bundle without an LDV)"
        )
    return imu_rate, ldv_rate


def _data_files(m: dict, parts: dict, t: dict, by_role: dict, rfu: _RfuImu) -> tuple[dict, str | None]:
    """``imu.csv``, ``ldv.csv`` and ``gnss.nmea`` of the bundle, and how the GGA heights were made (None without
    GNSS)."""
    from ldvsurvey.io.writers import imu_csv, ldv_csv

    files = {}
    src = by_role["imu"]
    files["imu.csv"] = imu_csv(
        t["imu"],
        rfu.dtheta_rad,
        rfu.dvel_mps,
        parts["imu"].turntable_deg,
        comment=f"imported from {src.name} ({src.format}, axes {rfu.axes})",
    )
    if "ldv" in parts:
        lc = parts["ldv"].columns
        files["ldv.csv"] = ldv_csv(
            t["ldv"],
            v_fwd_mps=lc.get("v_fwd"),
            v_up_mps=lc.get("v_up"),
            quality=lc.get("quality"),
            fd_hz=lc.get("fd_hz"),
            comment=f"imported from {by_role['ldv'].name} ({by_role['ldv'].format})",
        )
    how = None
    if "gnss" in parts:
        g: GnssPart = parts["gnss"]
        if g.raw_nmea is not None:
            files["gnss.nmea"] = g.raw_nmea
            how = "copied unchanged"
        else:
            files["gnss.nmea"], how = _gga_lines(t["gnss"], g, _options(m, "gnss").get("geoid_separation_m"))
    return files, how


def _provenance(sources: list[Source], clock: _Clock, rfu: _RfuImu, how: str | None, checks: dict) -> dict:
    """``import.provenance`` of the manifest: the software, the clock and axes used, the sources' SHA-256 and the
    checks (kept with the bundle: the log page shows them)."""
    prov = {
        "software": f"ldv-survey {__version__}",
        "gps_minus_utc_s": clock.gps_minus_utc_s,
        "leap_table_valid_to": gpstime.LEAP_TABLE_VALID_TO.isoformat(),
        "imu_axes": rfu.axes,
        "static_tilt_deg": round(rfu.static_tilt_deg, 3),
        "sources": [
            {"role": s.role, "format": s.format, "file": s.name, "sha256": hashlib.sha256(s.data).hexdigest()}
            for s in sources
        ],
    }
    if how:
        prov["gnss_heights"] = how
    prov["checks"] = _jsonable(checks)
    return prov


def _summary(sources: list[Source], parts: dict, t: dict, rates: tuple, day: dt.date, rfu: _RfuImu, checks: dict):
    """The import's summary for previews: files, time span (s), rates (Hz), a thinned GNSS track (lon, lat deg)."""
    gnss_track, gnss_rate = [], None
    if "gnss" in parts:
        g = parts["gnss"]
        gnss_rate = _rate_hz(t["gnss"])
        step = max(1, len(g.lat_deg) // 500)
        gnss_track = [
            [round(float(lo), 8), round(float(la), 8)] for lo, la in zip(g.lon_deg[::step], g.lat_deg[::step])
        ]
    spans = [(float(v[0]), float(v[-1])) for v in t.values() if len(v)]
    imu_rate, ldv_rate = rates
    return {
        "files": [{"name": s.name, "format": s.format, "role": s.role} for s in sources],
        "time_span_s": [min(a for a, _ in spans), max(b for _, b in spans)],
        "rates_hz": {"imu": imu_rate, "ldv": ldv_rate, "gnss": None if gnss_rate is None else round(gnss_rate, 3)},
        "gnss_track": gnss_track,
        "date": day.isoformat(),
        "imu_axes": rfu.axes,
        "static_tilt_deg": round(rfu.static_tilt_deg, 3),
        "checks": _jsonable(checks),
    }
