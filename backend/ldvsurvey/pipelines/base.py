"""What every pipeline shares: parameters, progress and cancellation, results and their files.

A pipeline is ``func(logs, params, progress) -> PipelineResult``. The CLI, the job runner and
the tests call it the same way through :func:`run_pipeline`, which adds the common summary
keys (``pipeline``, ``inputs``, ``parameters``, ``software_version``, ...).
"""

from __future__ import annotations

import contextvars
import datetime as dt
import hashlib
import io
import json
import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

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


class Cancelled(Exception):
    """Raised between stages when the job was asked to stop."""


class Progress:
    """Stage/fraction reporter; ``check()`` raises :class:`Cancelled` when cancellation was asked."""

    def __init__(self, callback: Callable[[str, float], None] | None = None,
                 cancelled: Callable[[], bool] | None = None):
        self._cb = callback
        self._cancelled = cancelled

    def __call__(self, stage: str, fraction: float) -> None:
        self.check()
        if self._cb is not None:
            self._cb(stage, max(0.0, min(1.0, float(fraction))))

    def check(self) -> None:
        if self._cancelled is not None and self._cancelled():
            raise Cancelled("cancelled")


@dataclass
class Param:
    """A pipeline parameter: name, type (float, int, bool, str, 'floats', 'paths'), default, help."""

    name: str
    kind: str
    default: object
    help: str
    choices: tuple | None = None

    def parse(self, value):
        if value is None:
            return None
        try:
            if self.kind == "float":
                v = float(value)
                if not math.isfinite(v):
                    raise ValueError
                return v
            if self.kind == "int":
                return int(value)
            if self.kind == "bool":
                if isinstance(value, bool):
                    return value
                s = str(value).strip().lower()
                if s in ("1", "true", "yes", "on"):
                    return True
                if s in ("0", "false", "no", "off"):
                    return False
                raise ValueError
            if self.kind == "floats":
                items = value if isinstance(value, (list, tuple)) else str(value).split(",")
                out = [float(x) for x in items]
                if not all(math.isfinite(x) for x in out):
                    raise ValueError
                return out
            if self.kind == "paths":
                items = value if isinstance(value, (list, tuple)) else str(value).split(",")
                return [str(x).strip() for x in items if str(x).strip()]
            v = str(value)
        except (TypeError, ValueError):
            raise ParameterError(f"expected {self.kind}, got {value!r}", field=self.name) from None
        if self.choices and v not in self.choices:
            raise ParameterError(f"must be one of {', '.join(self.choices)}, got {v!r}", field=self.name)
        return v


@dataclass
class PipelineResult:
    """A pipeline's output: summary dict, CSV tables (name -> columns), and warnings."""

    summary: dict
    tables: dict[str, dict[str, np.ndarray | list]] = field(default_factory=dict)
    warnings: list[str] = field(default_factory=list)


@dataclass
class Pipeline:
    name: str
    func: Callable
    params: list[Param]
    description: str
    multi_input: bool = False

    def resolve(self, given: dict) -> dict:
        """All parameter values, defaults included; unknown keys are an error."""
        known = {p.name: p for p in self.params}
        unknown = [k for k in given if k not in known]
        if unknown:
            raise ParameterError(f"unknown parameter for '{self.name}' (known: {', '.join(sorted(known))})",
                                 field=unknown[0])
        return {p.name: p.parse(given[p.name]) if p.name in given else p.default for p in self.params}


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


def run_pipeline(pipe: Pipeline, logs: list, params: dict, progress: Progress | None = None) -> PipelineResult:
    """Run ``pipe`` on parsed drive logs and add the common summary keys."""
    progress = progress or Progress()
    values = pipe.resolve(params)
    if not pipe.multi_input and len(logs) != 1:
        raise ParameterError(f"'{pipe.name}' takes exactly one bundle, got {len(logs)}", field="BUNDLE")
    started = dt.datetime.now(dt.timezone.utc)
    t0 = time.perf_counter()
    token = _RUN_WARNINGS.set([])
    try:
        result = pipe.func(logs, values, progress)
        staged = list(_RUN_WARNINGS.get())
    finally:
        _RUN_WARNINGS.reset(token)
    inputs = []
    for log in logs:
        for name, data in sorted(log.files.items()):
            inputs.append({"bundle": log.manifest.name, "file": name, "sha256": hashlib.sha256(data).hexdigest()})
    warnings = []
    for log in logs:
        warnings += list(log.warnings)
    warnings += result.warnings
    warnings += [w for w in staged if w not in warnings]
    common = {"pipeline": pipe.name, "format_version": FORMAT_VERSION, "inputs": inputs,
              "parameters": values, "software_version": __version__,
              "started_at": started.isoformat(timespec="seconds"),
              "elapsed_s": round(time.perf_counter() - t0, 3), "warnings": warnings}
    result.summary = _jsonable({**common, **result.summary})
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
    if any(c in s for c in ",\"\n"):
        s = '"' + s.replace('"', '""') + '"'
    return s


def table_csv(columns: dict) -> bytes:
    """CSV bytes of a column dict: floats in shortest round-trip form, NaN as empty, text protected."""
    names = list(columns)
    cols = [np.asarray(columns[n]) if not isinstance(columns[n], list) else columns[n] for n in names]
    n = len(cols[0]) if cols else 0
    buf = io.StringIO()
    buf.write(",".join(names) + "\n")
    numeric = [isinstance(c, np.ndarray) and c.dtype.kind in "fiub" for c in cols]
    if all(numeric) and n:  # fast path: pyarrow, NaN written as an empty cell
        import pyarrow as pa
        import pyarrow.csv as pacsv

        table = pa.table({nm: pa.array(c.astype(float) if c.dtype.kind == "b" else c, from_pandas=True)
                          for nm, c in zip(names, cols)})
        out = io.BytesIO()
        out.write(buf.getvalue().encode())
        pacsv.write_csv(table, out, write_options=pacsv.WriteOptions(include_header=False, quoting_style="none"))
        return out.getvalue()
    for i in range(n):
        buf.write(",".join(_cell(c[i]) for c in cols) + "\n")
    return buf.getvalue().encode()


def result_files(result: PipelineResult) -> dict[str, bytes]:
    """``summary.json`` and every table as ``<name>.csv``."""
    files = {"summary.json": (json.dumps(result.summary, indent=2) + "\n").encode()}
    for name, cols in result.tables.items():
        files[f"{name}.csv"] = table_csv(cols)
    return files


def write_result(result: PipelineResult, out_dir: str | Path) -> list[Path]:
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    paths = []
    for name, data in result_files(result).items():
        p = out / name
        p.write_bytes(data)
        paths.append(p)
    return paths
