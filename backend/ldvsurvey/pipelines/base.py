"""What every pipeline shares: parameters, progress and cancellation, results and their files.

A pipeline is ``func(logs, params, progress) -> PipelineResult`` where ``params`` is its validated,
frozen parameter model. The CLI, the job runner and the tests call it through
:func:`run_pipeline`, which adds the common summary keys (``pipeline``, ``inputs``,
``parameters``, ``software_version``, ...).
"""

from __future__ import annotations

import contextvars
import datetime as dt
import functools
import io
import json
import math
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Annotated

import numpy as np
from pydantic import BaseModel, BeforeValidator, ConfigDict, Field, ValidationError

from ldvsurvey import FORMAT_VERSION, __version__
from ldvsurvey.errors import ParameterError

#: warnings raised by shared stages (preparation, base tilt) during one pipeline run; every
#: pipeline's summary gets them, whether or not the pipeline passes them on itself
_RUN_WARNINGS: contextvars.ContextVar = contextvars.ContextVar("ldvsurvey_run_warnings", default=None)


def warn(message: str) -> None:
    """Record a warning for the summary of the pipeline run in progress (no-op outside a run)."""
    bucket = _RUN_WARNINGS.get()
    if bucket is not None and message not in bucket:
        bucket.append(message)


_RUN_NOTES: contextvars.ContextVar = contextvars.ContextVar("ldvsurvey_run_notes", default=None)


def note_summary(keys: dict) -> None:
    """Record summary keys a shared stage states for every pipeline that uses it (the start's
    alignment); the pipeline's own keys win. A no-op outside a run."""
    bucket = _RUN_NOTES.get()
    if bucket is not None:
        bucket.update(keys)


class Cancelled(Exception):
    """Raised between stages when the job was asked to stop."""


@functools.cache
def _malloc_trim():
    """glibc's ``malloc_trim``, looked up once; None where there is none (musl, macOS)."""
    import ctypes
    import ctypes.util

    try:
        return ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6").malloc_trim
    except (OSError, AttributeError):
        return None


def release_free_memory() -> None:
    """Give freed memory back to the system: pyarrow's memory pool (what parsing or reading Parquet
    left in it) and the C heap's free pages (glibc ``malloc_trim(0)``; a no-op elsewhere).

    A stage frees its large temporaries when it ends, but glibc keeps freed blocks below its (dynamic,
    up to 32 MB) mmap threshold in the process, and pyarrow's pool keeps what it allocated: on an
    8-hour 200 Hz log the loaded log held about 0.19 GB more than its arrays, and the final
    navigation started about 0.45 GB higher than the arrays alive at that moment. Called at each new
    stage.
    """
    pa = sys.modules.get("pyarrow")
    if pa is not None:
        pa.default_memory_pool().release_unused()
    trim = _malloc_trim()
    if trim is not None:
        trim(0)


class Progress:
    """Stage/fraction reporter; ``check()`` raises :class:`Cancelled` when cancellation was asked.

    At each new stage the memory the previous stage freed is given back (:func:`release_free_memory`).
    """

    def __init__(
        self, callback: Callable[[str, float], None] | None = None, cancelled: Callable[[], bool] | None = None
    ):
        self._cb = callback
        self._cancelled = cancelled
        self._stage: str | None = None

    def __call__(self, stage: str, fraction: float) -> None:
        self.check()
        if stage != self._stage:
            self._stage = stage
            release_free_memory()
        if self._cb is not None:
            self._cb(stage, max(0.0, min(1.0, float(fraction))))

    def check(self) -> None:
        """Raise :class:`Cancelled` when cancellation was asked."""
        if self._cancelled is not None and self._cancelled():
            raise Cancelled("cancelled")


class Params(BaseModel):
    """Base of every pipeline's parameter model: unknown keys refused, NaN/inf refused.

    A pipeline module subclasses it with one field per parameter: type, default, bounds
    (``gt``/``ge``/``le``...) and a description that states the unit. The same model parses the
    API's JSON body, the CLI's ``--set KEY=VALUE`` strings and is served as JSON schema by
    ``GET /api/pipelines``.
    """

    model_config = ConfigDict(extra="forbid", allow_inf_nan=False, frozen=True)


