"""A header of a million columns is refused on the header, naming file and line (issue 28: it took
10 s and 209 MB before its 422). Cost figures: benchmarks/bench_wide_header.py."""

import pytest

from ldvsurvey.errors import BundleError
from ldvsurvey.io.csvtable import MAX_COLUMNS, check_column_count
from ldvsurvey.io.drivelog import parse_files
from ldvsurvey.io.importers import Source, build_bundle
from tests.badinput import wide_imu
from tests.bundles import make_bundle


@pytest.mark.parametrize("as_path", [False, True])
def test_million_columns_refused_on_the_header(tmp_path, as_path):
    files = wide_imu(make_bundle(seed=3, n_imu=300), 10**6)
    if as_path:  # how uploads reach the parser: files on disk
        for n, b in files.items():
            (tmp_path / n).write_bytes(b)
        files = {n: tmp_path / n for n in files}
    with pytest.raises(BundleError) as ei:
        parse_files(files)
    assert (ei.value.file, ei.value.line) == ("imu.csv", 2)
    assert f"at most {MAX_COLUMNS}" in ei.value.message


def test_the_limit_is_on_the_count():
    check_column_count("a," * (MAX_COLUMNS - 1) + "a", "x.csv", 1)  # exactly the maximum passes
    with pytest.raises(BundleError, match=f"header has {MAX_COLUMNS + 1} columns") as ei:
        check_column_count(b"a," * MAX_COLUMNS + b"a", "x.csv", 4)
    assert (ei.value.file, ei.value.line) == ("x.csv", 4)


def test_upload_of_a_million_columns_is_422_naming_file_and_line(settings):
    from fastapi.testclient import TestClient

    from ldvsurvey.api.app import create_app

    files = wide_imu(make_bundle(seed=3, n_imu=300), 10**6)  # 7.9 MB: within the size limit here
    with TestClient(create_app(settings.model_copy(update={"max_upload_bytes": 64 << 20}))) as client:
        r = client.post("/api/logs", files=[("files", (n, d, "text/csv")) for n, d in files.items()])
    assert r.status_code == 422, r.text
    err = r.json()["error"]
    assert (err["file"], err["line"]) == ("imu.csv", 2) and str(MAX_COLUMNS) in err["message"]


def test_csv_importer_refuses_a_million_columns_on_the_header():
    text = b"# logger\n" + b",".join(b"c%d" % i for i in range(10**6)) + b"\n1.0" + b",0" * 6 + b"\n"
    partial = {"import": {"imu": {"csv": {"time": {"column": 1, "kind": "bundle"}, "columns": {"dvel_z": 7}}}}}
    with pytest.raises(BundleError) as ei:
        build_bundle([Source("imu", "csv", "imu.txt", text)], partial)
    assert (ei.value.file, ei.value.line) == ("imu.txt", 2) and f"at most {MAX_COLUMNS}" in ei.value.message
