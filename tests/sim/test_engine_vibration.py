"""The idling engine's vibration (``engine_vibration``): on a vehicle at rest with otherwise perfect
sensors, the increments carry the specified lines at their frequencies and amplitudes and the
broadband noise, and nothing else: the shake moves the vehicle nowhere (the mean specific force is
gravity's and the mean rate the Earth's, to the noise's own σ of the mean)."""

import numpy as np
import pytest

from ldvsurvey.nav.earth import OMEGA_IE
from ldvsurvey.sim.effects import Effects, EngineVibration
from ldvsurvey.sim.motion import Static
from ldvsurvey.sim.road import Ramps, Road
from ldvsurvey.sim.scenario import Scenario, simulate

LAT = 0.7
SPEC = EngineVibration(freq_hz=(24.0, 37.0), accel_mps2=(1.5, 0.8), rate_dps=(1.2, 0.6), axis_share=(0.6, 0.5, 1.0))
DEG = np.pi / 180


def _pair(spec):
    road = Road(LAT, 2.0, 100.0, 100.0, Ramps(0.3))
    quiet = dict(gyro_bias_dph=0.0, accel_bias_ug=0.0, gyro_arw_dprh=0.0, accel_vrw_ug_rthz=0.0)
    out = []
    for eff in (Effects.ideal(), Effects(engine_vibration=spec, seed=2)):
        sc = Scenario(name="idle", road=road, segments=[Static(60.0)], static_s=60.0, effects=eff, **quiet)
        out.append(simulate(sc, seed=1))
    return out


def test_lines_at_their_frequency_and_amplitude():
    still, shaken = _pair(SPEC)
    dt = 0.01
    a = (shaken.dvel_mps - still.dvel_mps) / dt  # what the vibration added, m/s² per sample (mean over dt)
    w = (shaken.dtheta_rad - still.dtheta_rad) / dt
    n = len(a)
    freq = np.fft.rfftfreq(n, dt)
    for x, amps, unit in ((a, SPEC.accel_mps2, 1.0), (w, SPEC.rate_dps, DEG)):
        z = np.abs(np.fft.rfft(x[:, 2])) * 2 / n
        for f, amp in zip(SPEC.freq_hz, amps):
            k = int(np.argmin(np.abs(freq - f)))
            # an increment is the line's mean over dt: its amplitude times sinc(f dt)
            seen = z[k - 2 : k + 3].max() / np.sinc(f * dt)
            assert seen == pytest.approx(amp * unit, rel=0.05)
    # broadband: what is left between the lines, per sample (z axis, share 1)
    resid = np.std(a[:, 2]) ** 2 - sum(
        (amp * np.sinc(f * dt)) ** 2 / 2 for f, amp in zip(SPEC.freq_hz, SPEC.accel_mps2)
    )
    assert np.sqrt(resid) == pytest.approx(SPEC.accel_noise_mps2, rel=0.1)


def test_the_shake_moves_the_vehicle_nowhere():
    still, shaken = _pair(SPEC)
    dt, n = 0.01, len(still.dvel_mps)
    d_v = (shaken.dvel_mps - still.dvel_mps).sum(axis=0)  # m/s over 60 s
    d_th = (shaken.dtheta_rad - still.dtheta_rad).sum(axis=0)
    share = np.asarray(SPEC.axis_share)
    # the sinusoids integrate to a bounded ripple; the broadband noise to its random walk σ √n dt
    bound_v = sum(2 * a / (2 * np.pi * f) for f, a in zip(SPEC.freq_hz, SPEC.accel_mps2)) * share
    bound_th = sum(2 * w * DEG / (2 * np.pi * f) for f, w in zip(SPEC.freq_hz, SPEC.rate_dps)) * share
    assert np.all(np.abs(d_v) <= bound_v + 4 * SPEC.accel_noise_mps2 * dt * np.sqrt(n) * share)
    assert np.all(np.abs(d_th) <= bound_th + 4 * SPEC.rate_noise_dps * DEG * dt * np.sqrt(n) * share)
    # the unshaken sensor at rest: the Earth rate, independent of the effect
    w_mean = still.dtheta_rad.sum(axis=0) / (n * dt)
    assert np.linalg.norm(w_mean) == pytest.approx(OMEGA_IE, rel=1e-6)
