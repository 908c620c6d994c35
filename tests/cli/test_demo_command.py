"""``ldv-survey demo``: a length the scenario cannot be driven in is refused naming the option."""

from __future__ import annotations

from ldvsurvey.cli import main


def test_too_short_a_height_drive_is_refused_naming_duration(tmp_path, capsys):
    # 400 s: the 300 s static start, the turn and the stops leave nothing to drive (was a ZeroDivisionError)
    assert main(["demo", str(tmp_path / "d"), "--scenario", "height", "--duration-s", "399"]) == 2
    err = capsys.readouterr().err
    assert "--duration-s" in err and "more than 400 s" in err
    assert not (tmp_path / "d").exists()  # nothing written
