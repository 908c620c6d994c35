"""A real consumer-MEMS car drive through the ``kf-gins`` importer (issue 34's yardstick).

The first 180 s of rtklibexplorer/GNSS_IMU ``drive_0708`` (see tests/fixtures/real/README.md): a car
standing with its engine idling for 33 s, then driving; IMU at 100 Hz in the car's front-right-down
axes, u-blox RTK fixes at 4 Hz. The import is judged against readings that do not come from the
product: normal gravity (boule's WGS-84 Somigliana formula), the source's own calendar time of the
first fix, the set's documented rate and axes checked by physics (the forward accelerometer against
the GNSS speed's rate of change, the up gyro against the GNSS course's rate of change). The gyros'
rest reading cannot be checked against the Earth rate: their bias (~630 °/h) is 40 times larger.
"""

from __future__ import annotations

import gzip
import json
from pathlib import Path

import boule
import numpy as np

from ldvsurvey.cli import main
from ldvsurvey.io.drivelog import load_bundle

FIX = Path(__file__).resolve().parents[1] / "fixtures" / "real" / "ins"
DRIVE = "rtklibexplorer-drive0708"
#: the source's first fix: ``2025/07/08 19:34:18.499`` GPST in gnss_1934_sf.pos; GPS − UTC = 18 s
FIRST_FIX_UTC_S = 19 * 3600 + 34 * 60 + 18.499 - 18.0
#: the GNSS shows the car standing (speed < 0.1 m/s) for the first 33 s of the IMU record
STILL_S = 30.0


def unpack(tmp: Path, stem: str = DRIVE, outages=(), **initial) -> dict:
    """The excerpt's files in ``tmp``: IMU, GNSS (fixes inside the ``outages`` windows, in seconds
    after the first IMU sample, left out) and the partial manifest (``initial`` keys added)."""
    imu = gzip.decompress((FIX / f"{stem}-imu.txt.gz").read_bytes())
    rows = gzip.decompress((FIX / f"{stem}-gnss.txt.gz").read_bytes()).decode().splitlines()
    t0 = float(imu.split(None, 1)[0])
    keep = [r for r in rows if not any(a <= float(r.split()[0]) - t0 < b for a, b in outages)]
    (tmp / "imu.txt").write_bytes(imu)
    (tmp / "gnss.txt").write_text("\n".join(keep) + "\n")
    partial = json.loads((FIX / f"{stem}-partial.json").read_text())
    if initial:
        partial["initial"] = dict(initial)
    (tmp / "partial.json").write_text(json.dumps(partial))
    return {"imu": tmp / "imu.txt", "gnss": tmp / "gnss.txt", "partial": tmp / "partial.json", "t0": t0}


def import_excerpt(tmp: Path, stem: str = DRIVE, outages=(), **initial):
    """``ldv-survey import`` of the excerpt; the parsed bundle."""
    f = unpack(tmp, stem, outages, **initial)
    out = tmp / "bundle.zip"
    rc = main(["import", "--imu", f"kf-gins:{f['imu']}", "--gnss", f"kf-gins:{f['gnss']}"]
              + ["--manifest", str(f["partial"]), "--out", str(out)])  # fmt: skip
    assert rc == 0
    return load_bundle(out)


def gnss_enu(log):
    """East/north (m) of the fixes about the first one (local tangent plane; a few km)."""
    g = log.gnss
    lat0 = np.radians(g.lat_deg[0])
    r = 6378137.0
    return np.column_stack(
        [np.radians(g.lon_deg - g.lon_deg[0]) * r * np.cos(lat0), np.radians(g.lat_deg - g.lat_deg[0]) * r]
    )


