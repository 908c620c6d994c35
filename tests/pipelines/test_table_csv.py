"""The result tables' CSV writer: the vectorised paths write the same bytes as the cell-by-cell rule
(:func:`_cell`, text and mixed tables) and as ``pa.array(from_pandas=True)`` (numeric tables)."""

from __future__ import annotations

import io

import numpy as np
import pyarrow as pa
import pyarrow.csv as pacsv
import pytest

from ldvsurvey.pipelines.base import _cell, table_csv


def _floats(n: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    x = rng.normal(size=n) * 10.0 ** rng.integers(-30, 30, n)
    x[::17], x[::23], x[::29], x[::31], x[::41], x[::43] = np.nan, np.inf, -np.inf, -0.0, 1e16, 123456.0
    return x


def _cell_by_cell(columns: dict) -> bytes:
    """The reference: every cell through :func:`_cell`, row by row."""
    cols = [columns[n] if isinstance(columns[n], list) else np.asarray(columns[n]) for n in columns]
    rows = [",".join(_cell(c[i]) for c in cols) for i in range(len(cols[0]) if cols else 0)]
    return ("".join(r + "\n" for r in [",".join(columns)] + rows)).encode()


def _pyarrow_reference(columns: dict) -> bytes:
    """The reference of an all-numeric table: pyarrow's own conversion of the arrays (NaN as null)."""
    table = pa.table(
        {n: pa.array(c.astype(float) if c.dtype.kind == "b" else c, from_pandas=True) for n, c in columns.items()}
    )
    out = io.BytesIO()
    out.write((",".join(columns) + "\n").encode())
    pacsv.write_csv(table, out, write_options=pacsv.WriteOptions(include_header=False, quoting_style="none"))
    return out.getvalue()


def test_mixed_table_matches_cell_by_cell():
    n = 700
    x = _floats(n, 1)
    rng = np.random.default_rng(2)
    columns = {
        "t_s": x,
        "line": [None if k % 5 == 0 else ("L" + str(k) if k % 7 else '=cmd,"q"\n') for k in range(n)],
        "count": rng.integers(-9, 9, n),
        "ok": rng.random(n) > 0.5,
        "f32": x.astype(np.float32),
        "label": np.array(["a,b", "+1", "x", "-y"] * (n // 4) + ["z"] * (n % 4)),
        "any": [1, 2.5, float("nan"), None, True, np.float64(3.0), "@x"] * (n // 7),
    }
    got = table_csv(columns)
    assert got == _cell_by_cell(columns)
    assert b"'=cmd" in got and b",," in got  # the formula guard and NaN/None as empty cells did apply


@pytest.mark.parametrize("seed", [3, 4])
def test_numeric_table_matches_pyarrow_conversion(seed):
    n = 2000
    x = _floats(n, seed)
    rng = np.random.default_rng(seed)
    columns = {
        "a": x,
        "strided": np.column_stack([x, -x])[:, 1],  # a non-contiguous view
        "f32": x.astype(np.float32),
        "i64": rng.integers(-(2**62), 2**62, n),
        "u8": rng.integers(0, 255, n).astype(np.uint8),
        "flag": rng.random(n) > 0.5,
    }
    got = table_csv(columns)
    assert got == _pyarrow_reference(columns)
    lines = got.split(b"\n")
    assert lines[1 + 17].split(b",")[0] == b""  # NaN as an empty cell
    assert int(lines[1].split(b",")[3]) == columns["i64"][0]  # integers written whole


def test_empty_and_short_tables():
    assert table_csv({}) == b"\n"
    assert table_csv({"a": np.array([]), "b": []}) == b"a,b\n"
    with pytest.raises(IndexError):  # a column shorter than the first is an error, as it always was
        table_csv({"a": [1, 2, 3], "b": [1]})
    with pytest.raises(pa.ArrowNotImplementedError):  # refused, not written from the swapped bytes
        table_csv({"a": np.arange(3.0).astype(">f8")})
