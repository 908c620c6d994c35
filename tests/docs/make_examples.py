"""Regenerate the small example recordings under docs/examples/ (run from the repository root):

    PYTHONPATH=backend python -m tests.docs.make_examples

They are 12 s of a vehicle standing still, simulated by the product's simulator and written in each
foreign format by the independent writers of the import tests.
"""

from __future__ import annotations

import datetime as dt
import json
from pathlib import Path

import numpy as np

from ldvsurvey.sim.catalog import RAD
from ldvsurvey.sim.motion import Static
from ldvsurvey.sim.road import Ramps, Road
from ldvsurvey.sim.scenario import Scenario, bundle_files, manifest, simulate
from tests.helpers.nmea import sentence
from tests.io.import_helpers import kfgins_gnss, kfgins_imu

OUT = Path("docs/examples")


def main():
    road = Road(28.4861 * RAD, 113.0623 * RAD, 120.0, 1000.0, Ramps(30 * RAD))
    sc = Scenario(
        name="example",
        road=road,
        segments=[Static(12.0)],
        static_s=12.0,
        ldv_rate_hz=10.0,
        date="2023-03-20",
        t0_s=30000.0,
    )
    sim = simulate(sc, seed=2)
    day = dt.date.fromisoformat(sc.date)
    files = bundle_files(sim)
    partial = manifest(sim)
    for key in ("format", "simulated"):
        partial.pop(key)
    partial["imu"].pop("rate_hz")
    partial["ldv"].pop("rate_hz")
    partial["name"] = "Example drive"
    OUT.mkdir(parents=True, exist_ok=True)
    (OUT / "partial.json").write_text(json.dumps(partial, indent=2) + "\n")
    (OUT / "ldv.csv").write_bytes(files["ldv.csv"])
    kf = OUT / "kf-gins"
    kf.mkdir(exist_ok=True)
    (kf / "imu.txt").write_bytes(kfgins_imu(sim.imu.t_s, sim.dtheta_rad, sim.dvel_mps, day))
    (kf / "gnss.txt").write_bytes(
        kfgins_gnss(sim.gnss_t_s, sim.gnss_lat_deg, sim.gnss_lon_deg, sim.gnss_h_m, sim.gnss_fix, day)
    )
    from tests.io.test_import_novatel import HG1700_AG58, ascii_log

    nv = OUT / "novatel"
    nv.mkdir(exist_ok=True)
    (nv / "span.log").write_bytes(ascii_log(sim, day, np.eye(3), HG1700_AG58))
    from tests.io.test_import_ubx import receiver_stream

    ub = OUT / "ubx"
    ub.mkdir(exist_ok=True)
    # ESF-RAW on a 25.6 kHz sensor clock (as the NEO-M8U), NAV-PVT 40 ms after its epoch, interleaved
    (ub / "receiver.ubx").write_bytes(receiver_stream(sim, day, nav_latency_s=0.04))
    dt_s = 1.0 / sc.imu_rate_hz
    nm = OUT / "nmea"
    nm.mkdir(exist_ok=True)
    from ldvsurvey.io.nmea import format_gga

    lines = []
    for k, t in enumerate(sim.gnss_t_s):
        lines.append(
            format_gga(
                float(t),
                float(sim.gnss_lat_deg[k]),
                float(sim.gnss_lon_deg[k]),
                float(sim.gnss_h_m[k]) + 16.9,
                -16.9,
                int(sim.gnss_fix[k]),
                talker="GP",
            )
        )
        if k == 0:
            lines.append(sentence("GPRMC,082000.00,A,2829.1660,N,11303.7380,E,0.0,30.0,200323,,,A"))
    (nm / "receiver.nmea").write_bytes(("\r\n".join(lines) + "\r\n").encode())
    # any CSV: rates in deg/s, accelerations in g, axes x forward / y left / z up, UNIX time in ms
    cs = OUT / "csv"
    cs.mkdir(exist_ok=True)
    unix0_ms = int((dt.datetime.combine(day, dt.time()) - dt.datetime(1970, 1, 1)).total_seconds() * 1000)
    w = sim.dtheta_rad / dt_s
    f = sim.dvel_mps / dt_s
    w_flu = np.column_stack([w[:, 1], -w[:, 0], w[:, 2]])
    f_flu = np.column_stack([f[:, 1], -f[:, 0], f[:, 2]])
    rows = ["time_ms;gx_dps;gy_dps;gz_dps;ax_g;ay_g;az_g"]
    for t, a, b in zip(sim.imu.t_s, np.degrees(w_flu), f_flu / 9.80665):
        rows.append(
            f"{unix0_ms + int(round(t * 1000))};"
            + ";".join(f"{x:.9g}" for x in a)
            + ";"
            + ";".join(f"{x:.9g}" for x in b)
        )
    (cs / "imu.csv").write_text("\n".join(rows) + "\n")
    p = dict(partial)
    p["date"] = None
    p.pop("date")
    p["import"] = {
        "imu": {
            "axes": "FLU",
            "csv": {
                "delimiter": ";",
                "header": True,
                "time": {"column": "time_ms", "kind": "unix", "unit": "ms"},
                "columns": {
                    "dtheta_x": {"column": "gx_dps", "unit": "deg/s"},
                    "dtheta_y": {"column": "gy_dps", "unit": "deg/s"},
                    "dtheta_z": {"column": "gz_dps", "unit": "deg/s"},
                    "dvel_x": {"column": "ax_g", "unit": "g"},
                    "dvel_y": {"column": "ay_g", "unit": "g"},
                    "dvel_z": {"column": "az_g", "unit": "g"},
                },
            },
        }
    }
    (cs / "partial.json").write_text(json.dumps(p, indent=2) + "\n")


