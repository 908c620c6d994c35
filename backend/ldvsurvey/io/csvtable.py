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
    groups: dict[str, np.ndarray] = field(default_factory=dict)  #: (N, k) arrays of ``groups``

    def __len__(self) -> int:
        return len(self.line_of_row)


#: the most columns a header may have: a bundle file has a handful (``imu.csv`` 7-8); a wider header
#: is refused before it is split, so that a file of a million columns costs nothing to refuse
MAX_COLUMNS = 256


def check_column_count(header: bytes | str, file: str, line: int, *, whole: bool = True) -> None:
    """A :class:`BundleError` naming file and line when ``header`` (the whole line, or with ``whole``
    False its beginning) has more than :data:`MAX_COLUMNS` comma-separated columns (counted without
    splitting it)."""
    n = header.count(b"," if isinstance(header, bytes) else ",") + 1
    if n > MAX_COLUMNS:
        has = f"{n} columns" if whole else f"more than {MAX_COLUMNS} columns"
        raise BundleError(f"header has {has}; at most {MAX_COLUMNS} are accepted", file=file, line=line)


_CHUNK = 1 << 26  # bytes scanned at a time: no file-sized temporaries for long logs


def _is_blank(data: bytes) -> bool:
    """True when ``data`` holds only whitespace (without copying it, as ``data.strip()`` would)."""
    return re.search(rb"\S", data) is None


def _lines(data: bytes) -> tuple[np.ndarray, np.ndarray]:
    """Start and end (exclusive, before ``\\r\\n``) byte offsets of every line."""
    arr = np.frombuffer(data, dtype=np.uint8)
    nl = np.concatenate(
        [np.flatnonzero(arr[a : a + _CHUNK] == 10) + a for a in range(0, len(arr), _CHUNK)]
        or [np.empty(0, dtype=np.int64)]
    )
    starts = np.concatenate(([0], nl + 1))
    ends = np.concatenate((nl, [len(arr)]))
    if starts[-1] >= len(arr):  # file ends with a newline: no last empty line
        starts, ends = starts[:-1], ends[:-1]
    # strip a trailing carriage return
    has_cr = (ends > starts) & (arr[np.maximum(ends - 1, 0)] == 13)
    ends = ends - has_cr
    return starts, ends


def read_numeric_csv(
    data,
    file: str,
    required: list[str],
    optional: list[str] = (),
    alternatives: list[tuple[str, ...]] = (),
    groups: dict[str, list[str]] | None = None,
) -> NumericTable:
    """Parse a comma-separated numeric file with a header row.

    A file without comment or blank lines after its header (what recorders write) is parsed in one
    pass by pyarrow, straight from disk when ``data`` is a path; anything else (or any defect) goes
    the exact way that keeps the line of every row, reading the whole file.

    Parameters
    ----------
    data : bytes or path
        The file's bytes, or its path. ``#`` starts a comment line; blank lines are skipped.
    file : str
        File name used in error messages.
    required : list of str
        Columns that must be present.
    optional : list of str
        Columns that may be present.
    alternatives : list of tuple of str
        Groups of which exactly one column must be present.

    groups : dict of str to list of str, optional
        Columns to fill into one (N, k) float64 array each (``{"dtheta": ["dtheta_x", ...]}``):
        ``columns`` then holds column views of it and ``NumericTable.groups`` the array, so that no
        second copy of the table is made to stack them.

    Raises
    ------
    BundleError
        Empty file, missing/misspelled/duplicated columns, wrong field count,
        non-numeric, empty, NaN or infinite cells; naming file, line and column.
    """
    fast = _read_regular(data, file, required, optional, alternatives, groups or {})
    if fast is not None:
        return fast
    if not isinstance(data, (bytes, bytearray, memoryview)):
        with open(data, "rb") as fh:
            data = fh.read()
    return _read_exact(data, file, required, optional, alternatives, groups or {})


