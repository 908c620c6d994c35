"""Property-based fuzzing of the parsers of field recordings (NMEA, NovAtel, RTKLIB) and of the
bundle's NMEA reader, starting from real receivers' files: truncations, bit flips, garbage, shuffled
and duplicated records, files cut at random points. Every outcome is a part or a typed input error
naming the file (and the line/message and field where there is one); never another exception, and
never exit 1 from the command line."""

from __future__ import annotations

import random
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from ldvsurvey.cli import main
from ldvsurvey.errors import InputError
from ldvsurvey.io.importers import get_importer
from ldvsurvey.io.nmea import parse_nmea

REAL = Path(__file__).resolve().parents[1] / "fixtures" / "real"
DOCS = Path(__file__).resolve().parents[2] / "docs" / "examples"
CASES = [  # (format, role, file, options)
    ("nmea", "gnss", REAL / "nmea" / "gpsd" / "telit-he910.log", {}),
    ("nmea", "gnss", REAL / "nmea" / "gpsd" / "ublox-8.log", {}),
    ("nmea", "gnss", REAL / "nmea" / "gpsd" / "st-teseo-liv4f.log", {}),
    ("novatel", "gnss", REAL / "novatel" / "swri-span-corrimudata.gps", {}),
    ("novatel", "gnss", REAL / "novatel" / "edie-test-logs.asc", {}),
    ("novatel", "imu", REAL / "novatel" / "edie-test-logs.asc", {"rate_hz": 100}),
    ("novatel", "gnss", REAL / "novatel" / "swri-bestpos-bestvel-psrdop2.gps", {}),
    ("rtklib", "gnss", REAL / "rtklib" / "matrtklib-rover-1hz-rtk.pos", {}),
]
CASES = [c for c in CASES if c[2].is_file()]
FUZZ = settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])


@st.composite
def mutated(draw, data: bytes) -> bytes:
    """One or more of: a cut, bit flips, inserted garbage, shuffled or repeated lines."""
    out = bytearray(data)
    for op in draw(st.lists(st.sampled_from(["cut", "flip", "garbage", "shuffle", "repeat"]), min_size=1, max_size=3)):
        n = len(out)
        if n == 0:
            break
        if op == "cut":
            out = out[: draw(st.integers(0, n))]
        elif op == "flip":
            for _ in range(draw(st.integers(1, 8))):
                k = draw(st.integers(0, n - 1))
                out[k] ^= 1 << draw(st.integers(0, 7))
        elif op == "garbage":
            k = draw(st.integers(0, n))
            out[k:k] = draw(st.binary(min_size=1, max_size=64))
        else:
            lines = bytes(out).split(b"\n")
            rnd = random.Random(draw(st.integers(0, 2**32 - 1)))
            if op == "shuffle":
                rnd.shuffle(lines)
            else:
                k = rnd.randrange(len(lines))
                lines[k:k] = [lines[k]] * rnd.randint(1, 3)
            out = bytearray(b"\n".join(lines))
    return bytes(out)


def _check(err: InputError, file: str) -> None:
    assert err.file == file, str(err)
    assert err.line is not None or err.field is not None or err.message.startswith("no "), str(err)


@pytest.mark.parametrize("fmt,role,path,opts", CASES, ids=[f"{c[0]}-{c[1]}-{c[2].name}" for c in CASES])
def test_importers_on_mutated_real_files(fmt, role, path, opts):
    imp = get_importer(fmt)
    original = path.read_bytes()

    @FUZZ
    @given(data=mutated(original))
    def run(data):
        try:
            imp.read(data, path.name, role, dict(opts))
        except InputError as err:
            _check(err, path.name)

    run()


@FUZZ
@given(data=mutated((REAL / "nmea" / "gpsd" / "ublox-8.log").read_bytes()))
def test_the_bundles_nmea_reader_on_mutated_real_files(data):
    try:
        parse_nmea(data)
    except InputError as err:
        _check(err, "gnss.nmea")


@FUZZ
@given(data=st.binary(max_size=2000))
def test_garbage_is_an_input_error_for_every_text_parser(data):
    for fmt in ("nmea", "rtklib", "novatel"):
        try:
            get_importer(fmt).read(data, "junk.bin", "gnss", {})
        except InputError as err:
            _check(err, "junk.bin")


@settings(
    max_examples=8, deadline=None, suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture]
)
@given(data=mutated((REAL / "nmea" / "gpsd" / "telit-he910.log").read_bytes()), fmt=st.sampled_from(["nmea", "rtklib"]))
def test_the_command_line_exits_0_or_2_never_1(tmp_path, data, fmt):
    gnss = tmp_path / "gnss.txt"
    gnss.write_bytes(
        data if fmt == "nmea" else (REAL / "rtklib" / "matrtklib-rover-1hz-rtk.pos").read_bytes()[: len(data)]
    )
    args = ["import", "--imu", f"kf-gins:{DOCS / 'kf-gins' / 'imu.txt'}", "--gnss", f"{fmt}:{gnss}"]
    args += ["--ldv", f"native:{DOCS / 'ldv.csv'}", "--manifest", str(DOCS / "partial.json")]
    assert main([*args, "--out", str(tmp_path / "out.zip")]) in (0, 2)
