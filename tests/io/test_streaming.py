"""Bundles read from disk: the one-pass reader agrees with the exact one, errors keep their line,
zips are inflated to a temporary folder that goes with the log, and commands import only what
they use."""

import gc
import json
import subprocess
import sys
import zipfile
from pathlib import Path

import numpy as np
import pytest

from ldvsurvey.errors import BundleError, TooLargeError
from ldvsurvey.io import csvtable
from ldvsurvey.io.csvtable import read_numeric_csv
from ldvsurvey.io.drivelog import IMU_COLUMNS, load_bundle, parse_files, stage_zip
from ldvsurvey.io.writers import write_bundle
from tests import badinput
from tests.bundles import make_bundle, zip_bytes

ROOT = Path(__file__).resolve().parents[2]


def _irregular(data: bytes) -> bytes:
    """The same rows with a comment line and a blank line inside the data (the exact reader's case)."""
    lines = data.split(b"\n")
    hdr = next(i for i, ln in enumerate(lines) if ln and not ln.startswith(b"#"))
    return b"\n".join(lines[: hdr + 5] + [b"# a remark in the middle", b""] + lines[hdr + 5 :])


@pytest.mark.parametrize("as_path", [False, True])
def test_one_pass_and_exact_reader_agree(tmp_path, as_path, monkeypatch):
    data = make_bundle(seed=4)["imu.csv"]
    regular, irregular = tmp_path / "a.csv", tmp_path / "b.csv"
    regular.write_bytes(data)
    irregular.write_bytes(_irregular(data))
    calls = []
    exact = csvtable._read_exact
    monkeypatch.setattr(csvtable, "_read_exact", lambda *a: calls.append(1) or exact(*a))
    a = read_numeric_csv(regular if as_path else data, "imu.csv", IMU_COLUMNS, groups={"dv": IMU_COLUMNS[4:]})
    assert calls == []  # the regular file took the one-pass way
    b = read_numeric_csv(
        irregular if as_path else irregular.read_bytes(), "imu.csv", IMU_COLUMNS, groups={"dv": IMU_COLUMNS[4:]}
    )
    assert calls == [1]
    for n in IMU_COLUMNS:
        np.testing.assert_array_equal(a.columns[n], b.columns[n])
    np.testing.assert_array_equal(a.groups["dv"], np.column_stack([a.columns[n] for n in IMU_COLUMNS[4:]]))
    # line numbers: the data starts after the comment and the header; rows after the inserted
    # comment and blank line sit two lines further down
    text = data.decode().split("\n")
    first = next(i for i, ln in enumerate(text) if ln and not ln.startswith("#")) + 2
    np.testing.assert_array_equal(a.line_of_row, first + np.arange(len(a)))
    np.testing.assert_array_equal(b.line_of_row, np.r_[first + np.arange(4), first + 6 + np.arange(len(a) - 4)])
    assert float(a.columns["t"][0]) == float(text[first - 1].split(",")[0])


@pytest.mark.parametrize("name", badinput.CASES)
def test_errors_name_the_line_when_read_from_disk(name, tmp_path):
    files, exp = badinput.case(name)
    folder = write_bundle(files, tmp_path / "bundle")
    with pytest.raises(BundleError) as ei:
        load_bundle(folder)
    err = ei.value
    assert err.file == exp["file"], str(err)
    if exp["line"] is not None:
        assert err.line == exp["line"], str(err)
    if exp["field"] is not None:
        assert err.field == exp["field"], str(err)


@pytest.mark.parametrize("ending", [b"\r\n", b"\r"])
def test_other_line_endings(tmp_path, ending):
    rows = [b"t,v_fwd", b"1.0,2.0", b"2.0,x", b"3.0,4.0"]
    p = tmp_path / "ldv.csv"
    p.write_bytes(ending.join(rows) + ending)
    with pytest.raises(BundleError) as ei:
        read_numeric_csv(p, "ldv.csv", ["t", "v_fwd"])
    if ending == b"\r\n":
        assert ei.value.line == 3 and ei.value.field == "v_fwd"


