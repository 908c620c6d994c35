"""The bundle's CSV writer (``io.writers.csv_bytes``) builds its Arrow table from the columns' buffers
(``pa.table`` of numpy arrays imports pandas, 0.2 s of every import): the bytes it writes are those of
the table built the usual way, on a simulated drive's ``imu.csv`` and on the awkward numbers."""

from __future__ import annotations

import io

import numpy as np
import pyarrow as pa
import pyarrow.csv as pacsv
import pytest

from ldvsurvey.io.writers import csv_bytes, imu_csv, ldv_csv
from ldvsurvey.sim import catalog
from ldvsurvey.sim.scenario import simulate


def _usual(columns: dict, comment: str | None = None) -> bytes:
    """The writer as it was: ``pa.table`` of the float64 numpy columns."""
    table = pa.table({k: np.asarray(v, dtype=np.float64) for k, v in columns.items()})
    buf = io.BytesIO()
    if comment:
        buf.write(f"# {comment}\n".encode())
    buf.write((",".join(table.column_names) + "\n").encode())
    pacsv.write_csv(table, buf, write_options=pacsv.WriteOptions(include_header=False, quoting_style="none"))
    return buf.getvalue()


def test_a_simulated_imu_and_ldv_file_are_the_same_bytes():
    sim = simulate(catalog.drive(minutes=6.0), seed=2)
    th, dv = sim.dtheta_rad, sim.dvel_mps
    cols = {"t": sim.imu.t_s, **{f"dtheta_{a}": th[:, k] for k, a in enumerate("xyz")}}
    cols |= {f"dvel_{a}": dv[:, k] for k, a in enumerate("xyz")}
    assert imu_csv(sim.imu.t_s, th, dv, comment="imported") == _usual(cols, "imported")
    assert len(imu_csv(sim.imu.t_s, th, dv)) > 1_000_000
    t = sim.imu.t_s[::10]
    assert ldv_csv(t, v_fwd_mps=np.cos(t), quality=np.ones_like(t)) == _usual(
        {"t": t, "v_fwd": np.cos(t), "quality": np.ones_like(t)}
    )


def test_awkward_numbers_and_inputs_are_the_same_bytes():
    x = np.array([0.0, -0.0, 5e-324, -1.7976931348623157e308, np.nan, np.inf, -np.inf, 0.1, 1 / 3, 1e22, 123456789.0])
    big_endian = x.astype(">f8")
    ints = np.arange(len(x), dtype=np.int16)
    strided = np.column_stack([x, x])[:, 1]
    cols = {"a": x, "b": big_endian, "c": ints, "d": strided, "e": list(x)}
    assert csv_bytes(cols) == _usual(cols)
    assert csv_bytes({"t": np.empty(0)}) == _usual({"t": np.empty(0)})


def test_columns_of_unequal_length_are_refused():
    with pytest.raises(pa.ArrowInvalid):
        csv_bytes({"a": np.zeros(3), "b": np.zeros(2)})
    with pytest.raises(pa.ArrowInvalid):
        _usual({"a": np.zeros(3), "b": np.zeros(2)})
