"""Start position from GNSS: the best fixes of the static period, averaged, through the lever arm.

Truth: the simulator's IMU-centre position at the start. The receiver starts with single-point
fixes (σ 2 m) before RTK (σ 2 cm) comes in; the antenna sits 0.8 m right, 1.2 m behind and 1.6 m above the IMU.
"""

import dataclasses
import json

import numpy as np
import pytest

from ldvsurvey.io.drivelog import parse_files
from ldvsurvey.nav.earth import enu_offset_m
from ldvsurvey.pipelines.stages.aids import nav_inputs
from ldvsurvey.sim import catalog
from ldvsurvey.sim.scenario import bundle_files, simulate


def _files(sim, keep_initial=False):
    f = bundle_files(sim)
    m = json.loads(f["manifest.json"])
    if not keep_initial:
        for k in ("lat_deg", "lon_deg", "h_m"):
            m["initial"].pop(k)
    f["manifest.json"] = json.dumps(m).encode()
    return f


@pytest.fixture(scope="module")
def sim():
    sc = catalog.drive(minutes=2.5, static_s=100.0)
    # a lever arm with all three components (m, body RFU); single fixes for the first 15 s, then RTK
    sc = dataclasses.replace(sc, gnss_lever_m=(0.8, -1.2, 1.6), fix_schedule=[(0.0, 15.0, 1)], heading_offset0_rad=0.0)
    return simulate(sc, seed=9)


def test_start_position_from_averaged_best_fixes_through_the_lever_arm(sim):
    inp = nav_inputs(parse_files(_files(sim)))
    d = enu_offset_m(sim.imu.lat_rad[0], sim.imu.lon_rad[0], sim.imu.h_m[0], *inp.pos0)
    # RTK fixes: σ 2 cm horizontal, 3 cm vertical (mostly correlated over 300 s: averaging barely helps)
    assert np.hypot(d[0], d[1]) < 0.06 and abs(d[2]) < 0.1, d


def test_manifest_position_stays_authoritative(sim):
    f = _files(sim, keep_initial=True)
    m = json.loads(f["manifest.json"])
    inp = nav_inputs(parse_files(f))
    assert np.degrees(inp.pos0[0]) == m["initial"]["lat_deg"] and inp.pos0[2] == m["initial"]["h_m"]
