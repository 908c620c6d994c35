"""One contract for every importer: the registry gives typed Importer objects, the command line
lists the registry's formats, and options are checked the same way for every format."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from ldvsurvey.cli import main
from ldvsurvey.errors import BundleError
from ldvsurvey.io.importers import REGISTRY, SNIFF_ORDER, Importer, get_importer, importers

EX = Path(__file__).resolve().parents[2] / "docs" / "examples"
KF_GNSS = b"302400.0 28.4861 113.0623 120.0 0.01 0.01 0.02\n302401.0 28.4861 113.0623 120.0 0.01 0.01 0.02\n"


def test_every_registered_format_is_a_typed_importer():
    got = importers()
    assert [i.name for i in got] == list(REGISTRY)
    for imp in got:
        assert isinstance(imp, Importer)
        assert imp.roles and set(imp.roles) <= {"imu", "gnss", "ldv"}
        assert callable(imp.reader) and callable(imp.sniffer)
        assert imp.summary, f"{imp.name} has no summary for the command line"


def test_the_command_line_lists_the_registry(capsys):
    with pytest.raises(SystemExit) as e:
        main(["import", "--help"])
    assert e.value.code == 0
    out = capsys.readouterr().out
    for imp in importers():
        assert f"  {imp.name} " in out and imp.summary[:30] in out


def test_an_option_of_the_wrong_type_names_its_key():
    with pytest.raises(BundleError) as e:
        get_importer("kf-gins").read(KF_GNSS, "gnss.txt", "gnss", {"geoid_separation_m": "ten"})
    assert e.value.field == "import.gnss.geoid_separation_m" and "a number" in e.value.message
    with pytest.raises(BundleError) as e:
        get_importer("novatel").read(b"", "x.gps", "imu", {"imu_type": [11]})
    assert e.value.field == "import.imu.imu_type"


def test_an_option_a_format_does_not_know_is_named_in_the_notes():
    part = get_importer("kf-gins").read(KF_GNSS, "gnss.txt", "gnss", {"imu_type": 11})
    assert any("import.gnss.imu_type not used by the kf-gins format" in n for n in part.notes)


def test_a_role_a_format_does_not_read_is_an_input_error():
    with pytest.raises(BundleError) as e:
        get_importer("rtklib").read(b"", "x.pos", "imu", {})
    assert e.value.file == "x.pos" and "no imu data" in e.value.message


def test_every_format_but_csv_is_tried_on_dropped_files():
    """``detect`` tries only the formats in ``SNIFF_ORDER``: a registered format left out of it would never be
    recognised among files dropped on the dashboard. ``csv`` needs a column map and is only ever named."""
    assert set(SNIFF_ORDER) == set(REGISTRY) - {"csv"}
    assert len(SNIFF_ORDER) == len(set(SNIFF_ORDER))


def _ubx_partial(tmp_path: Path, imu_options: dict) -> Path:
    partial = json.loads((EX / "partial.json").read_text())
    partial["import"] = {"imu": {"axes": "FRD", **imu_options}}
    path = tmp_path / "partial.json"
    path.write_text(json.dumps(partial))
    return path


@pytest.mark.parametrize(("key", "value", "want"), [("time_offset_s", "0.05", "a number"), ("esf", 1, "a string")])
def test_a_wrong_typed_ubx_option_is_refused_naming_it(tmp_path, capsys, key, value, want):
    """u-blox declares its options like every format: a wrong type is refused before reading (exit 2), nothing
    written; the same options with the right types import."""
    rx = f"ubx:{EX / 'ubx' / 'receiver.ubx'}"
    out = tmp_path / "out" / "drive.zip"
    bad = _ubx_partial(tmp_path, {key: value})
    assert main(["import", "--imu", rx, "--gnss", rx, "--manifest", str(bad), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert f"import.imu.{key}" in err and want in err
    assert not out.parent.exists() or not any(out.parent.iterdir())
    good = _ubx_partial(tmp_path, {key: {"time_offset_s": 0.0, "esf": "raw"}[key]})
    assert main(["import", "--imu", rx, "--gnss", rx, "--manifest", str(good), "--out", str(out)]) == 0
    assert out.is_file()


def test_a_wrong_typed_ubx_option_is_a_422_naming_it(client, db_counts):
    rx = (EX / "ubx" / "receiver.ubx").read_bytes()
    partial = json.loads((EX / "partial.json").read_text())
    partial["import"] = {"imu": {"axes": "FRD", "time_offset_s": "0.05"}}
    files = [("files", ("receiver.ubx", rx, "application/octet-stream"))]
    data = {"manifest": json.dumps(partial), "formats": json.dumps({"receiver.ubx": "ubx:imu"})}
    r = client.post("/api/imports", files=files, data=data)
    assert r.status_code == 422, r.text
    assert r.json()["error"]["field"] == "import.imu.time_offset_s"
    assert db_counts() == {"logs": 0, "log_files": 0, "log_arrays": 0}
