"""The ``rtklib`` importer on real RTKLIB solution files (see tests/fixtures/real/README.md).

Independent truth: RTKLIB's own header (``obs start : ... GPST (week2137 422922.0s)``), calendar
arithmetic done here with ``datetime``, and the columns read by numpy's text reader.
"""

from __future__ import annotations

import datetime as dt
import math
import re
from pathlib import Path

import numpy as np
import pytest

from ldvsurvey.errors import BundleError
from ldvsurvey.io.importers import detect, get_importer

REAL = Path(__file__).resolve().parents[1] / "fixtures" / "real" / "rtklib"
DEMO5 = REAL / "rtklib-py-demo5-b34f.pos"
MAT = REAL / "matrtklib-rover-1hz-rtk.pos"
GGA_OF_Q = {1: 4, 2: 5, 3: 2, 4: 2, 5: 1, 6: 5}


def _columns(path: Path) -> np.ndarray:
    rows = [ln.split() for ln in path.read_text().splitlines() if ln and not ln.startswith("%")]
    return np.array([r[2:7] for r in rows], dtype=np.float64)  # lat lon h Q ns after date and time


@pytest.mark.parametrize("path", [DEMO5, MAT], ids=lambda p: p.name)
def test_solutions_against_the_columns_and_the_calendar(path):
    data = path.read_bytes()
    assert detect(data, path.name) == ("rtklib", "gnss")
    g = get_importer("rtklib").read(data, path.name, "gnss", {})
    cols = _columns(path)
    keep = np.isin(cols[:, 3], list(GGA_OF_Q))
    np.testing.assert_array_equal(g.lat_deg, cols[keep, 0])
    np.testing.assert_array_equal(g.lon_deg, cols[keep, 1])
    np.testing.assert_array_equal(g.h_ell_m, cols[keep, 2])
    np.testing.assert_array_equal(g.fix, [GGA_OF_Q[int(q)] for q in cols[keep, 3]])
    first = next(ln for ln in path.read_text().splitlines() if ln and not ln.startswith("%"))
    t = dt.datetime.strptime(first[:23], "%Y/%m/%d %H:%M:%S.%f") - dt.datetime(1980, 1, 6)
    assert g.stamps.week[0] == t.days // 7
    assert g.stamps.values[0] == (t.days % 7) * 86400 + t.seconds + t.microseconds * 1e-6


def test_the_first_epoch_is_where_rtklib_says_it_is():
    head = DEMO5.read_text()
    week, sow = re.search(r"obs start : .* GPST \(week(\d+) ([\d.]+)s\)", head).groups()
    g = get_importer("rtklib").read(DEMO5.read_bytes(), DEMO5.name, "gnss", {})
    assert (g.stamps.week[0], g.stamps.values[0]) == (int(week), float(sow))


def test_without_the_height_line_the_user_must_say_which_height():
    text = "\n".join(ln for ln in DEMO5.read_text().splitlines() if "lat/lon/height=" not in ln) + "\n"
    with pytest.raises(BundleError) as e:
        get_importer("rtklib").read(text.encode(), "rover.pos", "gnss", {})
    assert e.value.field == "height" and "ellipsoidal" in e.value.message
    g = get_importer("rtklib").read(text.encode(), "rover.pos", "gnss", {"height": "ellipsoidal"})
    assert len(g.lat_deg) == 276


def test_geodetic_heights_are_refused():
    text = DEMO5.read_text().replace("WGS84/ellipsoidal", "WGS84/geodetic")
    with pytest.raises(BundleError) as e:
        get_importer("rtklib").read(text.encode(), "rover.pos", "gnss", {"height": "ellipsoidal"})
    assert "geodetic" in e.value.message


def test_utc_and_jst_times_are_calendar_utc():
    text = MAT.read_text()
    g_utc = get_importer("rtklib").read(text.replace("%  GPST ", "%  UTC  ").encode(), "u.pos", "gnss", {})
    assert g_utc.stamps.kind == "unix"
    unix = g_utc.stamps.values[0] + g_utc.stamps.offset_s
    assert unix == (dt.datetime(2023, 7, 11, 6, 4, 32) - dt.datetime(1970, 1, 1)).total_seconds()
    g_jst = get_importer("rtklib").read(text.replace("%  GPST ", "%  JST  ").encode(), "j.pos", "gnss", {})
    assert g_jst.stamps.values[0] + g_jst.stamps.offset_s == unix - 9 * 3600


def test_ecef_solutions_are_converted_to_latitude_longitude_height():
    a, f = 6378137.0, 1 / 298.257223563
    e2 = f * (2 - f)
    lat, lon, h = 35.165360854, 136.881409534, 41.4069
    n = a / math.sqrt(1 - e2 * math.sin(math.radians(lat)) ** 2)
    x = (n + h) * math.cos(math.radians(lat)) * math.cos(math.radians(lon))
    y = (n + h) * math.cos(math.radians(lat)) * math.sin(math.radians(lon))
    z = (n * (1 - e2) + h) * math.sin(math.radians(lat))
    text = (
        "% (x/y/z-ecef=WGS84,Q=1:fix,2:float,3:sbas,4:dgps,5:single,6:ppp,ns=# of satellites)\n"
        "%  GPST                      x-ecef(m)      y-ecef(m)      z-ecef(m)   Q  ns\n"
        f"2023/07/11 06:04:32.000 {x:.4f} {y:.4f} {z:.4f} 1 19\n"
    )
    g = get_importer("rtklib").read(text.encode(), "e.pos", "gnss", {})
    # the file rounds x, y, z to 0.1 mm: 1e-9 deg is 0.1 mm
    assert g.lat_deg[0] == pytest.approx(lat, abs=2e-9) and g.lon_deg[0] == pytest.approx(lon, abs=2e-9)
    assert g.h_ell_m[0] == pytest.approx(h, abs=1e-3)  # the file's 0.1 mm rounding


def test_a_bad_number_names_line_and_field():
    lines = MAT.read_text().splitlines()
    k = next(i for i, ln in enumerate(lines) if ln and not ln.startswith("%"))
    lines[k + 3] = lines[k + 3].replace("136.88", "136.8x", 1)
    with pytest.raises(BundleError) as e:
        get_importer("rtklib").read("\n".join(lines).encode(), "r.pos", "gnss", {})
    assert (e.value.line, e.value.field) == (k + 4, "longitude")