def _split(value):
    """``"1,2.5"`` (a CLI or form string) into ``["1", "2.5"]``; lists pass through."""
    if isinstance(value, str):
        return [x.strip() for x in value.split(",") if x.strip()]
    return value


def _text(value):
    """A number given where text is expected (``gnss_fixes=4``) is taken as its text, as before."""
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        return str(value)
    return value


#: text that also accepts a bare number (``4`` for ``"4"``)
Text = Annotated[str, BeforeValidator(_text)]
#: a list of numbers given as a JSON list or as ``"1,2,3"``
Floats = Annotated[list[float], BeforeValidator(_split)]
#: a list of server-side file paths given as a JSON list or as ``"a.gdf,b.gdf"``
Paths = Annotated[list[str], BeforeValidator(_split)]


def output_rate(default_hz: float, what: str):
    """The ``output_rate_hz`` field every pipeline has: > 0 and at most 1 kHz (at most the IMU rate
    of the log is checked by :func:`rate_within_imu`)."""
    return Field(default_hz, gt=0.0, le=1000.0, description=f"rate of {what} in Hz (> 0, at most the IMU rate)")


@dataclass(frozen=True)
class LogFacts:
    """What the applicability checks may know of a log without reading its samples (the facts
    :func:`ldvsurvey.io.logfacts.log_facts` found when the log was read or stored)."""

    name: str
    platform: str  #: vehicle or vessel
    ldv_kind: str  #: 1d, 2d or water; "none" for a log without an LDV
    imu_rotating: bool
    imu_rate_hz: float
    t_start_s: float
    t_end_s: float
    has_gnss: bool
    lines: tuple = ()  #: manifest survey lines as (name, t_start_s, t_end_s)
    static_s: float | None = None  #: manifest initial.static_s
    has_ldv: bool = True  #: the log has an LDV (ldv.csv and the manifest's ldv section)
    #: repeated survey passes found in the log's speed when it was stored (None: not known)
    repeated_lines: int | None = None

    @classmethod
    def of_manifest(
        cls, m: dict, t_start_s: float, t_end_s: float, has_gnss: bool, facts: dict | None = None
    ) -> LogFacts:
        """From a manifest as JSON (``manifest.json`` or the store's copy), the IMU time span and the
        stored facts (``facts``, see :func:`ldvsurvey.io.logfacts.log_facts`; None: not known)."""
        imu, ldv = m.get("imu") or {}, m.get("ldv")
        facts = facts or {}
        return cls(
            name=str(m.get("name", "")),
            platform=str(m.get("platform", "")),
            ldv_kind=str(ldv.get("kind", "")) if ldv else "none",
            imu_rotating=bool(imu.get("rotating", False)),
            imu_rate_hz=float(imu.get("rate_hz") or 0.0),
            t_start_s=float(t_start_s),
            t_end_s=float(t_end_s),
            has_gnss=bool(has_gnss),
            lines=tuple((ln.get("name"), float(ln["t_start"]), float(ln["t_end"])) for ln in m.get("lines") or []),
            static_s=(m.get("initial") or {}).get("static_s"),
            has_ldv=bool(ldv),
            repeated_lines=facts.get("repeated_lines"),
        )

    @classmethod
    def of_log(cls, log) -> LogFacts:
        """From a parsed :class:`~ldvsurvey.io.drivelog.DriveLog`."""
        from ldvsurvey.io.logfacts import log_facts

        return cls.of_manifest(
            log.manifest.model_dump(mode="json"),
            float(log.imu.t_s[0]),
            float(log.imu.t_s[-1]),
            log.gnss is not None,
            log_facts(log),
        )


@dataclass(frozen=True)
class Reason:
    """Why a pipeline cannot run on the chosen logs with the chosen parameters."""

    field: str
    message: str


