"""Text recordings saved in another encoding than ASCII/UTF-8 (Windows loggers and editors write UTF-16LE with
a byte-order mark) are read as text; a file that is no text is refused as such.

``rst39-utf16le-bom.log`` is gpsd's real OXTS log re-encoded as UTF-16LE with a byte-order mark, as Windows
Notepad saves "Unicode" text (tests/fixtures/real/README.md); the other encodings below are made here the same
way from real files. The truth is the original ASCII file: pynmeagps' decode of it, and the RTKLIB file's
own columns.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from pynmeagps import NMEAReader

from ldvsurvey.errors import BundleError
from ldvsurvey.io.importers import Source, build_bundle, detect, get_importer
from ldvsurvey.io.nmea import parse_nmea

REAL = Path(__file__).resolve().parents[1] / "fixtures" / "real"
RST39 = REAL / "nmea" / "gpsd" / "rst39.log"
UTF16 = REAL / "nmea" / "derived" / "rst39-utf16le-bom.log"
DEMO5 = REAL / "rtklib" / "rtklib-py-demo5-b34f.pos"


def _gga_of(data: bytes) -> list:
    """pynmeagps' GGA messages of an ASCII NMEA file, in file order."""
    out = []
    for ln in data.split(b"\n"):
        if b"GGA," in ln:
            m = NMEAReader.parse(ln.strip(), validate=1)
            if m is not None and m.quality in (1, 2, 4, 5):
                out.append(m)
    return out


def test_the_derived_file_is_the_real_log_in_utf16le_with_a_byte_order_mark():
    data = UTF16.read_bytes()
    assert data[:2] == b"\xff\xfe" and data[2:].decode("utf-16-le").encode("ascii") == RST39.read_bytes()


def test_a_utf16le_nmea_log_imports_as_its_ascii_original():
    # before: not recognised, and as nmea refused "no valid GGA sentence with a fix (... N with a bad checksum)"
    data = UTF16.read_bytes()
    assert detect(data, UTF16.name) == ("nmea", "gnss")
    g = get_importer("nmea").read(data, UTF16.name, "gnss", {})
    ref = _gga_of(RST39.read_bytes())
    assert len(g.lat_deg) == len(ref) == 40
    assert g.lat_deg.tolist() == pytest.approx([m.lat for m in ref], abs=1e-9)
    assert g.lon_deg.tolist() == pytest.approx([m.lon for m in ref], abs=1e-9)
    assert g.h_ell_m.tolist() == pytest.approx([float(m.alt) for m in ref], abs=1e-9)
    # the same lines as in the original: each line of UTF-16 text is a line
    assert g.stamps.where.tolist() == [k + 1 for k, ln in enumerate(RST39.read_bytes().split(b"\n")) if b"GGA," in ln]
    assert any("UTF-16LE with a byte-order mark" in n for n in g.notes)
    assert not any("checksum" in n for n in g.notes)


@pytest.mark.parametrize(
    "encode",
    [
        lambda t: b"\xfe\xff" + t.encode("utf-16-be"),
        lambda t: t.encode("utf-16-le"),  # without a byte-order mark
        lambda t: b"\xef\xbb\xbf" + t.encode("utf-8"),
    ],
    ids=["utf16be-bom", "utf16le-no-bom", "utf8-bom"],
)
def test_other_encodings_of_the_same_nmea_log(encode):
    data = encode(RST39.read_text())
    g = get_importer("nmea").read(data, "rx.nmea", "gnss", {})
    assert g.lat_deg.tolist() == pytest.approx([m.lat for m in _gga_of(RST39.read_bytes())], abs=1e-9)


def test_a_utf16_rtklib_solution_imports_as_its_original():
    text = DEMO5.read_text()
    plain = get_importer("rtklib").read(text.encode(), DEMO5.name, "gnss", {})
    wide = b"\xff\xfe" + text.encode("utf-16-le")
    assert detect(wide, DEMO5.name) == ("rtklib", "gnss")
    g = get_importer("rtklib").read(wide, DEMO5.name, "gnss", {})
    rows = [ln.split() for ln in text.splitlines() if ln.strip() and not ln.startswith("%")]
    assert g.lat_deg.tolist() == pytest.approx([float(r[2]) for r in rows], abs=1e-12)
    assert np.array_equal(g.stamps.values, plain.stamps.values) and np.array_equal(g.h_ell_m, plain.h_ell_m)


def test_a_bundle_gnss_nmea_in_utf16_is_written_as_ascii_by_the_native_importer():
    data = UTF16.read_bytes()
    part = get_importer("native").read(data, "gnss.nmea", "gnss", {})
    assert part.raw_nmea == RST39.read_bytes()
    # the bundle's own reader: gnss.nmea is ASCII text; UTF-16 is named as what it is, not as bad checksums
    with pytest.raises(BundleError) as e:
        parse_nmea(data)
    assert "cannot be read as NMEA text" in e.value.message and "UTF-16" in e.value.message


def test_a_binary_file_given_as_nmea_is_refused_as_no_text():
    # a real u-blox UBX capture (pyubx2): before, "no valid GGA sentence with a fix (0 without a fix, 0 defective,
    # 0 with a bad checksum, N lines that are no NMEA sentence)"
    path = REAL / "pygpsdata-NAV.log"
    with pytest.raises(BundleError) as e:
        get_importer("nmea").read(path.read_bytes(), path.name, "gnss", {})
    assert e.value.file == path.name and "cannot be read as NMEA text" in e.value.message


def test_a_kfgins_file_with_a_utf8_byte_order_mark():
    # the KF-GINS GNSS text of docs/examples as a Windows editor saves it (UTF-8 with a mark): before, the mark
    # made the first row's time "not a number"
    path = Path(__file__).resolve().parents[2] / "docs" / "examples" / "kf-gins" / "gnss.txt"
    text = path.read_text()
    plain = get_importer("kf-gins").read(text.encode(), "gnss.txt", "gnss", {})
    g = get_importer("kf-gins").read(b"\xef\xbb\xbf" + text.encode(), "gnss.txt", "gnss", {})
    assert float(text.split()[1]) == g.lat_deg[0] and np.array_equal(g.lat_deg, plain.lat_deg)


def test_an_import_with_a_utf16_log_writes_an_ascii_gnss_nmea():
    import json

    ex = Path(__file__).resolve().parents[2] / "docs" / "examples"
    text = (ex / "nmea" / "receiver.nmea").read_text()
    srcs = [
        Source("imu", "kf-gins", "imu.txt", (ex / "kf-gins" / "imu.txt").read_bytes()),
        Source("gnss", "nmea", "receiver.nmea", b"\xff\xfe" + text.encode("utf-16-le")),
    ]
    res = build_bundle(srcs, json.loads((ex / "partial.json").read_text()))
    res.files["gnss.nmea"].decode("ascii")
    assert len(parse_nmea(res.files["gnss.nmea"])) == len(_gga_of(text.encode()))