def _standing_companions(prefix: str, name: str, lat: float, lon: float, h: float, date: str, t0: float, dur: float):
    """A simulated IMU (KF-GINS text, 5 Hz) and LDV standing still at a real log's place and time,
    and their partial manifest, as docs/examples/real/<prefix>-imu.txt, -ldv.csv, -partial.json."""
    out = OUT / "real"
    out.mkdir(exist_ok=True)
    road = Road(lat * RAD, lon * RAD, h, 1000.0, Ramps(30 * RAD))
    sc = Scenario(
        name=prefix,
        road=road,
        segments=[Static(dur)],
        static_s=12.0,
        imu_rate_hz=5.0,
        ldv_rate_hz=5.0,
        date=date,
        t0_s=t0,
    )
    sim = simulate(sc, seed=3)
    day = dt.date.fromisoformat(sc.date)
    files = bundle_files(sim)
    (out / f"{prefix}-imu.txt").write_bytes(kfgins_imu(sim.imu.t_s, sim.dtheta_rad, sim.dvel_mps, day))
    (out / f"{prefix}-ldv.csv").write_bytes(files["ldv.csv"])
    partial = json.loads((OUT / "partial.json").read_text())
    partial.update(name=name, date=sc.date)
    partial["initial"].update(lat_deg=lat, lon_deg=lon, h_m=h)
    (out / f"{prefix}-partial.json").write_text(json.dumps(partial, indent=2) + "\n")


def real_nmea_companions():
    """The worked examples on real GNSS logs: gpsd's Telit HE910 NMEA log of 2019-03-12 (as in
    tests/fixtures/real) and the first 90 epochs of rtklib-py's RTKPOST demo5 solution of 2020-12-24,
    each with a simulated IMU and LDV standing still at its place and time."""
    out = OUT / "real"
    out.mkdir(exist_ok=True)
    (out / "telit-he910.nmea").write_bytes(Path("tests/fixtures/real/nmea/gpsd/telit-he910.log").read_bytes())
    _standing_companions("telit", "Telit HE910 log (real NMEA)", 50.8402, 4.3471, 156.0, "2019-03-12", 39110.0, 90.0)
    lines = Path("tests/fixtures/real/rtklib/rtklib-py-demo5-b34f.pos").read_text().splitlines(keepends=True)
    head = [ln for ln in lines if ln.startswith("%")]
    (out / "rtklib-demo5.pos").write_text("".join(head + [ln for ln in lines if not ln.startswith("%")][:90]))
    # 2020-12-24 21:28:42 GPST is 21:28:24 UTC
    _standing_companions(
        "rtklib", "RTKPOST demo5 solution (real)", 40.0970, -105.1472, 1578.8, "2020-12-24", 77300.0, 96.0
    )


if __name__ == "__main__":
    main()
    real_nmea_companions()
