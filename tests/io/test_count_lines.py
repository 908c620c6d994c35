"""The line count that checks pyarrow's row count (``csvtable._count_lines``) against its definition:
newlines from the start byte on, plus one for a last line without a newline; bytes, views and files
alike, across the counting blocks."""

import numpy as np
import pytest

from ldvsurvey.io import csvtable
from ldvsurvey.io.csvtable import _count_lines


def _reference(data: bytes, start: int) -> int:
    return data.count(b"\n", start) + (data[-1:] != b"\n")


@pytest.mark.parametrize("block", [7, 64, 1 << 22])
def test_count_lines_matches_definition(block, tmp_path, monkeypatch):
    monkeypatch.setattr(csvtable, "_COUNT_BLOCK", block)
    rng = np.random.default_rng(block)
    for k in range(40):
        n = int(rng.integers(1, 400))
        data = bytes(rng.choice(np.frombuffer(b"0123,\n\r\n", dtype=np.uint8), n))
        if k % 3 == 0:
            data = data.rstrip(b"\n") + b"\n"  # ends with a newline
        elif k % 3 == 1:
            data = data.rstrip(b"\n") + b"9"  # a last line without one
        start = int(rng.integers(0, len(data)))
        path = tmp_path / f"f{k}.csv"
        path.write_bytes(data)
        want = _reference(data, start)
        assert _count_lines(data, start) == want
        assert _count_lines(memoryview(data), start) == want
        assert _count_lines(bytearray(data), start) == want
        assert _count_lines(path, start) == want


def test_count_lines_known_values(tmp_path):
    p = tmp_path / "x.csv"
    for data, start, want in [(b"a\nb\n", 0, 2), (b"a\nb", 0, 2), (b"h\n1\n2\n3", 2, 3), (b"h\n1\r2\n", 2, 1)]:
        p.write_bytes(data)
        assert _count_lines(data, start) == want == _count_lines(p, start)
