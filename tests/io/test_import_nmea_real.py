"""The ``nmea`` importer and the bundle's NMEA reader (one reader, two modes) on real receivers' logs.

The yardstick is gpsd's regression logs (``tests/fixtures/real/nmea/gpsd``, many receivers from 1999
to 2024, with pre-fix sentences, binary frames, empty fields, out-of-order epochs), each sentence
decoded independently by pynmeagps. Every file must import with the epochs pynmeagps finds, or be
refused with a typed error naming file, line and field; never anything else.
"""

from __future__ import annotations

import datetime as dt
import re
from pathlib import Path

import numpy as np
import pytest
from pynmeagps import NMEAReader

from ldvsurvey.errors import BundleError
from ldvsurvey.io.importers import nmea
from ldvsurvey.io.nmea import parse_nmea
from tests.helpers.nmea import sentence

GPSD = Path(__file__).resolve().parents[1] / "fixtures" / "real" / "nmea" / "gpsd"
LOGS = sorted(GPSD.glob("*.log"))
#: qualities that are a measured position (6 dead reckoning, 7 manual input, 8 simulator are not)
MEASURED = (1, 2, 3, 4, 5)


def _independent(data: bytes) -> dict[int, object]:
    """Line number -> pynmeagps GGA message (good checksum, measured quality) of every line."""
    out = {}
    for lineno, raw in enumerate(data.split(b"\n"), start=1):
        k = raw.rfind(b"$")
        if k < 0 or b"GGA," not in raw[k:]:
            continue
        try:
            m = NMEAReader.parse(raw[k:].strip(), validate=1)
        except Exception:  # noqa: BLE001 - pynmeagps raises several types for what it cannot read
            continue
        if m is not None and m.msgID == "GGA" and isinstance(m.quality, int) and m.quality in MEASURED:
            out[lineno] = m
    return out


def test_the_fixture_set_is_there():
    assert len(LOGS) >= 100, "tests/fixtures/real/nmea/gpsd holds the gpsd logs (see its README)"


def test_at_least_95_percent_of_real_logs_with_a_fixed_gga_import_and_the_rest_are_refused_by_name():
    with_fix, imported, refused = 0, [], []
    for path in LOGS:
        data = path.read_bytes()
        if not _independent(data):
            continue
        with_fix += 1
        try:
            nmea.read(data, path.name, "gnss", {})
            imported.append(path.name)
        except BundleError as exc:  # any other exception fails the test: exit 1
            assert exc.file == path.name
            assert exc.line is not None or "no valid GGA" in exc.message, str(exc)
            refused.append(f"{exc}")
    share = len(imported) / with_fix
    print(f"\n{len(imported)}/{with_fix} real NMEA logs with a fixed GGA import ({100 * share:.1f} %); refused:")
    print("\n".join(refused))
    assert share >= 0.95


@pytest.mark.parametrize("path", LOGS, ids=[p.name for p in LOGS])
def test_every_imported_epoch_is_the_receivers_sentence_as_pynmeagps_reads_it(path):
    data = path.read_bytes()
    ref = _independent(data)
    try:
        g = nmea.read(data, path.name, "gnss", {})
    except BundleError as exc:
        assert exc.file == path.name
        return
    lines = g.stamps.where.tolist()
    assert set(lines) <= set(ref), "an epoch from a line pynmeagps does not read as a measured fix"
    for j, ln in enumerate(lines):
        m = ref[ln]
        assert g.lat_deg[j] == pytest.approx(m.lat, abs=1e-9)
        assert g.lon_deg[j] == pytest.approx(m.lon, abs=1e-9)
        sep = float(m.sep) if m.sep != "" else 0.0
        assert g.h_ell_m[j] == pytest.approx(float(m.alt) + sep, abs=1e-9)
        assert g.sep_m[j] == pytest.approx(sep, abs=1e-12)
        assert g.fix[j] == m.quality
        tod = m.time.hour * 3600 + m.time.minute * 60 + m.time.second + m.time.microsecond * 1e-6
        assert (g.stamps.values[j] - tod) % 86400.0 == pytest.approx(0.0, abs=1e-6)
    # what is not imported is accounted for: no altitude, a repeated or stray epoch
    missing = [ln for ln in ref if ln not in set(lines)]
    times = {round(float(v) % 86400.0, 3) for v in g.stamps.values}
    for ln in missing:
        m = ref[ln]
        tod = round(m.time.hour * 3600 + m.time.minute * 60 + m.time.second + m.time.microsecond * 1e-6, 3)
        assert m.alt == "" or tod in times or any("out of order" in n for n in g.notes), f"line {ln} lost"
    assert np.all(np.diff(g.stamps.values) > 0)


