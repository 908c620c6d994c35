"""Turntable indexing schemes of rotating IMUs (the ``turntable`` effect).

Schemes (angles of the encoder η, a move between stops is a smooth step at ``rate_dps`` mean rate):

- ``2pos``: 0 → 180 → 0 …
- ``4pos-seq``: 0 → 90 → 180 → 270 → back to 0 (−270°) …, stops taken in sequence;
- ``4pos-paper``: 0 → 180 → 270 → 90 → 0 … (the rotating-IMU paper, no net turn);
- ``continuous``: rotation at ``rate_dps`` (1–10°/s realistic) after a smooth 5-s start.

Dwell times are unequal: each uniform in ``dwell_s (1 ± dwell_spread)``, aligned on the IMU grid.
The encoder reading written to ``imu.csv`` is quantised to ``lsb_deg`` (360°/2¹⁶) and jitters by
±``jitter_lsb`` counts (probabilities ¼, ½, ¼ of −1, 0, +1); the truth keeps the exact angle.
"""

from __future__ import annotations

import numpy as np

from ldvsurvey.sim.effects import TurntableSpec
from ldvsurvey.sim.road import smooth_step, smooth_step_integral

DELTAS = {"2pos": [180.0, -180.0], "4pos-seq": [90.0, 90.0, 90.0, -270.0], "4pos-paper": [180.0, 90.0, -180.0, -90.0]}


def _grid(x: float, dt: float) -> float:
    return max(dt, round(x / dt) * dt)


class ScheduledTurntable:
    """A turntable timeline: ``moves`` rows (t_start_s, duration_s, delta_rad); or continuous."""

    def __init__(self, spec: TurntableSpec, t0_s: float, t_end_s: float, dt_s: float, rng):
        self.spec = spec
        self.t0_s = t0_s
        self.continuous = spec.scheme == "continuous"
        self.moves = []
        if self.continuous:
            self.ramp_s = _grid(5.0, dt_s)
            self.start_s = t0_s + _grid(2.0, dt_s)
            return
        if spec.scheme not in DELTAS:
            raise ValueError(f"unknown turntable scheme '{spec.scheme}'")
        t, k = t0_s, 0
        deltas = DELTAS[spec.scheme]
        while t < t_end_s:
            t += _grid(spec.dwell_s * (1 + rng.uniform(-spec.dwell_spread, spec.dwell_spread)), dt_s)
            d = deltas[k % len(deltas)]
            dur = _grid(abs(d) / spec.rate_dps, dt_s)
            self.moves.append((t, dur, np.radians(d)))
            t += dur
            k += 1
        self.moves = np.array(self.moves).reshape(-1, 3)

    def angle(self, t_s):
        """True encoder angle η (rad, unwrapped) and its rate (rad/s)."""
        t = np.asarray(t_s, float)
        if self.continuous:
            w = np.radians(self.spec.rate_dps)
            u = (t - self.start_s) / self.ramp_s
            return w * self.ramp_s * smooth_step_integral(u), w * smooth_step(u)[0]
        # cumulative delta of the moves finished, plus the move in progress
        cum = np.concatenate([[0.0], np.cumsum(self.moves[:, 2])])
        i = np.searchsorted(self.moves[:, 0], t, side="right") - 1  # last move started
        started = i >= 0
        ii = np.maximum(i, 0)
        u = (t - self.moves[ii, 0]) / self.moves[ii, 1]
        s, s1, _ = smooth_step(u)
        eta = np.where(started, cum[ii] + self.moves[ii, 2] * s, 0.0)
        rate = np.where(started, self.moves[ii, 2] * s1 / self.moves[ii, 1], 0.0)
        return eta, rate

    def stops(self) -> list:
        """(t_from_s, t_to_s, angle_deg) of each stop (empty for continuous rotation)."""
        if self.continuous:
            return []
        out, t, ang = [], self.t0_s, 0.0
        for ts, dur, d in self.moves:
            out.append((float(t), float(ts), float(np.mod(ang, 360.0))))
            ang += np.degrees(d)
            t = ts + dur
        return out


def encoder_reading(eta_rad, spec: TurntableSpec, rng) -> np.ndarray:
    """The written encoder angle (deg in [0, 360)): quantised, with ±LSB jitter."""
    deg = np.degrees(np.asarray(eta_rad, float))
    q = np.round(deg / spec.lsb_deg)
    j = rng.choice([-1, 0, 0, 1], len(q)) * spec.jitter_lsb
    return np.mod((q + j) * spec.lsb_deg, 360.0)
