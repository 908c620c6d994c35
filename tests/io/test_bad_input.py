"""Every defect is refused by the parser with file, line and field, and by the CLI with exit 2."""

import pytest

from ldvsurvey.cli import main
from ldvsurvey.errors import BundleError, TooLargeError
from ldvsurvey.io.drivelog import parse_files, read_zip
from ldvsurvey.io.writers import write_bundle
from tests import badinput


@pytest.mark.parametrize("name", badinput.CASES)
def test_parser_names_file_line_field(name):
    files, exp = badinput.case(name)
    with pytest.raises(BundleError) as ei:
        parse_files(files)
    err = ei.value
    assert err.file == exp["file"], str(err)
    if exp["line"] is not None:
        assert err.line == exp["line"], str(err)
    if exp["field"] is not None:
        assert err.field == exp["field"], str(err)


@pytest.mark.parametrize("name", badinput.CASES)
def test_cli_validate_exits_2(name, tmp_path, capsys):
    files, exp = badinput.case(name)
    path = write_bundle(files, tmp_path / "bundle")
    assert main(["validate", str(path)]) == 2
    err = capsys.readouterr().err
    assert exp["file"] in err
    if exp["line"] is not None:
        assert f"line {exp['line']}" in err
    if exp["field"] is not None:
        assert exp["field"] in err


def test_cli_validate_good_bundle(tmp_path, capsys):
    from tests.bundles import make_bundle

    path = write_bundle(make_bundle(seed=1), tmp_path / "b.zip")
    assert main(["validate", str(path)]) == 0
    assert "valid ldv-drive-log/1" in capsys.readouterr().out


def test_truncated_zip():
    with pytest.raises(BundleError, match="truncated or corrupt"):
        read_zip(badinput.truncated_zip(), 10**9)


@pytest.mark.parametrize("path", ["../evil.txt", "/etc/evil", "a/../../evil", "C:/evil"])
def test_zip_unsafe_paths(path):
    with pytest.raises(BundleError, match="unsafe path") as ei:
        read_zip(badinput.traversal_zip(path), 10**9)
    assert ei.value.field == path


def test_zip_bomb_refused():
    with pytest.raises(TooLargeError):
        read_zip(badinput.bomb_zip(20 * 1024 * 1024), 10 * 1024 * 1024)
    with pytest.raises(TooLargeError, match="zip bomb"):  # ratio guard even within the size limit
        read_zip(badinput.bomb_zip(20 * 1024 * 1024), 10**9, max_ratio=200)


@pytest.mark.parametrize("member", ["imu.csv", "ldv.csv", "manifest.json"])
def test_corrupt_deflate_data_names_the_member(member, tmp_path, capsys):
    """zlib.error from a member's deflate data was not caught (issue 28): a 500 in the API."""
    bad = badinput.corrupt_deflate_zip(member)
    with pytest.raises(BundleError, match="truncated or corrupt") as ei:
        read_zip(bad, 10**9)
    assert ei.value.field == member
    path = tmp_path / "bad.zip"
    path.write_bytes(bad)
    assert main(["validate", str(path)]) == 2  # stage_zip, the command line's reader
    assert f"field '{member}'" in capsys.readouterr().err


def test_encrypted_member_names_the_member(tmp_path, capsys):
    path = tmp_path / "enc.zip"
    path.write_bytes(badinput.encrypted_flag_zip("imu.csv"))
    assert main(["validate", str(path)]) == 2
    assert "field 'imu.csv'" in capsys.readouterr().err
