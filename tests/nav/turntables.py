"""Turntable indexing schemes for tests, beside the simulator's own 0/180/270/90 scheme.

A scheme is any object with ``angle(t) -> (η rad, η̇ rad/s)``; :func:`simulate_with_table` runs the
product's simulator with it in place of the built-in one, and :func:`quantise_encoder` makes the
written encoder angle step by whole counts with ±1 count of jitter (the IMU itself turned smoothly).
"""

from __future__ import annotations

import contextlib
import dataclasses

import numpy as np

from ldvsurvey.sim import scenario as scenario_mod
from ldvsurvey.sim.road import smooth_step, smooth_step_integral


class Stops:
    """Stops at the (unwrapped) angles ``angles_deg`` with dwell times ``dwell_s`` (one per stop),
    smooth moves at ``rate_dps`` mean rate between them, starting at ``t_start_s``."""

    def __init__(self, t_start_s, angles_deg, dwell_s, rate_dps=20.0):
        self.moves = []  # (t0, duration, delta rad)
        dw = np.broadcast_to(np.asarray(dwell_s, float), (len(angles_deg),))
        t = t_start_s + dw[0]
        for a, b, d in zip(angles_deg[:-1], angles_deg[1:], dw[1:]):
            T = abs(b - a) / rate_dps
            self.moves.append((t, T, np.radians(b - a)))
            t += T + d
        self.eta0 = np.radians(angles_deg[0])
        self.t_end_s = t

    def angle(self, t_s):
        t = np.asarray(t_s, float)
        eta = np.full_like(t, self.eta0)
        rate = np.zeros_like(t)
        for t0, T, d in self.moves:
            s, s1, _ = smooth_step((t - t0) / T)
            eta += d * s
            rate += d * s1 / T
        return eta, rate


class Continuous:
    """Continuous rotation at ``rate_dps`` from ``t_start_s`` (a smooth ramp of ``ramp_s``)."""

    def __init__(self, t_start_s, rate_dps, ramp_s=5.0, eta0_deg=0.0):
        self.t0, self.rate, self.ramp, self.eta0 = t_start_s, np.radians(rate_dps), ramp_s, np.radians(eta0_deg)

    def angle(self, t_s):
        u = (np.asarray(t_s, float) - self.t0) / self.ramp
        return self.eta0 + self.rate * self.ramp * smooth_step_integral(u), self.rate * smooth_step(u)[0]


@contextlib.contextmanager
def _table(table):
    saved = scenario_mod.Turntable
    scenario_mod.Turntable = lambda *a, **k: table
    try:
        yield
    finally:
        scenario_mod.Turntable = saved


def simulate_with_table(sc, table, seed=1):
    """The product's simulation of ``sc`` (made rotating) with the turntable ``table``."""
    sc = dataclasses.replace(sc, rotating=True)
    with _table(table):
        return scenario_mod.simulate(sc, seed=seed)


def quantise_encoder(sim, lsb_deg=0.01, seed=0):
    """Written encoder angle in whole counts of ``lsb_deg`` with ±1 count of random jitter."""
    rng = np.random.default_rng(seed)
    lsb = np.radians(lsb_deg)
    eta = sim.imu.eta_rad
    sim.imu.eta_rad = (np.round(eta / lsb) + rng.integers(-1, 2, len(eta))) * lsb
    return sim
