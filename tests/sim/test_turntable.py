"""Turntable schemes from the written encoder column: stop angles and order, unequal dwells,
quantisation with ±1 LSB jitter, continuous rotation rate; the gyro sees the same rotation."""

import io
import json

import numpy as np
import pytest

from ldvsurvey.nav.earth import OMEGA_IE
from ldvsurvey.sim import catalog
from ldvsurvey.sim.effects import Effects, TurntableSpec
from ldvsurvey.sim.motion import Motion, Static
from ldvsurvey.sim.road import Ramps, Road
from ldvsurvey.sim.scenario import Scenario, bundle_files, simulate, truth_files

LAT = 0.5
LSB = 360.0 / 2**16


def _sim(spec, seconds=420.0):
    road = Road(LAT, 2.0, 50.0, 100.0, Ramps(0.0))
    sc = Scenario(
        name="table",
        road=road,
        segments=[Static(seconds)],
        static_s=seconds,
        rotating=True,
        gyro_bias_dph=0.0,
        accel_bias_ug=0.0,
        gyro_arw_dprh=0.0,
        accel_vrw_ug_rthz=0.0,
        effects=Effects.ideal().with_(turntable=spec),
    )
    sim = simulate(sc, seed=4)
    data = np.loadtxt(io.BytesIO(bundle_files(sim)["imu.csv"]), delimiter=",", comments="#", skiprows=2)
    return sim, data


def _stops(t, deg, min_s=5.0):
    """(t_start, t_end, angle) of runs where the reading stays within 2 LSB."""
    out, a = [], 0
    for i in range(1, len(deg) + 1):
        if i == len(deg) or abs(((deg[i] - deg[a] + 180) % 360) - 180) > 2.5 * LSB:
            if t[i - 1] - t[a] >= min_s:
                out.append((t[a], t[i - 1], float(np.median(deg[a:i]))))
            a = i
    return out


@pytest.mark.parametrize(
    "scheme, cycle", [("2pos", [0, 180]), ("4pos-seq", [0, 90, 180, 270]), ("4pos-paper", [0, 180, 270, 90])]
)
def test_indexing_schemes(scheme, cycle):
    spec = TurntableSpec(scheme=scheme, dwell_s=30.0, dwell_spread=0.3, rate_dps=20.0)
    sim, data = _sim(spec)
    t, deg = data[:, 0], data[:, 7]
    # quantised to the LSB, and jittering by at most one count around the true angle
    np.testing.assert_allclose(deg / LSB, np.round(deg / LSB), atol=1e-6)
    true = np.mod(np.degrees(sim.imu.eta_rad), 360.0)
    err = (deg - true + 180.0) % 360.0 - 180.0
    assert np.abs(err).max() <= 1.5 * LSB + 1e-9
    assert (np.abs(err) > 0.5 * LSB).mean() == pytest.approx(0.5, abs=0.03)
    stops = _stops(t, deg)
    angles = [round(s[2] / 90.0) * 90 % 360 for s in stops]
    assert angles == [cycle[i % len(cycle)] for i in range(len(angles))] and len(angles) >= 8
    dwell = np.array([b - a for a, b, _ in stops[:-1]])
    assert dwell.min() >= 30.0 * 0.7 - 0.05 and dwell.max() <= 30.0 * 1.3 + 0.05 and dwell.std() > 1.0
    # the sensor z gyro (level base, α = β = 0) integrates the table rotation plus Ω sin L
    dth = sim.dtheta_rad[:, 2].sum()
    expected = sim.imu.eta_rad[-1] + OMEGA_IE * np.sin(LAT) * (sim.imu.t_s[-1] - sim.scenario.t0_s)
    assert dth == pytest.approx(expected, abs=1e-9)


def test_continuous_rotation():
    spec = TurntableSpec(scheme="continuous", rate_dps=6.0)
    sim, data = _sim(spec, seconds=120.0)
    t, deg = data[:, 0], data[:, 7]
    late = t > sim.scenario.t0_s + 10.0
    slope = np.polyfit(t[late], np.unwrap(np.radians(deg[late])), 1)[0]
    assert np.degrees(slope) == pytest.approx(6.0, rel=1e-5)
    meta = json.loads(truth_files(sim)["truth.json"])
    assert meta["turntable"]["scheme"] == "continuous"


def test_moving_start_has_no_static_period():
    sc = catalog.realistic_drive(seed=1, moving_start=True, minutes=8)
    assert sc.static_s == 0.0 and sc.lead_s > 0
    m = Motion(sc.road, sc.segments, sc.t0_s - sc.lead_s)
    assert m.truth([sc.t0_s])["speed_mps"][0] == pytest.approx(15.0, rel=0.01)  # cruising from the first row
    sc2 = catalog.realistic_drive(seed=1, minutes=8)
    assert sc2.static_s > 0 and sc2.effects.moving_start is None