def test_time_rate_and_fixes_against_the_source(tmp_path):
    log = import_excerpt(tmp_path)
    # the source's calendar time of the first fix, through GPS − UTC: not the importer's arithmetic
    # (the bundle's GGA time field keeps microseconds: equal to float rounding)
    assert abs(log.gnss.t_s[0] - FIRST_FIX_UTC_S) < 1e-6
    # every 4-Hz fix came through (one of them at 19:34:59.999 UTC, which the GGA writer must carry)
    assert len(log.gnss.t_s) == 733 and np.allclose(np.diff(log.gnss.t_s), 0.25, atol=2e-3)
    assert set(np.unique(log.gnss.fix)) == {4}  # σ 1 cm: RTK fixed
    # the set's documented 100 Hz
    assert log.manifest.imu.rate_hz == 100.0
    assert abs(np.median(np.diff(log.imu.t_s)) - 0.01) < 5e-5


def test_gravity_at_rest_against_normal_gravity(tmp_path):
    log = import_excerpt(tmp_path)
    t = log.imu.t_s
    k = t < t[0] + STILL_S
    f = log.imu.dvel_mps[k].sum(0) / (t[k][-1] - t[k][0] + 0.01)  # mean specific force, RFU
    gamma = boule.WGS84.normal_gravity((log.gnss.lon_deg[0], log.gnss.lat_deg[0], log.gnss.h_m[0]), si_units=True)
    # an uncalibrated consumer accelerometer: within the set's own initial σ of 0.2 m/s² (2 %); this
    # one reads 1.3 % high (the import accepts it only with import.imu.static_gravity_tolerance)
    assert abs(np.linalg.norm(f) / gamma - 1.0) < 0.02
    # the documented mounting puts the reaction to gravity up: a parked car tilts with the road, < 5°
    tilt = np.degrees(np.arccos(f[2] / np.linalg.norm(f)))
    assert tilt < 5.0


def test_axes_against_the_gnss_track(tmp_path):
    """The forward accelerometer follows the GNSS speed's rate of change, the up gyro the rate of
    change of the GNSS course (counter-clockwise positive about up): the axes, signs and units."""
    log = import_excerpt(tmp_path)
    t_g = log.gnss.t_s
    e = gnss_enu(log)
    v = np.gradient(e, t_g, axis=0)
    speed = np.hypot(v[:, 0], v[:, 1])
    course = np.unwrap(np.arctan2(v[:, 0], v[:, 1]))
    moving = (speed > 3.0) & (t_g > t_g[0] + 40.0) & (t_g < log.imu.t_s[-1] - 1.0)
    dt_imu = np.diff(log.imu.t_s, prepend=log.imu.t_s[0] - 0.01)
    # IMU means over each fix's ±0.5 s
    edges = np.searchsorted(log.imu.t_s, np.column_stack([t_g - 0.5, t_g + 0.5]))
    cs_f = np.vstack([np.zeros(3), np.cumsum(log.imu.dvel_mps, axis=0)])
    cs_w = np.vstack([np.zeros(3), np.cumsum(log.imu.dtheta_rad, axis=0)])
    cs_t = np.concatenate([[0.0], np.cumsum(dt_imu)])
    span = np.maximum(cs_t[edges[:, 1]] - cs_t[edges[:, 0]], 1e-3)  # (the first fixes precede the IMU)
    f_fwd = (cs_f[edges[:, 1], 1] - cs_f[edges[:, 0], 1]) / span
    w_up = (cs_w[edges[:, 1], 2] - cs_w[edges[:, 0], 2]) / span
    a_along = np.gradient(speed, t_g)
    yaw_rate = -np.gradient(course, t_g)  # course is clockwise from north
    k = moving
    slope_f = np.polyfit(a_along[k], f_fwd[k], 1)[0]
    slope_w = np.polyfit(yaw_rate[k], w_up[k], 1)[0]
    # the road's grade adds g·sin(grade) to the forward reading: slope and correlation, not equality
    assert 0.8 < slope_f < 1.2 and np.corrcoef(a_along[k], f_fwd[k])[0, 1] > 0.8
    assert 0.95 < slope_w < 1.05 and np.corrcoef(yaw_rate[k], w_up[k])[0, 1] > 0.95
