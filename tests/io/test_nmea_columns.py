"""The column-at-once NMEA parser against an independent reader (pynmeagps), and its error messages.

A defect anywhere in a long file must still be reported with its own line and field, whichever of
the parser's two paths (all columns at once, or line by line) meets it.
"""

import datetime as dt

import numpy as np
import pytest
from pynmeagps import NMEAReader

from ldvsurvey.errors import BundleError
from ldvsurvey.io.nmea import parse_nmea
from tests.helpers.nmea import sentence


def _survey(n: int = 400, seed: int = 3) -> list[str]:
    """GGA (GP/GN talkers, both hemispheres, no-fix epochs, fractional seconds, empty separation)
    interleaved with RMC/GSA sentences, written by hand here rather than by the product's writer."""
    rng = np.random.default_rng(seed)
    lines = []
    for k in range(n):
        tod = 3600.0 * 23 + 1000.0 + 0.2 * k  # from 23:16:40 on, 5 Hz
        hh, rem = divmod(tod, 3600)
        mm, ss = divmod(rem, 60)
        t = f"{int(hh):02d}{int(mm):02d}{ss:05.2f}"
        lat, lon = rng.uniform(-80, 80), rng.uniform(-179, 179)
        fix = int(rng.choice([0, 1, 2, 4, 5])) if k % 7 else 0
        la = f"{int(abs(lat)):02d}{(abs(lat) % 1) * 60:011.8f}"
        lo = f"{int(abs(lon)):03d}{(abs(lon) % 1) * 60:011.8f}"
        sep = "" if k % 5 == 0 else f"{rng.uniform(-40, 40):.3f}"
        talker = "GP" if k % 2 else "GN"
        if fix:
            body = (
                f"{talker}GGA,{t},{la},{'N' if lat >= 0 else 'S'},{lo},{'E' if lon >= 0 else 'W'},{fix},"
                f"{rng.integers(4, 30):02d},{rng.uniform(0.5, 3):.1f},{rng.uniform(-50, 3000):.4f},M,{sep},M,,"
            )
        else:
            body = f"{talker}GGA,{t},,,,,0,00,,,M,,M,,"
        lines.append(sentence(body))
        if k % 3 == 0:
            lines.append(sentence(f"GNRMC,{t},A,{la},N,{lo},E,0.0,0.0,200323,,,A"))
            lines.append(sentence("GNGSA,A,3,01,02,03,,,,,,,,,,1.4,0.9,1.1"))
    return lines


def test_values_match_pynmeagps_sentence_by_sentence():
    lines = _survey()
    g = parse_nmea("\r\n".join(lines).encode(), t_ref_s=23 * 3600.0)
    ggas = [(i + 1, NMEAReader.parse(s.encode(), validate=1)) for i, s in enumerate(lines) if s[3:6] == "GGA"]
    assert len(g) == len(ggas)
    day = dt.datetime.combine(dt.date(2020, 1, 1), dt.time())
    for j, (lineno, m) in enumerate(ggas):
        assert g.line_of_row[j] == lineno
        tod = (dt.datetime.combine(day.date(), m.time) - day).total_seconds()
        assert g.t_s[j] == pytest.approx(tod, abs=1e-6)
        assert g.fix[j] == m.quality
        if m.quality > 0:
            assert g.lat_deg[j] == pytest.approx(m.lat, abs=1e-9)
            assert g.lon_deg[j] == pytest.approx(m.lon, abs=1e-9)
            assert g.h_m[j] == pytest.approx(m.alt + float(m.sep or 0.0), abs=1e-9)
            assert g.hdop[j] == float(m.HDOP)
            assert g.n_sat[j] == float(m.numSV)
        else:
            assert np.isnan(g.lat_deg[j]) and np.isnan(g.h_m[j])
    assert g.skipped_sentences == {"RMC": 134, "GSA": 134}


def _corrupt(field_index: int, value: str, at: int = 250):
    lines = _survey()
    gga_rows = [i for i, s in enumerate(lines) if s[3:6] == "GGA" and ",0,00," not in s]
    i = gga_rows[at]
    body = lines[i][1:].rpartition("*")[0].split(",")
    body[field_index] = value
    lines[i] = sentence(",".join(body))
    return "\r\n".join(lines).encode(), i + 1


@pytest.mark.parametrize(
    "index,value,field",
    [
        (1, "2316x0.00", "time"),
        (1, "", "time"),
        (1, "256000.00", "time"),
        (2, "12a4.5", "latitude"),
        (4, "", "latitude"),
        (5, "Q", "lon_dir"),
        (6, "", "fix_quality"),
        (6, "4.5", "fix_quality"),
        (9, "12a.5", "altitude"),
        (9, "", "altitude"),
        (9, "nan", "altitude"),
        (11, "inf", "geoid_separation"),
        (7, "x", "num_sats"),
        (8, "1;5", "hdop"),
    ],
)
def test_a_bad_field_deep_in_a_long_file_names_its_line_and_field(index, value, field):
    data, line = _corrupt(index, value)
    with pytest.raises(BundleError) as e:
        parse_nmea(data, t_ref_s=23 * 3600.0)
    assert (e.value.file, e.value.line, e.value.field) == ("gnss.nmea", line, field), str(e.value)


def test_time_going_backwards_deep_in_the_file_names_its_line():
    lines = _survey()
    ggas = [i for i, s in enumerate(lines) if s[3:6] == "GGA"]
    a, b = ggas[300], ggas[302]
    lines[a], lines[b] = lines[b], lines[a]
    with pytest.raises(BundleError) as e:
        parse_nmea("\n".join(lines).encode(), t_ref_s=23 * 3600.0)
    assert (e.value.line, e.value.field) == (ggas[301] + 1, "time")