def test_pre_fix_sentences_are_left_out_not_fatal():
    # telit-he910: 37 pre-fix sentences "$GPGGA,,,,,,0,,,,M,,M,,*66" before the first fix (exit 2 before)
    g = nmea.read((GPSD / "telit-he910.log").read_bytes(), "telit-he910.log", "gnss", {})
    assert len(g.lat_deg) > 20
    assert any("without a fix" in n for n in g.notes)
    rmc = next(
        m
        for m in (
            NMEAReader.parse(ln.strip(), validate=1) for ln in (GPSD / "telit-he910.log").read_bytes().split(b"\n")
        )
        if m is not None and m.msgID == "RMC" and m.status == "A"
    )
    assert g.stamps.day == rmc.date == dt.date(2019, 3, 12)  # (the log's header gives its submission, 03-14)


def test_double_dollar_sentences_are_read():
    # st-teseo-liv4f writes "$$GNGGA,...": 330 sentences counted as bad checksums before
    g = nmea.read((GPSD / "st-teseo-liv4f.log").read_bytes(), "st-teseo-liv4f.log", "gnss", {})
    assert len(g.lat_deg) == len(_independent((GPSD / "st-teseo-liv4f.log").read_bytes())) == 12
    assert 47.3 < g.lat_deg[0] < 47.4


def test_empty_altitude_names_line_and_field():
    # polarx2: fixes without altitude (2-D): no height, no epoch; the refusal names the first one
    with pytest.raises(BundleError) as e:
        nmea.read((GPSD / "polarx2.log").read_bytes(), "polarx2.log", "gnss", {})
    assert (e.value.file, e.value.field) == ("polarx2.log", "altitude") and e.value.line is not None
    assert "None" not in e.value.message


def _fix(t: str, alt: str = "545.4") -> str:
    return sentence(f"GPGGA,{t},4807.0380,N,01131.0000,E,1,08,0.9,{alt},M,46.9,M,,")


def test_a_malformed_gga_with_a_good_checksum_is_skipped_and_named():
    lines = [_fix("123519"), sentence("GPGGA,123520,48x7.038,N,01131.000,E,1,08,0.9,545.4,M,46.9,M,,"), _fix("123521")]
    g = nmea.read("\r\n".join(lines).encode(), "rx.nmea", "gnss", {})
    assert g.stamps.where.tolist() == [1, 3]
    note = next(n for n in g.notes if "defective" in n)
    assert "line 2" in note and "latitude" in note


def test_a_sentence_right_after_a_binary_frame_is_read():
    ubx = b"\xb5b\x01\x07\x5c\x00" + bytes(range(92)).replace(b"\n", b"\x00") + b"\x12\x34"
    data = _fix("123519").encode() + b"\r\n" + ubx + _fix("123520").encode() + b"\r\n"
    g = nmea.read(data, "rx.nmea", "gnss", {})
    assert g.stamps.where.tolist() == [1, 2]
    assert any("binary" in n for n in g.notes)


def test_simulator_and_dead_reckoning_fixes_are_not_measurements():
    body = "GPGGA,125106,3854.5087,N,07726.4523,W,{q},10,2.0,268.8,M,-33.9,M,,"
    data = "\r\n".join(sentence(body.format(q=q)) for q in (8, 6, 7)).encode()
    with pytest.raises(BundleError):
        nmea.read(data, "sim.nmea", "gnss", {})


DERIVED = GPSD.parent / "derived"


def _tod(m) -> float:
    return m.time.hour * 3600 + m.time.minute * 60 + m.time.second + m.time.microsecond * 1e-6