def rate_within_imu(logs: list[LogFacts], params: Params, field_name: str = "output_rate_hz") -> list[Reason]:
    """A given output rate above the IMU rate of a log would only repeat samples (a default above
    it is left to the pipeline, which writes every IMU epoch)."""
    if field_name not in params.model_fields_set:
        return []
    rate_hz = getattr(params, field_name)
    return [
        Reason(field_name, f"{rate_hz:g} Hz is above the IMU rate of '{f.name}' ({f.imu_rate_hz:g} Hz)")
        for f in logs
        if f.imu_rate_hz and rate_hz > f.imu_rate_hz
    ]


def window_inside(logs: list[LogFacts], window, field_name: str) -> list[Reason]:
    """A ``t0,t1`` window (s) must lie inside every log's IMU time span."""
    if window is None:
        return []
    a, b = window
    return [
        Reason(field_name, f"[{a:g}, {b:g}] s is not inside the log '{f.name}' [{f.t_start_s:.2f}, {f.t_end_s:.2f}] s")
        for f in logs
        if not (f.t_start_s <= a < b <= f.t_end_s)
    ]


def needs_gnss(logs: list[LogFacts], why: str, field_name: str = "BUNDLE") -> list[Reason]:
    """A pipeline (or a choice of its parameters) that needs GNSS, on a log without ``gnss.nmea``."""
    return [Reason(field_name, f"{why}: log '{f.name}' has no gnss.nmea") for f in logs if not f.has_gnss]


def needs_ldv(logs: list[LogFacts], why: str, field_name: str = "ldv") -> list[Reason]:
    """A pipeline (or a choice of its parameters) that needs the LDV, on a log without one."""
    return [
        Reason(field_name, f"{why}: log '{f.name}' has no LDV (no ldv.csv, no manifest ldv section)")
        for f in logs
        if not f.has_ldv
    ]


def _no_reasons(logs, params) -> list[Reason]:
    return []


def _error_of(exc: ValidationError) -> ParameterError:
    """The first pydantic error as a :class:`ParameterError` naming the parameter."""
    errs = exc.errors()
    first = errs[0]
    loc = [str(x) for x in first.get("loc", ()) if not isinstance(x, int)]
    name = loc[0] if loc else "parameters"
    if first.get("type") == "extra_forbidden":
        msg = "unknown parameter"
    else:
        msg = first.get("msg", "invalid value")
        if "input" in first and not isinstance(first["input"], dict):
            msg += f", got {first['input']!r}"
    more = f" (and {len(errs) - 1} more)" if len(errs) > 1 else ""
    return ParameterError(msg + more, field=name)


@dataclass
class PipelineResult:
    """A pipeline's output: summary dict, CSV tables (name -> columns), and warnings."""

    summary: dict
    tables: dict[str, dict[str, np.ndarray | list]] = field(default_factory=dict)
    warnings: list[str] = field(default_factory=list)
    #: other result files by name (e.g. a gridded map as netCDF), written beside the tables
    files: dict[str, bytes] = field(default_factory=dict)


@dataclass(frozen=True)
class ParamInfo:
    """One parameter as the docs and the old ``parameters`` list of ``GET /api/pipelines`` show it."""

    name: str
    kind: str  #: float, int, bool, str, floats or paths
    default: object
    help: str
    choices: tuple | None = None


def _kind(schema: dict) -> tuple[str, tuple | None]:
    alts = schema.get("anyOf", [schema])
    s = next((a for a in alts if a.get("type") != "null"), alts[0])
    if "enum" in s:
        return "str", tuple(s["enum"])
    t = s.get("type")
    if t == "array":
        return ("floats" if (s.get("items") or {}).get("type") == "number" else "paths"), None
    return {"number": "float", "integer": "int", "boolean": "bool"}.get(t, "str"), None