def _read_exact(data: bytes, file, required, optional, alternatives, groups) -> NumericTable:
    """The exact reader: every line located, comments and blank lines skipped (holds the file)."""
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
            if not data[starts[i] : ends[i]].strip():
                blank[i] = True
    keep = ~blank & (first != ord("#"))
    kept = np.flatnonzero(keep)
    if len(kept) == 0:
        raise BundleError("no header row (only comments or blank lines)", file=file, line=1)
    header_idx = kept[0]
    hline = int(header_idx) + 1
    check_column_count(data[starts[header_idx] : ends[header_idx]], file, hline)
    header_line = data[starts[header_idx] : ends[header_idx]].decode("utf-8", "replace").lstrip("\ufeff")
    names = [c.strip() for c in header_line.split(",")]
    _check_header(names, file, hline, required, optional, alternatives)
    rows = kept[1:]
    if len(rows) == 0:
        raise BundleError("header but no data rows", file=file, line=hline + 1)
    line_of_row = rows + 1

    # bytes of the data rows only, without comment/blank lines (a view, not a copy, when contiguous)
    if rows[-1] - rows[0] + 1 == len(rows):
        body = memoryview(data)[starts[rows[0]] :]
    else:
        breaks = np.flatnonzero(np.diff(rows) != 1)
        run_starts = np.concatenate(([rows[0]], rows[breaks + 1]))
        run_ends = np.concatenate((rows[breaks], [rows[-1]]))
        body = b"\n".join(data[starts[a] : ends[b]] for a, b in zip(run_starts, run_ends)) + b"\n"

    wanted = [n for n in names if n in set(required) | set(optional) | {c for grp in alternatives for c in grp}]
    try:
        table = pacsv.read_csv(
            pa.BufferReader(pa.py_buffer(body)),
            read_options=pacsv.ReadOptions(column_names=names, autogenerate_column_names=False),
            parse_options=pacsv.ParseOptions(delimiter=","),
            convert_options=pacsv.ConvertOptions(
                column_types={n: pa.float64() for n in wanted},
                include_columns=wanted,
                strings_can_be_null=False,
                null_values=[""],
            ),
        )
    except (pa.ArrowInvalid, pa.ArrowTypeError) as exc:
        _diagnose(data, starts, ends, rows, names, wanted, file)
        raise BundleError(f"could not be parsed: {exc}", file=file) from None
    if table.num_rows != len(rows):
        _diagnose(data, starts, ends, rows, names, wanted, file)
        raise BundleError(f"parsed {table.num_rows} rows, expected {len(rows)}", file=file)

    return _to_numpy(table, names, wanted, groups, file, lambda r: int(line_of_row[r]), line_of_row)


def _to_numpy(table, names, wanted, groups, file, line_of, line_of_row) -> NumericTable:
    """Move the Arrow columns into numpy, one column at a time (each Arrow column is dropped once
    copied, so the table exists in two copies for one column only); empty and non-finite cells are
    refused naming their line (``line_of(row)``)."""
    n_rows = table.num_rows
    group_arrays = {
        g: np.empty((n_rows, len(cols)), dtype=np.float64)
        for g, cols in groups.items()
        if all(c in wanted for c in cols)
    }
    slot = {c: (g, k) for g, cols in groups.items() if g in group_arrays for k, c in enumerate(cols)}
    columns: dict[str, np.ndarray] = {}
    for n in wanted:
        col = table.column(n)
        table = table.drop_columns([n])
        if col.null_count:
            r = int(np.flatnonzero(np.asarray(col.is_null()))[0])
            raise BundleError("empty cell", file=file, line=line_of(r), field=n)
        if n in slot:
            g, k = slot[n]
            values = group_arrays[g][:, k]
            _float64_values(col, out=values)
        else:
            values = _float64_values(col)
        del col
        bad = np.flatnonzero(~np.isfinite(values))
        if len(bad):
            r = int(bad[0])
            raise BundleError(f"value {values[r]} is not a finite number", file=file, line=line_of(r), field=n)
        columns[n] = values
    ignored = [n for n in names if n not in wanted]
    warnings = [f"{file}: column '{n}' is not part of the format and was ignored" for n in ignored]
    return NumericTable(file=file, columns=columns, line_of_row=line_of_row, warnings=warnings, groups=group_arrays)


def _float64_values(col, out: np.ndarray | None = None) -> np.ndarray:
    """A null-free float64 Arrow column as one numpy array, from the value buffers (into ``out``
    when given).

    ``ChunkedArray.to_numpy`` would import pandas (a third of a second at every start).
    """
    parts = [
        np.frombuffer(c.buffers()[1], dtype=np.float64, count=len(c), offset=8 * c.offset) for c in col.chunks if len(c)
    ]
    if out is None:
        if not parts:
            return np.empty(0, dtype=np.float64)
        return parts[0].copy() if len(parts) == 1 else np.concatenate(parts)
    i = 0
    for p in parts:
        out[i : i + len(p)] = p
        i += len(p)
    return out


#: bytes read to find the header of a file given by path
_HEAD = 1 << 16