def test_epochs_written_out_of_order_are_sorted_and_exact_repeats_dropped():
    # rst39-out-of-order.log: gpsd's OXTS log (10 Hz, driving at 4.8 m/s) with five pairs of epochs written in
    # the wrong order and the last three written again (see the fixtures' README); refused before ("GGA time goes
    # backwards ... the receiver's clock jumped")
    data = (DERIVED / "rst39-out-of-order.log").read_bytes()
    assert sorted(data.split(b"\n")) == sorted((GPSD / "rst39.log").read_bytes().split(b"\n") + _last_ggas(3))
    ref = sorted({_tod(m): m for m in _independent((GPSD / "rst39.log").read_bytes()).values()}.items())
    g = nmea.read(data, "rst39-out-of-order.log", "gnss", {})
    assert len(g.lat_deg) == len(ref) == 40
    for j, (tod, m) in enumerate(ref):
        assert g.stamps.values[j] == pytest.approx(tod, abs=1e-6)
        assert (g.lat_deg[j], g.lon_deg[j]) == (pytest.approx(m.lat, abs=1e-9), pytest.approx(m.lon, abs=1e-9))
    assert any("5 GGA epoch(s) written out of order sorted into place" in n for n in g.notes), g.notes
    assert any("3 repeated GGA epoch(s) skipped" in n for n in g.notes), g.notes


def _last_ggas(n: int) -> list[bytes]:
    return [ln for ln in (GPSD / "rst39.log").read_bytes().split(b"\n") if b"GGA," in ln][-n:]


def test_a_log_whose_sessions_are_in_reverse_order_is_sorted_into_one_track():
    # bt451: a session at 15:25 (standing) and then one at 14:33 (driving at 15 m/s, 2 km away): sorted by time
    # they make one track with a pause; refused before as a clock jump
    data = (GPSD / "bt451.log").read_bytes()
    ref = sorted((_tod(m), m) for m in _independent(data).values())
    g = nmea.read(data, "bt451.log", "gnss", {})
    assert [round(t, 2) for t in g.stamps.values] == [round(t, 2) for t, _ in ref]
    assert g.lat_deg.tolist() == pytest.approx([m.lat for _, m in ref], abs=1e-9)
    assert any("5 GGA epoch(s) written out of order" in n and "line 112" in n for n in g.notes), g.notes


def test_a_clock_that_jumps_back_is_refused_because_the_fixes_make_no_track():
    # humminbird-M37: 19:41:04-19:41:24, then 19:41:14 and 19:41:18 while the boat keeps going east at 2.7 m/s;
    # sorted, those two lie 60 m off the track between their neighbours in time
    with pytest.raises(BundleError) as e:
        nmea.read((GPSD / "humminbird-M37.log").read_bytes(), "humminbird-M37.log", "gnss", {})
    assert (e.value.file, e.value.line, e.value.field) == ("humminbird-M37.log", 93, "time")
    assert "no track" in e.value.message
    # the speed the message gives for the rest of the log against the boat's own (RMC speed over ground, knots)
    data = (GPSD / "humminbird-M37.log").read_bytes()
    rmc = [NMEAReader.parse(ln.strip()) for ln in data.split(b"\n") if b"RMC," in ln]
    v_rmc = np.median([m.spd for m in rmc]) * 1852.0 / 3600.0
    v_said = float(re.search(r"against ([0-9.]+) m/s", e.value.message).group(1))
    assert v_said == pytest.approx(v_rmc, abs=0.3)


def test_epochs_out_of_order_across_midnight_keep_counting():
    # rst39's sentences with their times moved back by 20:41:34.00 - 24:00:00 (checksums recomputed), so that the
    # drive crosses midnight, and the epochs of 23:59:59.90 and 00:00:00.00 written in the wrong order
    shift = 20 * 3600 + 41 * 60 + 34.0
    out = []
    for ln in (GPSD / "rst39.log").read_text().splitlines():
        if "GGA," not in ln:
            continue
        f = ln[1 : ln.index("*")].split(",")
        t = (int(f[1][:2]) * 3600 + int(f[1][2:4]) * 60 + float(f[1][4:]) - shift) % 86400.0
        f[1] = f"{int(t // 3600):02d}{int(t % 3600 // 60):02d}{t % 60:05.2f}"
        out.append(sentence(",".join(f)))
    k = next(i for i, x in enumerate(out) if ",000000.00," in x)
    out[k - 1], out[k] = out[k], out[k - 1]
    g = nmea.read("\r\n".join(out).encode(), "midnight.nmea", "gnss", {})
    assert len(g.lat_deg) == 40
    assert np.diff(g.stamps.values) == pytest.approx(np.full(39, 0.1), abs=1e-6)
    assert g.stamps.values[0] == pytest.approx(86400.0 - 1.9, abs=1e-6)  # 23:59:58.10, then on past 86400 s


