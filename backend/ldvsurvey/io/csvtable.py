"""Fast, strict reader for the bundle's numeric CSV files (``imu.csv``, ``ldv.csv``).

The happy path is one multi-threaded pyarrow parse. Only when that fails does a
(slow, Python) diagnostic pass run, to name the exact line and column of the defect.
"""

from __future__ import annotations

import difflib
import re
from dataclasses import dataclass, field

import numpy as np
import pyarrow as pa
import pyarrow.csv as pacsv

from ldvsurvey.errors import BundleError


@dataclass
class NumericTable:
    """Columns of one CSV file as float64 arrays, with the file line of every row.

    Attributes
    ----------
    columns : dict[str, numpy.ndarray]
        Column name to float64 values.
    line_of_row : numpy.ndarray
        1-based line number in the original file of each data row.
    warnings : list[str]
        Things accepted but worth telling (ignored columns, ...).
    """

    file: str
    columns: dict[str, np.ndarray]
    line_of_row: np.ndarray
    warnings: list[str] = field(default_factory=list)

    def __len__(self) -> int:
        return len(self.line_of_row)


_CHUNK = 1 << 26  # bytes scanned at a time: no file-sized temporaries for long logs


def _is_blank(data: bytes) -> bool:
    """True when ``data`` holds only whitespace (without copying it, as ``data.strip()`` would)."""
    return re.search(rb"\S", data) is None


def _lines(data: bytes) -> tuple[np.ndarray, np.ndarray]:
    """Start and end (exclusive, before ``\\r\\n``) byte offsets of every line."""
    arr = np.frombuffer(data, dtype=np.uint8)
    nl = np.concatenate([np.flatnonzero(arr[a:a + _CHUNK] == 10) + a for a in range(0, len(arr), _CHUNK)]
                        or [np.empty(0, dtype=np.int64)])
    starts = np.concatenate(([0], nl + 1))
    ends = np.concatenate((nl, [len(arr)]))
    if starts[-1] >= len(arr):  # file ends with a newline: no last empty line
        starts, ends = starts[:-1], ends[:-1]
    # strip a trailing carriage return
    has_cr = (ends > starts) & (arr[np.maximum(ends - 1, 0)] == 13)
    ends = ends - has_cr
    return starts, ends


def read_numeric_csv(data: bytes, file: str, required: list[str],
                     optional: list[str] = (), alternatives: list[tuple[str, ...]] = ()
                     ) -> NumericTable:
    """Parse a comma-separated numeric file with a header row.

    Parameters
    ----------
    data : bytes
        The file's bytes. ``#`` starts a comment line; blank lines are skipped.
    file : str
        File name used in error messages.
    required : list of str
        Columns that must be present.
    optional : list of str
        Columns that may be present.
    alternatives : list of tuple of str
        Groups of which exactly one column must be present.

    Raises
    ------
    BundleError
        Empty file, missing/misspelled/duplicated columns, wrong field count,
        non-numeric, empty, NaN or infinite cells; naming file, line and column.
    """
    if _is_blank(data):
        raise BundleError("file is empty", file=file, line=1)
    starts, ends = _lines(data)
    arr = np.frombuffer(data, dtype=np.uint8)
    first = arr[np.minimum(starts, len(arr) - 1)]
    blank = ends <= starts
    if np.any(~blank):
        # whitespace-only lines count as blank
        idx = np.flatnonzero(~blank & ((first == 32) | (first == 9)))
        for i in idx:
            if not data[starts[i]:ends[i]].strip():
                blank[i] = True
    keep = ~blank & (first != ord("#"))
    kept = np.flatnonzero(keep)
    if len(kept) == 0:
        raise BundleError("no header row (only comments or blank lines)", file=file, line=1)
    header_idx = kept[0]
    header_line = data[starts[header_idx]:ends[header_idx]].decode("utf-8", "replace").lstrip("\ufeff")
    names = [c.strip() for c in header_line.split(",")]
    hline = int(header_idx) + 1
    _check_header(names, file, hline, required, optional, alternatives)
    rows = kept[1:]
    if len(rows) == 0:
        raise BundleError("header but no data rows", file=file, line=hline + 1)
    line_of_row = rows + 1

    # bytes of the data rows only, without comment/blank lines (a view, not a copy, when contiguous)
    if rows[-1] - rows[0] + 1 == len(rows):
        body = memoryview(data)[starts[rows[0]]:]
    else:
        breaks = np.flatnonzero(np.diff(rows) != 1)
        run_starts = np.concatenate(([rows[0]], rows[breaks + 1]))
        run_ends = np.concatenate((rows[breaks], [rows[-1]]))
        body = b"\n".join(data[starts[a]:ends[b]] for a, b in zip(run_starts, run_ends)) + b"\n"

    wanted = [n for n in names if n in set(required) | set(optional)
              | {c for grp in alternatives for c in grp}]
    try:
        table = pacsv.read_csv(
            pa.BufferReader(pa.py_buffer(body)),
            read_options=pacsv.ReadOptions(column_names=names, autogenerate_column_names=False),
            parse_options=pacsv.ParseOptions(delimiter=","),
            convert_options=pacsv.ConvertOptions(
                column_types={n: pa.float64() for n in wanted}, include_columns=wanted,
                strings_can_be_null=False, null_values=[""]),
        )
    except (pa.ArrowInvalid, pa.ArrowTypeError) as exc:
        _diagnose(data, starts, ends, rows, names, wanted, file)
        raise BundleError(f"could not be parsed: {exc}", file=file) from None
    if table.num_rows != len(rows):
        _diagnose(data, starts, ends, rows, names, wanted, file)
        raise BundleError(f"parsed {table.num_rows} rows, expected {len(rows)}", file=file)

    columns: dict[str, np.ndarray] = {}
    for n in wanted:
        col = table.column(n)
        table = table.drop_columns([n])  # its Arrow buffers go once copied: one column at a time in two copies
        if col.null_count:
            r = int(np.flatnonzero(np.asarray(col.is_null()))[0])
            raise BundleError("empty cell", file=file, line=int(line_of_row[r]), field=n)
        values = _float64_values(col)
        bad = ~np.isfinite(values)
        if bad.any():
            r = int(np.flatnonzero(bad)[0])
            raise BundleError(f"value {values[r]} is not a finite number", file=file,
                              line=int(line_of_row[r]), field=n)
        columns[n] = values
        del col, bad
    ignored = [n for n in names if n not in wanted]
    warnings = [f"{file}: column '{n}' is not part of the format and was ignored" for n in ignored]
    return NumericTable(file=file, columns=columns, line_of_row=line_of_row, warnings=warnings)