def test_zip_goes_to_a_temporary_folder_that_goes_with_the_log(tmp_path):
    files = make_bundle(seed=5)
    z = tmp_path / "b.zip"
    z.write_bytes(zip_bytes({**files, "notes.txt": b"not part of the format"}))
    log = load_bundle(z)
    folder = Path(log.files["imu.csv"]).parent
    assert folder.is_dir() and Path(log.files["imu.csv"]).read_bytes() == files["imu.csv"]
    assert log.files["manifest.json"] == files["manifest.json"]  # small files are kept as bytes
    assert any("notes.txt" in w for w in log.warnings)
    ref = parse_files(files)
    assert log.sha256 == ref.sha256  # the bundle's identity does not depend on how it was read
    np.testing.assert_array_equal(log.imu.dvel_mps, ref.imu.dvel_mps)
    del log
    gc.collect()
    assert not folder.exists()


def test_refused_zip_leaves_no_folder(tmp_path):
    z = tmp_path / "bomb.zip"
    z.write_bytes(badinput.bomb_zip(20 * 1024 * 1024))
    parent = tmp_path / "staging"
    with pytest.raises(TooLargeError):
        stage_zip(z, 10 * 1024 * 1024, parent=parent)
    # a member that lies about its size is cut at its declared size
    files = make_bundle(seed=6)
    liar = tmp_path / "liar.zip"
    liar.write_bytes(zip_bytes(files))
    with zipfile.ZipFile(liar) as zf:
        info = zf.getinfo("imu.csv")
    raw = bytearray(liar.read_bytes())
    # shrink the declared size in the central directory entry of imu.csv
    cd = raw.find(b"imu.csv", raw.find(b"PK\x01\x02")) - 46
    assert raw[cd : cd + 4] == b"PK\x01\x02"
    raw[cd + 24 : cd + 28] = (info.file_size // 2).to_bytes(4, "little")
    liar.write_bytes(bytes(raw))
    with pytest.raises((TooLargeError, BundleError)):
        stage_zip(liar, 10**9, parent=parent)
    assert list(parent.iterdir()) == []


def _modules_after(code: str) -> set[str]:
    out = subprocess.run(
        [sys.executable, "-c", code + "\nimport sys, json; print(json.dumps(sorted(sys.modules)))"],
        capture_output=True,
        text=True,
        check=True,
        env={"PYTHONPATH": str(ROOT / "backend"), "PATH": "/usr/bin:/bin"},
    )
    return set(json.loads(out.stdout.strip().splitlines()[-1]))


def test_validate_imports_no_numerical_core(tmp_path):
    folder = write_bundle(make_bundle(seed=7), tmp_path / "bundle")
    mods = _modules_after(f"from ldvsurvey.cli import main; assert main(['validate', {str(folder)!r}]) == 0")
    heavy = {
        m
        for m in mods
        if m.split(".")[0] in ("scipy", "numba", "pandas", "sqlalchemy", "fastapi")
        or m.startswith(("ldvsurvey.nav", "ldvsurvey.pipelines"))
    }
    assert heavy == set()


def test_registry_imports_a_pipeline_only_when_used():
    from ldvsurvey.pipelines.registry import MODULES

    mods = _modules_after(
        "from ldvsurvey.pipelines.registry import get, PIPELINES\n"
        "assert list(PIPELINES) and 'height' in PIPELINES\n"
        "assert get('height').name == 'height'"
    )
    assert "ldvsurvey.pipelines.height" in mods
    others = {m for n, m in MODULES.items() if n != "height" and m in mods}
    # what height itself needs may come along; the rest must not
    assert "ldvsurvey.pipelines.dov" not in others and "ldvsurvey.pipelines.damping" not in others


def test_registry_lists_every_pipeline_under_its_own_name():
    from ldvsurvey.errors import ParameterError
    from ldvsurvey.pipelines.registry import MODULES, PIPELINES, get

    assert [p.name for p in PIPELINES.values()] == list(MODULES) == list(PIPELINES)
    assert all(get(n) is PIPELINES[n] for n in MODULES)
    with pytest.raises(ParameterError, match="unknown pipeline"):
        get("nope")