def test_a_file_whose_every_checksum_is_wrong_is_an_input_error():
    # regression: IndexError (exit 1) in the bundle's reader
    data = b"$GPGGA,123519,4807.038,N,01131.000,E,1,08,0.9,545.4,M,46.9,M,,*00\r\n" * 3
    with pytest.raises(BundleError) as e:
        parse_nmea(data)
    assert e.value.file == "gnss.nmea" and "3 with a bad checksum" in e.value.message
    with pytest.raises(BundleError):
        nmea.read(data, "rx.nmea", "gnss", {})


def test_the_bundle_reader_leaves_pre_fix_sentences_out():
    data = ("$GPGGA,,,,,,0,,,,M,,M,,*66\r\n" + _fix("123519") + "\r\n").encode()
    g = parse_nmea(data)
    assert len(g) == 1 and g.no_fix == 1


def test_the_bundle_reader_is_the_importers_reader():
    import inspect

    src = inspect.getsource(nmea)
    assert "parse_nmea" in src and "pynmea" not in src


def test_real_logs_are_recognised_from_their_content():
    # gpsd's logs start with comment lines, real captures with cut sentences or binary frames: 102 of
    # the 105 were recognised by no format before (the sniffer wanted '$' first)
    from ldvsurvey.io.importers import detect

    got = {p.name: detect(p.read_bytes(), p.name) for p in LOGS}
    assert all(v in (("nmea", "gnss"), ("ubx", "gnss")) for v in got.values()), got
    assert sum(v == ("nmea", "gnss") for v in got.values()) >= 100


def _with_quality(path: Path, quality: int) -> bytes:
    """A real log with every GGA's fix quality set to ``quality`` (checksums recomputed)."""
    out = []
    for ln in path.read_text().splitlines():
        if "GGA," in ln and "*" in ln:
            f = ln[1 : ln.index("*")].split(",")
            f[6] = str(quality)
            ln = sentence(",".join(f))
        out.append(ln)
    return "\r\n".join(out).encode()


def test_simulator_fixes_are_counted_in_the_refusal():
    # gpsd's Garmin GPSmap 76S log in its simulator mode: every GGA of quality 8; before, the refusal said
    # "0 without a fix, 0 defective, 0 with a bad checksum": nothing named what the file held
    path = GPSD.parent / "gpsd-extra" / "GPSmap-76S.log"
    data = path.read_bytes()
    q = [m.quality for m in (NMEAReader.parse(ln.strip()) for ln in data.split(b"\n") if b"GGA," in ln)]
    assert set(q) == {8}
    with pytest.raises(BundleError) as e:
        nmea.read(data, path.name, "gnss", {})
    assert f"{len(q)} of quality 6, 7 or 8 (dead reckoning, manual input, simulator)" in e.value.message


def test_manual_input_fixes_are_counted_in_the_refusal():
    # no real log of quality 7 was found: rst39's 40 fixes as a receiver in manual-input mode would write them
    with pytest.raises(BundleError) as e:
        nmea.read(_with_quality(GPSD / "rst39.log", 7), "rst39.log", "gnss", {})
    assert "40 of quality 6, 7 or 8 (dead reckoning, manual input, simulator)" in e.value.message


