"""One contract for every importer: the registry gives typed Importer objects, the command line
lists the registry's formats, and options are checked the same way for every format."""

from __future__ import annotations

import pytest

from ldvsurvey.cli import main
from ldvsurvey.errors import BundleError
from ldvsurvey.io.importers import REGISTRY, SNIFF_ORDER, Importer, get_importer, importers

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
