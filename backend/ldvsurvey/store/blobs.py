"""Column dicts of numpy arrays to and from Parquet bytes."""

from __future__ import annotations

import io

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq


def to_parquet(columns: dict[str, np.ndarray]) -> bytes:
    """Serialize equal-length 1-D arrays (None values are left out) to Parquet bytes."""
    table = pa.table({k: np.asarray(v) for k, v in columns.items() if v is not None})
    buf = io.BytesIO()
    pq.write_table(table, buf, compression="zstd", compression_level=1)
    return buf.getvalue()


def from_parquet(data: bytes) -> dict[str, np.ndarray]:
    """Inverse of :func:`to_parquet`."""
    table = pq.read_table(io.BytesIO(data))
    return {name: table.column(name).to_numpy() for name in table.column_names}
