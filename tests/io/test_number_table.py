"""The KF-GINS text reader (``read_number_table``): its fast path (numpy's C reader, for plain tables)
gives exactly what the strict line-by-line reader gives (the same float64 values bit for bit, the same
line numbers, the same error naming file, line and field), on the real KF-GINS demo data set and a
real consumer-MEMS car drive, on simulated drives in two writers' styles and on the text a user may feed it."""

from __future__ import annotations

import datetime as dt
import gzip
from pathlib import Path

import numpy as np
import pytest

from ldvsurvey.errors import BundleError
from ldvsurvey.io.importers import common
from ldvsurvey.sim import catalog
from ldvsurvey.sim.scenario import simulate
from tests.io.import_helpers import kfgins_gnss, kfgins_imu

REAL = Path(__file__).resolve().parents[1] / "fixtures" / "real" / "kfgins"
NAMES = ["gps_sow", "a", "b", "c", "d", "e", "f"]


def _strict(data: bytes, min_cols: int = 7, names=NAMES):
    """The line-by-line reader alone (the fast path switched off)."""
    fast = common._regular_table
    common._regular_table = lambda *a: None
    try:
        return common.read_number_table(data, "x.txt", min_cols, names)
    finally:
        common._regular_table = fast


def _outcome(read):
    """(values, lines) or the error's (message, file, line, field)."""
    try:
        return read()
    except BundleError as e:
        return ("error", str(e), e.file, e.line, e.field)


def assert_same_as_strict(data: bytes, min_cols: int = 7, names=NAMES) -> bool:
    """The reader's result equals the strict reader's; True when the fast path read it."""
    got = _outcome(lambda: common.read_number_table(data, "x.txt", min_cols, names))
    want = _outcome(lambda: _strict(data, min_cols, names))
    if isinstance(want[0], str) or isinstance(got[0], str):
        assert got == want
        return False
    np.testing.assert_array_equal(got[0], want[0])  # NaN padding equal to NaN
    assert got[0].dtype == want[0].dtype == np.float64
    np.testing.assert_array_equal(got[1], want[1])
    assert got[1].dtype == want[1].dtype
    with np.errstate(invalid="ignore"):  # bit for bit, the sign of zero included
        assert np.array_equal(got[0].view(np.int64), want[0].view(np.int64))
    return common._regular_table(data.decode("utf-8", "replace"), min_cols, "#") is not None


def test_real_kfgins_gnss_file_reads_the_same_on_the_fast_path():
    """KF-GINS's demo GNSS-RTK.txt: columns aligned with runs of spaces, a trailing space on every line."""
    data = gzip.decompress((REAL / "GNSS-RTK.txt.gz").read_bytes())
    assert assert_same_as_strict(data)
    a, lines = common.read_number_table(data, "GNSS-RTK.txt", 7, NAMES)
    assert a.shape == (len(data.splitlines()), 7) and lines[0] == 1 and lines[-1] == len(a)
    # the values are the file's decimal text, correctly rounded (independent of both readers)
    first = data.split(b"\n", 1)[0].split()
    assert a[0].tolist() == [float(x) for x in first]


@pytest.mark.parametrize("name", ["rtklibexplorer-drive0708-imu.txt.gz", "rtklibexplorer-drive0708-gnss.txt.gz"])
def test_real_mems_drive_in_kfgins_text_reads_the_same_on_the_fast_path(name):
    """The real consumer-MEMS car drive's IMU (its first 180 s: 17 995 rows at about 100 Hz) and its RTK
    fixes, as prepared for KF-GINS."""
    data = gzip.decompress((REAL.parent / "ins" / name).read_bytes())
    assert assert_same_as_strict(data)
    a, _ = common.read_number_table(data, name, 7, NAMES)
    assert a[-1].tolist() == [float(x) for x in data.rstrip(b"\n").rsplit(b"\n", 1)[1].split()]


@pytest.fixture(scope="module")
def drive():
    return simulate(catalog.drive(minutes=6.0, with_ldv=False), seed=5)


def test_simulated_drive_in_two_writers_styles(drive):
    day = dt.date(2023, 3, 20)
    imu = kfgins_imu(drive.imu.t_s, drive.dtheta_rad, drive.dvel_mps, day)  # shortest repr, single spaces
    gnss = kfgins_gnss(drive.gnss_t_s, drive.gnss_lat_deg, drive.gnss_lon_deg, drive.gnss_h_m, drive.gnss_fix, day)
    assert assert_same_as_strict(imu) and assert_same_as_strict(gnss)
    rows = np.column_stack([drive.imu.t_s + 86418.0, drive.dtheta_rad, drive.dvel_mps])
    fixed = "\n".join(" ".join(f"{v:.12e}" for v in r) for r in rows[:3000]).encode()  # printf style, no last \n
    assert assert_same_as_strict(fixed)
    assert assert_same_as_strict(fixed.replace(b"\n", b"\r\n") + b"\r\n")
    assert assert_same_as_strict(fixed.replace(b" ", b",  "))
    assert assert_same_as_strict(fixed.replace(b" ", b"\t"))


ROW = "388800.01 1e-05 -2.5E-06 0.0 -0.0 3.2e-04 -0.0978"
CASES = {
    "comment header and % comments": f"# time gx gy gz ax ay az\n%another\n{ROW}\n{ROW}\n",
    "indented comment": f"   # note\n{ROW}\n",
    "blank lines between rows": f"{ROW}\n\n   \n{ROW}\n\t\n",
    "thirteen columns": f"{ROW} 1 2 3 4 5 6\n{ROW} 1 2 3 4 5 6\n",
    "first row wider": f"{ROW} 9\n{ROW}\n",
    "later row wider": f"{ROW}\n{ROW} 9\n",
    "short row": f"{ROW}\n388800.02 1 2 3\n",
    "a word": f"{ROW}\n388800.02 1 2 x 4 5 6\n",
    "nan": f"{ROW}\n388800.02 1 2 nan 4 5 6\n",
    "inf": f"{ROW}\n388800.02 1 2 3 4 5 -inf\n",
    "underscore digits": f"{ROW}\n388800.02 1_0 2 3 4 5 6\n",
    "signs and bare points": "+388800 .5 5. -.5e-3 +1E+2 0 -0\n",
    "trailing comment on a row": f"{ROW} # why\n",
    "non-breaking space": f"{ROW}\n388800.02\xa01 2 3 4 5 6 7\n",
    "form feed": f"{ROW}\n\x0c{ROW}\n",
    "lone carriage return": f"{ROW}\r{ROW}\n",
    "comma separated": ROW.replace(" ", ",") + "\n",
    "empty fields between commas": ROW.replace(" ", ",,") + "\n",
    "empty": "",
    "only comments": "# nothing\n# here\n",
    "single row without newline": ROW,
    "byte order mark": "\ufeff" + ROW + "\n",
    "hex": f"{ROW}\n0x10 1 2 3 4 5 6\n",
}


@pytest.mark.parametrize("name", sorted(CASES))
def test_awkward_text_reads_as_the_strict_reader_reads_it(name):
    assert_same_as_strict(CASES[name].encode("utf-8"))


def test_invalid_utf8_reads_as_before():
    assert_same_as_strict(ROW.encode() + b"\n\xff\xfe 1 2 3 4 5 6\n")
