"""Vehicle motion on a road: a timeline of segments (static, drive, turn in place, turntable).

Evaluates the truth at any times with analytic rates and accelerations: position,
velocity v_n and its derivative, the travel-frame attitude C_t^n and rate ω_nt^t.
The travel frame t is the frame the vehicle moves along (its forward axis is the
velocity direction): the LDV frame in the simulator. Segment boundaries fall on the
sampling grid so that quadrature within one sampling interval never straddles a kink.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ldvsurvey.nav.attitude import c_bn_from_euler
from ldvsurvey.sim.road import Road, smooth_step, smooth_step_integral


@dataclass
class Static:
    """Stand still for ``duration_s`` (s)."""

    duration_s: float


@dataclass
class Drive:
    """Drive along the road to arc length ``s_to_m`` at ``speed_mps`` with smooth ramps."""

    s_to_m: float
    speed_mps: float
    ramp_s: float = 20.0


@dataclass
class TurnInPlace:
    """Rotate the heading by ``dpsi_rad`` while standing (a turnaround is π)."""

    duration_s: float
    dpsi_rad: float


def _grid(x: float, dt: float) -> float:
    """``x`` (s) rounded to whole steps ``dt`` (s), at least one step."""
    return max(dt, round(x / dt) * dt)


def euler_rate_to_body(pitch, roll, yaw_cw, pitch_rate, roll_rate, yaw_cw_rate):
    """ω of a frame in its own axes (rad/s) from the product's Euler angles and their rates (yaw clockwise).

    With y = −ψ: ω = (R_x(θ) R_y(γ))ᵀ [0, 0, ẏ] + R_y(γ)ᵀ [θ̇, 0, 0] + [0, γ̇, 0], where
    R_x(θ)ᵀ e_z = [0, sθ, cθ] and R_y(γ)ᵀ [a, b, c] = [cγ a − sγ c, b, sγ a + cγ c]. Used for the
    travel frame here and for the vehicle body in ``body.py``.
    """
    yd = -yaw_cw_rate
    cg, sg, ct, st = np.cos(roll), np.sin(roll), np.cos(pitch), np.sin(pitch)
    wz = np.stack([-sg * ct * yd, st * yd, cg * ct * yd], axis=-1)
    wx = np.stack([cg * pitch_rate, np.zeros_like(yd), sg * pitch_rate], axis=-1)
    wy = np.stack([np.zeros_like(yd), roll_rate, np.zeros_like(yd)], axis=-1)
    return wz + wx + wy


class Motion:
    """A vehicle timeline on a road. Times are seconds of day (the bundle clock)."""

    def __init__(
        self,
        road: Road,
        segments: list,
        t0_s: float,
        *,
        dt_s: float = 0.01,
        s0_m: float = 0.0,
        heading_offset0_rad: float = 0.0,
        current_n_mps=None,
        current_from_s: float = 0.0,
        current_ramp_s: float = 30.0,
    ):
        """Lay the segments out in time from ``t0_s`` on the sampling grid.

        Parameters
        ----------
        road : Road
            The road driven (for a vessel: the track through the water).
        segments : list of Static, Drive, TurnInPlace
            The timeline, in order.
        t0_s : float
            Start of the first segment (s of day).
        dt_s : float
            Sampling interval (s); segment boundaries fall on its grid.
        s0_m : float
            Arc length of the road where the vehicle starts (m).
        heading_offset0_rad : float
            Initial heading relative to the road (rad; π faces backwards).
        current_n_mps : (3,) array, optional
            A water current (ENU, m/s) the vehicle (vessel) drifts with from ``t0_s + current_from_s``
            on, smoothly over ``current_ramp_s`` (s); the LDV frame moves along the road relative to
            the water.
        current_from_s, current_ramp_s : float
            Start (s after ``t0_s``) and ramp length (s) of the current.

        Raises
        ------
        ValueError
            A turn in place on a graded or banked road, or a drive the vehicle does not face.
        """
        self.road = road
        self.t0_s = t0_s
        self.current = None if current_n_mps is None else np.asarray(current_n_mps, float)
        self.current_t0 = t0_s + current_from_s
        self.current_ramp = current_ramp_s
        self.pieces = []  # (t_start, t_end, kind, params)
        t, s, off = t0_s, s0_m, heading_offset0_rad
        for seg in segments:
            if isinstance(seg, Static):
                d = _grid(seg.duration_s, dt_s)
                self.pieces.append((t, t + d, "static", dict(s=s, off=off)))
                t += d
            elif isinstance(seg, TurnInPlace):
                th, _, _ = road.grade.eval(np.array([s]))
                if abs(th[0]) > 1e-9 or abs(road.bank.eval(np.array([s]))[0][0]) > 1e-9:
                    raise ValueError(f"turn in place at s={s:.1f} m needs a flat road there")
                d = _grid(seg.duration_s, dt_s)
                self.pieces.append((t, t + d, "turn", dict(s=s, off=off, dpsi=seg.dpsi_rad, T=d)))
                t += d
                off += seg.dpsi_rad
            elif isinstance(seg, Drive):
                dist = seg.s_to_m - s
                sign = 1.0 if dist > 0 else -1.0
                facing = 1.0 if np.cos(off) > 0 else -1.0
                if abs(abs(np.cos(off)) - 1) > 1e-9 or facing != sign:
                    raise ValueError("the vehicle must face the direction it drives (turn around first)")
                ta = _grid(seg.ramp_s, dt_s)
                tc = _grid(abs(dist) / seg.speed_mps - ta, dt_s)
                v = abs(dist) / (ta + tc)
                self.pieces.append((t, t + 2 * ta + tc, "drive", dict(s=s, off=off, sign=sign, V=v, Ta=ta, Tc=tc)))
                t += 2 * ta + tc
                s = seg.s_to_m
            else:
                raise TypeError(seg)
        self.t_end_s = t

    def _kinematics(self, t):
        """s, ṡ, s̈, heading offset, its rate and acceleration at times t."""
        n = len(t)
        s, sd, sdd = np.zeros(n), np.zeros(n), np.zeros(n)
        off, offd, offdd = np.zeros(n), np.zeros(n), np.zeros(n)
        for i, (ta, tb, kind, p) in enumerate(self.pieces):
            last = i == len(self.pieces) - 1
            m = (t >= ta) & ((t < tb) | (last & (t <= tb + 1e-9)))
            if not m.any():
                continue
            tau = t[m] - ta
            s[m], off[m] = p["s"], p["off"]
            if kind == "turn":
                S, S1, S2 = smooth_step(tau / p["T"])
                off[m] += p["dpsi"] * S
                offd[m] = p["dpsi"] * S1 / p["T"]
                offdd[m] = p["dpsi"] * S2 / p["T"] ** 2
            elif kind == "drive":
                V, Ta, Tc, sg = p["V"], p["Ta"], p["Tc"], p["sign"]
                u1, u2 = tau / Ta, (tau - Ta - Tc) / Ta
                a1, b1, c1 = smooth_step(u1)
                a2, b2, c2 = smooth_step(u2)
                s[m] += sg * V * Ta * (smooth_step_integral(u1) - smooth_step_integral(u2))
                sd[m] = sg * V * (a1 - a2)
                sdd[m] = sg * V / Ta * (b1 - b2)
        if np.any(t < self.t0_s - 1e-9) or np.any(t > self.t_end_s + 1e-9):
            raise ValueError("time outside the simulated timeline")
        return s, sd, sdd, off, offd, offdd

    def _drift(self, t):
        """Latitude and longitude (rad) added by the current: ∫ c_N/(R_M+h) dt, ∫ c_E/((R_N+h) cos L) dt
        along the actual latitude, tabulated at 0.5 s and spline-interpolated (consistent with v_n)."""
        if not hasattr(self, "_drift_splines"):
            from scipy.interpolate import CubicSpline

            from ldvsurvey.nav.earth import radii

            tt = np.arange(self.t0_s - 1.0, self.t_end_s + 1.5, 0.5)
            s, *_ = self._kinematics(np.clip(tt, self.t0_s, self.t_end_s))
            lat_r, _, h = self.road.geodetic(s)
            frac = smooth_step((tt - self.current_t0) / self.current_ramp)[0]
            dlat = np.zeros_like(tt)
            for _ in range(3):  # the radii depend (weakly) on the drifted latitude
                rm, rn = radii(lat_r + dlat)
                fn = frac * self.current[1] / (rm + h)
                dlat = np.concatenate([[0.0], np.cumsum(0.5 * (fn[1:] + fn[:-1]) * 0.5)])
            fe = frac * self.current[0] / ((rn + h) * np.cos(lat_r + dlat))
            dlon = np.concatenate([[0.0], np.cumsum(0.5 * (fe[1:] + fe[:-1]) * 0.5)])
            self._drift_splines = (CubicSpline(tt, dlat), CubicSpline(tt, dlon))
        a, b = self._drift_splines
        return a(t), b(t)

    def truth(self, t_s):
        """Truth at times ``t_s`` (s).

        Returns
        -------
        dict with lat_rad, lon_rad, h_m, v_n (N,3) m/s, a_n (N,3) = dv_n/dt m/s², c_tn (N,3,3),
        w_nt_t (N,3) rad/s, s_m, speed_mps, pitch_t, roll_t, heading_t (rad, travel frame).
        """
        t = np.atleast_1d(np.asarray(t_s, dtype=float))
        s, sd, sdd, off, offd, offdd = self._kinematics(t)
        road = self.road
        lat, lon, h = road.geodetic(s)
        tan, dtan = road.tangent(s)
        v_n = sd[:, None] * tan
        a_n = sdd[:, None] * tan + (sd**2)[:, None] * dtan
        psi, dpsi, _ = road.heading.eval(s)
        th_r, dth_r, _ = road.grade.eval(s)
        ga_r, dga_r, _ = road.bank.eval(s)
        co, so = np.cos(off), np.sin(off)
        heading = psi + off
        pitch = co * th_r
        roll = co * ga_r
        heading_rate = dpsi * sd + offd
        pitch_rate = co * dth_r * sd - so * offd * th_r
        roll_rate = co * dga_r * sd - so * offd * ga_r
        if self.current is not None:  # drift with the water
            u = (t - self.current_t0) / self.current_ramp
            frac, rate, _ = smooth_step(u)
            dlat, dlon = self._drift(t)
            lat = lat + dlat
            lon = lon + dlon
            v_n = v_n + frac[:, None] * self.current
            a_n = a_n + (rate / self.current_ramp)[:, None] * self.current
        c_tn = c_bn_from_euler(pitch, roll, heading)
        w_nt_t = euler_rate_to_body(pitch, roll, heading, pitch_rate, roll_rate, heading_rate)
        return dict(
            t_s=t,
            lat_rad=lat,
            lon_rad=lon,
            h_m=h,
            v_n=v_n,
            a_n=a_n,
            c_tn=c_tn,
            w_nt_t=w_nt_t,
            s_m=s,
            speed_mps=np.abs(sd),
            pitch_t=pitch,
            roll_t=roll,
            heading_t=np.mod(heading, 2 * np.pi),
        )


@dataclass
class Turntable:
    """4-position rotate-stop scheme 0°, 180°, 270°, 90° (back and forth, no net turn).

    ``dwell_s`` at each stop, rotations at ``rate_dps`` mean rate with smooth ramps, from ``t0_s``.
    """

    t0_s: float
    dwell_s: float = 30.0
    rate_dps: float = 20.0
    dt_s: float = 0.01

    def angle(self, t_s):
        """Encoder angle η (rad, unwrapped), its rate (rad/s) at times t."""
        t = np.asarray(t_s, dtype=float)
        deltas = np.radians([180.0, 90.0, -180.0, -90.0])
        durs = [_grid(abs(np.degrees(d)) / self.rate_dps, self.dt_s) for d in deltas]
        dwell = _grid(self.dwell_s, self.dt_s)
        period = 4 * dwell + sum(durs)
        tau = np.maximum(t - self.t0_s, 0.0)
        k = np.floor(tau / period + 1e-12)
        r = tau - k * period
        eta = np.zeros_like(t)
        rate = np.zeros_like(t)
        start = 0.0
        for d, T in zip(deltas, durs):
            start += dwell
            S, S1, _ = smooth_step((r - start) / T)
            eta += d * S
            rate += d * S1 / T
            start += T
        return eta, rate