@dataclass
class Pipeline:
    """A pipeline: its function, its parameter model and its applicability check.

    ``applicable(logs: list[LogFacts], params: Params) -> list[Reason]`` says why the pipeline
    cannot run on these logs with these (already validated) parameters; empty when it can.
    """

    name: str
    func: Callable
    model: type[Params]
    description: str
    multi_input: bool = False
    applicable: Callable[[list[LogFacts], Params], list[Reason]] = _no_reasons
    #: the pipeline keeps the grids it synthesizes in a grid cache the caller provides
    #: (:data:`ldvsurvey.pipelines.stages.grid_cache.GRID_CACHE`): ``ldv-survey run`` opens the
    #: database's for it, as the job runner does for every job
    uses_grid_cache: bool = False

    @property
    def params(self) -> list[ParamInfo]:
        """The parameters in declaration order (derived from :attr:`model`)."""
        props = self.model.model_json_schema()["properties"]
        out = []
        for name, f in self.model.model_fields.items():
            kind, choices = _kind(props[name])
            out.append(ParamInfo(name, kind, f.get_default(call_default_factory=True), f.description or "", choices))
        return out

    def validate(self, given: dict) -> Params:
        """The parameter model from ``given`` (JSON values or ``--set`` strings); a
        :class:`ParameterError` naming the first bad or unknown key otherwise."""
        try:
            return self.model.model_validate(given)
        except ValidationError as exc:
            err = _error_of(exc)
            if err.message.startswith("unknown parameter"):
                err = ParameterError(
                    f"unknown parameter for '{self.name}' (known: {', '.join(self.model.model_fields)})",
                    field=err.field,
                )
            raise err from None

    def model_of(self, given: dict | Params) -> Params:
        """``given`` itself when it already is this pipeline's validated model, else :meth:`validate`."""
        return given if type(given) is self.model else self.validate(given)

    def check(self, logs: list[LogFacts], given: dict | Params) -> Params:
        """The validated parameter model (:meth:`model_of`) once it applies to ``logs``; the first
        reason raised as a :class:`ParameterError` (all reasons in its message)."""
        params = self.model_of(given)
        if not self.multi_input and len(logs) != 1:
            raise ParameterError(f"'{self.name}' takes exactly one log, got {len(logs)}", field="log_ids")
        reasons = self.applicable(logs, params)
        if reasons:
            raise ParameterError(
                f"'{self.name}' cannot run here: " + "; ".join(f"{r.field}: {r.message}" for r in reasons),
                field=reasons[0].field,
            )
        return params


def parse_set_args(items: list[str]) -> dict:
    """``['k=v', ...]`` from ``--set`` into a dict (values still strings)."""
    out = {}
    for item in items:
        if "=" not in item:
            raise ParameterError(f"--set expects KEY=VALUE, got {item!r}", field=item)
        k, v = item.split("=", 1)
        out[k.strip()] = v.strip()
    return out