def _float64_values(col) -> np.ndarray:
    """A null-free float64 Arrow column as one numpy array, from the value buffers.

    ``ChunkedArray.to_numpy`` would import pandas (a third of a second at every start).
    """
    parts = [np.frombuffer(c.buffers()[1], dtype=np.float64, count=len(c), offset=8 * c.offset)
             for c in col.chunks if len(c)]
    if not parts:
        return np.empty(0, dtype=np.float64)
    return parts[0].copy() if len(parts) == 1 else np.concatenate(parts)


def _check_header(names, file, hline, required, optional, alternatives) -> None:
    known = set(required) | set(optional) | {c for grp in alternatives for c in grp}
    seen = set()
    for n in names:
        if n == "":
            raise BundleError("empty column name in header", file=file, line=hline)
        if n in seen:
            raise BundleError("column appears twice in the header", file=file, line=hline, field=n)
        seen.add(n)
    missing = [c for c in required if c not in seen]
    unknown = [n for n in names if n not in known]
    for n in unknown:  # a near miss of a known column is a misspelling, not an extra column
        close = difflib.get_close_matches(n, sorted(known - seen), n=1, cutoff=0.75)
        if close:
            raise BundleError(f"unknown column '{n}': did you mean '{close[0]}'?",
                              file=file, line=hline, field=n)
    if missing:
        raise BundleError(f"required column '{missing[0]}' is missing (header has: {', '.join(names)})",
                          file=file, line=hline, field=missing[0])
    for grp in alternatives:
        present = [c for c in grp if c in seen]
        if len(present) != 1:
            raise BundleError(f"exactly one of {', '.join(grp)} must be present, found "
                              f"{', '.join(present) if present else 'none'}",
                              file=file, line=hline, field=grp[0])


def _diagnose(data, starts, ends, rows, names, wanted, file) -> None:
    """Find and raise the first defect row by row (error path only)."""
    ncol = len(names)
    index = {n: i for i, n in enumerate(names)}
    for r in rows:
        text = data[starts[r]:ends[r]].decode("utf-8", "replace")
        cells = text.split(",")
        if len(cells) != ncol:
            raise BundleError(f"expected {ncol} fields, found {len(cells)}", file=file, line=int(r) + 1)
        for n in wanted:
            cell = cells[index[n]].strip()
            if cell == "":
                raise BundleError("empty cell", file=file, line=int(r) + 1, field=n)
            try:
                float(cell)
            except ValueError:
                raise BundleError(f"'{cell}' is not a number", file=file, line=int(r) + 1,
                                  field=n) from None


def check_time(t: np.ndarray, line_of_row: np.ndarray, file: str, column: str = "t") -> None:
    """Raise if ``t`` does not strictly increase, naming the first offending line."""
    d = np.diff(t)
    bad = np.flatnonzero(d <= 0)
    if len(bad):
        i = int(bad[0]) + 1
        what = "repeats" if d[i - 1] == 0 else "goes backwards"
        raise BundleError(f"time {what}: {float(t[i])!r} s after {float(t[i - 1])!r} s on line {int(line_of_row[i - 1])}",
                          file=file, line=int(line_of_row[i]), field=column)
