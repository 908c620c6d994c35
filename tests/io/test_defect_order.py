"""A bundle with defects in several files names the same first one however its files are parsed
(imu.csv, then ldv.csv, then gnss.nmea), though gnss.nmea is parsed in a thread beside ldv.csv."""

import pytest

from ldvsurvey.errors import BundleError
from ldvsurvey.io.drivelog import load_bundle, parse_files
from ldvsurvey.io.writers import write_bundle
from tests import badinput

IMU, LDV, GNSS = "non_numeric_cell", "nan_cell", "nmea_bad_altitude"


def _bundle(*defects):
    """The bundle of the first case with the defective file of every other case put in."""
    files, _ = badinput.case(defects[0])
    expected = []
    for name in defects:
        bad, exp = badinput.case(name)
        files[exp["file"]] = bad[exp["file"]]
        expected.append(exp)
    return files, expected


@pytest.mark.parametrize(
    "defects", [(IMU, LDV, GNSS), (LDV, IMU), (GNSS, IMU), (LDV, GNSS), (GNSS, LDV), ("inf_cell", "time_backwards")]
)
def test_first_defect_in_file_order(defects, tmp_path):
    files, expected = _bundle(*defects)
    order = ["imu.csv", "ldv.csv", "gnss.nmea"]
    first = min(expected, key=lambda e: order.index(e["file"]))
    for source in (files, write_bundle(files, tmp_path / "b.zip")):
        with pytest.raises(BundleError) as ei:
            parse_files(source) if isinstance(source, dict) else load_bundle(source)
        err = ei.value
        assert (err.file, err.line, err.field) == (first["file"], first["line"], first["field"]), str(err)


def test_each_defect_alone_still_found():
    for name in (IMU, LDV, GNSS):
        files, (exp,) = _bundle(name)
        with pytest.raises(BundleError) as ei:
            parse_files(files)
        assert (ei.value.file, ei.value.line, ei.value.field) == (exp["file"], exp["line"], exp["field"])