def _jsonable(x):
    if isinstance(x, dict):
        return {str(k): _jsonable(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_jsonable(v) for v in x]
    if isinstance(x, np.ndarray):
        return _jsonable(x.tolist())
    if isinstance(x, (np.floating,)):
        x = float(x)
    if isinstance(x, (np.integer,)):
        return int(x)
    if isinstance(x, (np.bool_,)):
        return bool(x)
    if isinstance(x, float) and not math.isfinite(x):
        return None
    return x


def run_pipeline(pipe: Pipeline, logs: list, params: dict | Params, progress: Progress | None = None) -> PipelineResult:
    """Run ``pipe`` on parsed drive logs and add the common summary keys.

    ``params`` is the pipeline's validated model (from :meth:`Pipeline.check` or
    :meth:`Pipeline.validate`: used as it is) or a dict of given values (validated here).
    """
    progress = progress or Progress()
    model = pipe.model_of(params)
    values = model.model_dump()
    if not pipe.multi_input and len(logs) != 1:
        raise ParameterError(f"'{pipe.name}' takes exactly one bundle, got {len(logs)}", field="BUNDLE")
    started = dt.datetime.now(dt.UTC)
    t0 = time.perf_counter()
    token = _RUN_WARNINGS.set([])
    notes = _RUN_NOTES.set({})
    try:
        result = pipe.func(logs, model, progress)
        staged = list(_RUN_WARNINGS.get())
        noted = dict(_RUN_NOTES.get())
    finally:
        _RUN_WARNINGS.reset(token)
        _RUN_NOTES.reset(notes)
    inputs = []
    for log in logs:
        for name in sorted(log.files):  # the hashes known since the files were read: never re-read
            inputs.append({"bundle": log.manifest.name, "file": name, "sha256": log.sha256_of(name)})
    warnings = []
    for log in logs:
        warnings += list(log.warnings)
    warnings += result.warnings
    warnings += [w for w in staged if w not in warnings]
    warnings += add_gps_time(result.tables, [getattr(getattr(log, "manifest", None), "date", None) for log in logs])
    common = {
        "pipeline": pipe.name,
        "format_version": FORMAT_VERSION,
        "inputs": inputs,
        "parameters": values,
        "software_version": __version__,
        "started_at": started.isoformat(timespec="seconds"),
        "elapsed_s": round(time.perf_counter() - t0, 3),
        "warnings": warnings,
    }
    result.summary = _jsonable({**common, **noted, **result.summary})
    result.summary["elapsed_s"] = round(time.perf_counter() - t0, 3)
    progress("done", 1.0)
    return result


FORMULA_START = ("=", "+", "-", "@", "\t", "\r")


def _cell(v) -> str:
    if v is None:
        return ""
    if isinstance(v, (float, np.floating)):
        return "" if not math.isfinite(v) else repr(float(v))
    if isinstance(v, (int, np.integer, bool, np.bool_)):
        return str(int(v))
    s = str(v)
    if s.startswith(FORMULA_START):  # CSV formula injection guard for text cells
        s = "'" + s
    if any(c in s for c in ',"\n'):
        s = '"' + s.replace('"', '""') + '"'
    return s


def _text_column(c) -> list[str]:
    """The cells of one column as :func:`_cell` writes them, a numeric array at once."""
    if isinstance(c, np.ndarray) and c.ndim == 1:
        if c.dtype.kind == "f":
            x = c.astype(float)
            return [repr(v) if ok else "" for v, ok in zip(x.tolist(), np.isfinite(x).tolist())]
        if c.dtype.kind in "iub":
            return [str(int(v)) for v in c.tolist()]
    return [_cell(v) for v in c]


def _arrow_column(c: np.ndarray):
    """A 1-D numeric column as an Arrow array, NaN as null (as ``pa.array(c, from_pandas=True)``), built
    from its buffers: ``pa.array`` would import pandas (a third of a second at every start)."""
    import pyarrow as pa

    if c.dtype.kind == "b":
        c = c.astype(float)
    if c.ndim != 1 or not c.dtype.isnative:
        return pa.array(c, from_pandas=True)  # refused there, as before
    c = np.ascontiguousarray(c)
    validity, nulls = None, 0
    if c.dtype.kind == "f":
        nan = np.isnan(c)
        nulls = int(np.count_nonzero(nan))
        if nulls:
            validity = pa.py_buffer(np.packbits(~nan, bitorder="little"))
    return pa.Array.from_buffers(pa.from_numpy_dtype(c.dtype), len(c), [validity, pa.py_buffer(c)], null_count=nulls)


def _arrow_csv(header: str, names: list[str], cols: list[np.ndarray]) -> bytes:
    """The CSV bytes of numeric columns, written by pyarrow after ``header`` (into one growing buffer
    whose bytes are returned without a copy: the table's text exists once)."""
    import pyarrow as pa
    import pyarrow.csv as pacsv

    table = pa.Table.from_arrays([_arrow_column(c) for c in cols], names=names)
    out = io.BytesIO()
    out.write(header.encode())
    pacsv.write_csv(table, out, write_options=pacsv.WriteOptions(include_header=False, quoting_style="none"))
    return out.getvalue()


def table_csv(columns: dict) -> bytes:
    """CSV bytes of a column dict: floats in shortest round-trip form, NaN as empty, text protected."""
    names = list(columns)
    cols = [np.asarray(columns[n]) if not isinstance(columns[n], list) else columns[n] for n in names]
    n = len(cols[0]) if cols else 0
    header = ",".join(names) + "\n"
    numeric = [isinstance(c, np.ndarray) and c.dtype.kind in "fiub" for c in cols]
    if all(numeric) and n:  # fast path: pyarrow, NaN written as an empty cell
        return _arrow_csv(header, names, cols)
    if any(len(c) < n for c in cols):  # a short column: the row-by-row loop raises as it always did
        body = "".join(",".join(_cell(c[i]) for c in cols) + "\n" for i in range(n))
    else:
        texts = [_text_column(c[:n]) for c in cols]
        body = "".join(",".join(row) + "\n" for row in zip(*texts))
    return (header + body).encode()


def gps_time_columns(t_s, day) -> tuple[np.ndarray | list, np.ndarray]:
    """``gps_week`` and ``gps_sow_s`` (s) of bundle-clock times ``t_s`` (s) on the UTC day ``day`` (a date, or
    one date per row); the week is an integer column, an empty cell where ``t_s`` is missing."""
    from ldvsurvey.io.leapseconds import bundle_to_gps

    t = np.asarray(t_s, dtype=np.float64)
    if isinstance(day, dt.date):
        week, sow = bundle_to_gps(t, day)
    else:
        days = np.asarray(day, dtype=object)
        week, sow = np.full(len(t), -1, dtype=np.int64), np.full(len(t), np.nan)
        for d in dict.fromkeys(days.tolist()):
            sel = days == d
            week[sel], sow[sel] = bundle_to_gps(t[sel], d)
    if np.all(np.isfinite(t)):
        return week, sow
    return [str(int(w)) if np.isfinite(x) else "" for w, x in zip(week.tolist(), t.tolist())], sow


def add_gps_time(tables: dict[str, dict], dates: list) -> list[str]:
    """Put ``gps_week`` and ``gps_sow_s`` beside ``t_s`` in every table that has it (in place).

    ``dates`` are the UTC dates of the run's logs (``manifest.date``, None where unknown). One date
    for all the logs serves every row; logs of different dates need a table's ``log`` column (1-based
    log number) to tell each row's date. A table whose rows' dates are not known gets no GPS columns:
    the returned warnings say which.
    """
    warnings = []
    known = set(dates)
    for name, cols in list(tables.items()):
        if "t_s" not in cols or "gps_week" in cols or not len(dates):
            continue
        if None in known:
            day = None
        elif len(known) == 1:
            day = dates[0]
        elif "log" in cols:
            idx = np.asarray(cols["log"], dtype=np.int64) - 1
            day = [dates[i] for i in idx.tolist()]
        else:
            day = None
        if day is None:
            warnings.append(f"{name}.csv: no gps_week/gps_sow_s (the date of its rows is not known)")
            continue
        week, sow = gps_time_columns(cols["t_s"], day)
        out = {}
        for k, v in cols.items():
            out[k] = v
            if k == "t_s":
                out["gps_week"], out["gps_sow_s"] = week, sow
        tables[name] = out
    from ldvsurvey.io.leapseconds import LEAP_TABLE_VALID_TO, gps_minus_utc_s

    late = sorted(d for d in known if d is not None and d > LEAP_TABLE_VALID_TO)
    if late and any("gps_week" in cols for cols in tables.values()):
        warnings.append(
            f"gps_sow_s: the built-in leap-second table is known complete to {LEAP_TABLE_VALID_TO}; for {late[-1]} "
            f"GPS−UTC = {gps_minus_utc_s(late[-1])} s is assumed"
        )
    return warnings


def result_files(result: PipelineResult) -> dict[str, bytes]:
    """``summary.json``, every table as ``<name>.csv`` and the other files (:attr:`PipelineResult.files`)."""
    files = {"summary.json": (json.dumps(result.summary, indent=2) + "\n").encode()}
    for name, cols in result.tables.items():
        files[f"{name}.csv"] = table_csv(cols)
    files.update(result.files)
    return files


def write_result(result: PipelineResult, out_dir: str | Path) -> list[Path]:
    """Write :func:`result_files` into ``out_dir`` (created if missing); the paths written."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    paths = []
    for name, data in result_files(result).items():
        p = out / name
        p.write_bytes(data)
        paths.append(p)
    return paths