def _read_regular(data, file, required, optional, alternatives, groups) -> NumericTable | None:
    """The one-pass reader of a file whose data rows follow its header without a comment or blank
    line: pyarrow parses the body (multi-threaded, from disk for a path) and the file line of row
    ``r`` is ``header line + 1 + r``. None when the file is not like that or has a defect (the
    exact reader then says which, naming its line)."""
    is_path = not isinstance(data, (bytes, bytearray, memoryview))
    if is_path:
        with open(data, "rb") as fh:
            head = fh.read(_HEAD)
    else:
        head = bytes(memoryview(data)[:_HEAD])
    # the header: the first line that is neither blank nor a comment (within the head)
    pos, hline = 0, 0
    while True:
        nl = head.find(b"\n", pos)
        if nl < 0:  # a line longer than the head: refused here when it is a header too wide
            text = head[pos:]
            if text.strip() and not text.startswith(b"#"):
                check_column_count(text, file, hline + 1, whole=False)
            return None
        hline += 1
        text = head[pos:nl].rstrip(b"\r")
        if text.strip() and not text.startswith(b"#"):
            break
        pos = nl + 1
    check_column_count(text, file, hline)
    body_at = nl + 1
    names = [c.strip() for c in text.decode("utf-8", "replace").lstrip("\ufeff").split(",")]
    if len(names) < 2:
        return None
    _check_header(names, file, hline, required, optional, alternatives)
    wanted = [n for n in names if n in set(required) | set(optional) | {c for grp in alternatives for c in grp}]
    if is_path:
        src = pa.OSFile(str(data))
        src.seek(body_at)
        size = src.size() - body_at
    else:
        src = pa.BufferReader(pa.py_buffer(memoryview(data)[body_at:]))
        size = len(data) - body_at
    if size <= 0:
        return None
    try:
        # blank lines are kept (as rows of empty cells) so that every line is a row: a row count
        # that differs from the line count, an empty cell or a parse error sends the file the exact way
        table = pacsv.read_csv(
            src,
            read_options=pacsv.ReadOptions(column_names=names, autogenerate_column_names=False, block_size=4 << 20),
            parse_options=pacsv.ParseOptions(delimiter=",", ignore_empty_lines=False),
            convert_options=pacsv.ConvertOptions(
                column_types={n: pa.float64() for n in wanted},
                include_columns=wanted,
                strings_can_be_null=False,
                null_values=[""],
            ),
        )
    except (pa.ArrowInvalid, pa.ArrowTypeError):
        return None
    finally:
        src.close()
    if table.num_rows == 0 or any(table.column(n).null_count for n in wanted):
        return None
    if _count_lines(data, body_at) != table.num_rows:  # e.g. a lone carriage return split a line
        return None
    first = hline + 1
    line_of_row = np.arange(first, first + table.num_rows, dtype=np.int64)
    return _to_numpy(table, names, wanted, groups, file, lambda r: first + int(r), line_of_row)


#: bytes counted at a time by :func:`_count_lines`
_COUNT_BLOCK = 1 << 22


def _count_lines(data, start: int) -> int:
    """Lines from byte ``start`` to the end (a last line without newline counts), counted by numpy a
    block at a time (a quarter of the CPU of ``bytes.count``; a file is read into one reused block)."""
    if isinstance(data, (bytes, bytearray, memoryview)):
        arr = np.frombuffer(data, dtype=np.uint8)
        n = sum(int(np.count_nonzero(arr[a : a + _COUNT_BLOCK] == 10)) for a in range(start, len(arr), _COUNT_BLOCK))
        return n + bool(len(arr) == 0 or arr[-1] != 10)
    n, last = 0, 10
    block = np.empty(_COUNT_BLOCK, dtype=np.uint8)
    with open(data, "rb", buffering=0) as fh:
        fh.seek(start)
        while k := fh.readinto(block):
            n += int(np.count_nonzero(block[:k] == 10))
            last = block[k - 1]
    return n + bool(last != 10)


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
            raise BundleError(f"unknown column '{n}': did you mean '{close[0]}'?", file=file, line=hline, field=n)
    if missing:
        raise BundleError(
            f"required column '{missing[0]}' is missing (header has: {', '.join(names)})",
            file=file,
            line=hline,
            field=missing[0],
        )
    for grp in alternatives:
        present = [c for c in grp if c in seen]
        if len(present) != 1:
            raise BundleError(
                f"exactly one of {', '.join(grp)} must be present, found {', '.join(present) if present else 'none'}",
                file=file,
                line=hline,
                field=grp[0],
            )


def _diagnose(data, starts, ends, rows, names, wanted, file) -> None:
    """Find and raise the first defect row by row (error path only)."""
    ncol = len(names)
    index = {n: i for i, n in enumerate(names)}
    for r in rows:
        text = data[starts[r] : ends[r]].decode("utf-8", "replace")
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
                raise BundleError(f"'{cell}' is not a number", file=file, line=int(r) + 1, field=n) from None


def check_time(t: np.ndarray, line_of_row: np.ndarray, file: str, column: str = "t") -> None:
    """Raise if ``t`` does not strictly increase, naming the first offending line."""
    d = np.diff(t)
    bad = np.flatnonzero(d <= 0)
    if len(bad):
        i = int(bad[0]) + 1
        what = "repeats" if d[i - 1] == 0 else "goes backwards"
        raise BundleError(
            f"time {what}: {float(t[i])!r} s after {float(t[i - 1])!r} s on line {int(line_of_row[i - 1])}",
            file=file,
            line=int(line_of_row[i]),
            field=column,
        )