def test_an_rmc_only_log_is_refused_saying_what_it_holds_and_lacks():
    # gpsd's Magellan EC-10X log: RMC only ("as dumb as NMEA gets"); before, "no valid GGA sentence with a fix
    # (0 without a fix, 0 defective, ...)"
    path = GPSD.parent / "gpsd-extra" / "magellan-ec10.log"
    data = path.read_bytes()
    rmc = [
        (k, m)
        for k, ln in enumerate(data.split(b"\n"), start=1)
        if b"RMC," in ln and (m := NMEAReader.parse(ln.strip(), validate=1)) is not None and m.status == "A"
    ]
    with pytest.raises(BundleError) as e:
        nmea.read(data, path.name, "gnss", {})
    assert (e.value.file, e.value.line, e.value.field) == (path.name, rmc[0][0], "GGA")
    assert f"positions without a height ({len(rmc)} RMC with status A" in e.value.message


def test_a_gll_only_marine_log_is_refused_saying_what_it_holds():
    # SignalK's plaka.log (a sailing boat's instruments: GLL positions, wind, depth, AIS...): before, no format
    # recognised it (the sniffer wanted GGA or RMC)
    from ldvsurvey.io.importers import detect

    path = GPSD.parent / "signalk" / "plaka-head.log"
    data = path.read_bytes()
    gll = [
        k
        for k, ln in enumerate(data.split(b"\n"), start=1)
        if b"GLL," in ln and (m := NMEAReader.parse(ln.strip(), validate=1)) is not None and m.status == "A"
    ]
    assert detect(data, path.name) == ("nmea", "gnss")
    with pytest.raises(BundleError) as e:
        nmea.read(data, path.name, "gnss", {})
    assert (e.value.line, e.value.field) == (gll[0], "GGA")
    assert f"({len(gll)} GLL with status A" in e.value.message


def test_ais_lines_are_recognised_and_ignored():
    # gpsd's ais-nmea.log: a boat's GPS with an AIS receiver; before, the !AIVDM lines were counted as "lines that
    # are not NMEA sentences"
    data = (GPSD / "ais-nmea.log").read_bytes()
    n_ais = sum(1 for ln in data.split(b"\n") if re.match(rb"!AIVD[MO],", ln))
    n_other = sum(1 for ln in data.split(b"\n") if ln.strip() and not ln.strip().startswith((b"!AIVD", b"$")))
    g = nmea.read(data, "ais-nmea.log", "gnss", {})
    assert any(f"{n_ais} AIS line(s)" in n for n in g.notes), g.notes
    assert any(f"{n_other} line(s) that are not NMEA sentences" in n for n in g.notes), g.notes
    assert len(g.lat_deg) == len(_independent(data))


@pytest.mark.parametrize("name", ["mr-350p.log", "hemi.log", "ericsson-gru04-02-70sec.log"])
def test_a_log_without_rmc_is_dated_by_its_zda(name):
    # these receivers write ZDA, not RMC; before, the manifest had to give the date
    data = (GPSD / name).read_bytes()
    zda = [m for m in (NMEAReader.parse(ln.strip()) for ln in data.split(b"\n") if b"ZDA," in ln) if m is not None]
    fix_times = {_tod(m) for m in _independent(data).values()}
    z = next(m for m in zda if any(abs(_tod(m) - t) <= 1.5 for t in fix_times))  # at the time of a fix
    g = nmea.read(data, name, "gnss", {})
    assert g.stamps.day == dt.date(z.year, z.month, z.day)
    assert any("dated" in n and "ZDA line" in n for n in g.notes), g.notes


def test_rmc_and_zda_dating_the_log_differently_is_warned():
    # rst39's ZDA sentences moved a day on (checksums recomputed): the RMC's date (2014-02-19) is kept, both named
    out = []
    for ln in (GPSD / "rst39.log").read_text().splitlines():
        if "ZDA," in ln:
            f = ln[1 : ln.index("*")].split(",")
            f[2] = f"{int(f[2]) + 1:02d}"
            ln = sentence(",".join(f))
        out.append(ln)
    data = "\r\n".join(out).encode()
    rmc = next(m for m in (NMEAReader.parse(x.strip()) for x in data.split(b"\n") if b"RMC," in x) if m)
    g = nmea.read(data, "rst39.log", "gnss", {})
    assert g.stamps.day == rmc.date == dt.date(2014, 2, 19)
    assert any("dates the log 2014-02-19" in n and "2014-02-20" in n for n in g.notes), g.notes
