"""The effects real drives have, one switch each, for the simulator's ``realistic`` scenarios.

An :class:`Effects` holds one parameter object per effect; ``None`` switches the effect off.
``Effects.ideal()`` is everything off (the ideal scenarios, which the identity tests rely on);
``Effects.realistic(seed)`` switches every effect on at magnitudes drawn from the ranges below;
``Effects.realistic(seed, gnss=False)`` or ``Effects.only("gnss", seed)`` give one effect alone.
:func:`effect_names` lists the switches (for accuracy matrices).

Effects, their models and realistic magnitudes
----------------------------------------------
``ldv_dropouts`` (:class:`LdvDropouts`, model in ``ldvfaults.py``)
    Bursts of samples with quality below ``min_quality``: Poisson arrivals, ~1 per minute on a
    road (×2–3 on rough ground, ``rate_per_min``), durations log-uniform 0.1–5 s. The velocity
    values in a burst are garbage, never NaN: zeros, a stale repeat of the last good value,
    or wild spikes (±2–30 m/s). Occasional single spikes of 0.3–5 m/s keep a *good* quality
    (~1 per 5 min). Also a burst or two while the vehicle stands.
``body_attitude`` (:class:`BodyAttitude`, model in ``body.py``)
    The vehicle body (IMU and LDV fixed to it) is not aligned with its travel direction:
    constant stance pitch and crab (yaw) of a few tenths of a degree; squat/dive of
    1–3°/g of longitudinal acceleration (nose up when accelerating); roll outward in curves,
    1–3°/g of lateral acceleration; bounce at 1–2 Hz of a few hundredths of a degree,
    growing with speed. The LDV measures along its own axis, so the travel direction seen
    in body/LDV axes changes with the driving.
``gravity_field`` (:class:`GravityFieldSpec`, model in ``pointmass.py``)
    One potential of buried point masses (regional: deep and far, giving 5–30″ of DOV over
    the area; local: 2–8 km deep, Δg of ±10–40 mGal, gradients up to ~3 mGal/km), from which
    Δg, ξ and η all follow; the IMU senses g^n = [−γη, −γξ, −(γ+Δg)].
``imu_errors`` (:class:`ImuErrorSpec`, model in ``imuerrors.py``)
    Scale factors 10–300 ppm per axis, non-orthogonality of tens of µrad, in-run bias
    instability as first-order Gauss–Markov (σ ~30 % of the manifest's bias, correlation times
    10–60 min), on top of the turn-on bias (the constant bias of each run, as in the ideal case).
``imu_timing`` (:class:`ImuTiming`)
    Dropped IMU rows (~1 event per 5 min, 1–5 consecutive rows; their increments are lost) and
    time-tag jitter (σ 20–200 µs, rare ms-level excursions; increments remain those of the true
    interval).
``turntable`` (:class:`TurntableSpec`, model in ``turntable.py``; rotating IMUs only)
    Indexing scheme (two-position 0/180°, four-position 0/90/180/270° in sequence, the paper's
    0/180/270/90°, continuous rotation at 1–10°/s), unequal dwell times (±30 %), encoder
    quantisation (LSB 360°/2¹⁶) with ±1 LSB jitter of the reading.
``gnss`` (:class:`GnssEffects`, model in ``gnsseffects.py``)
    Outages (10–120 s, ~3 per hour), quality changes (4 → 5/2/1 for 30–300 s), multipath jumps
    of 0.1–0.5 m for 5–60 s in fixed solutions, and a real antenna lever arm ([0.3, 0.8, 1.6] m
    RFU) applied through the true body attitude.
``engine_vibration`` (:class:`EngineVibration`, model in ``imuerrors.py``)
    An engine running through the whole log, idling at the stops: sinusoids at its firing frequency
    and a second line (20–40 Hz) of 0.5–3 m/s² and 0.5–2 °/s per axis, plus broadband noise of a few
    tenths of m/s² and °/s per sample. It shakes the sensor without moving the vehicle: each
    increment is the exact integral of the sinusoids over its interval, so they leave no net
    velocity or angle. Off in ``realistic()`` unless asked for (it would change every realistic
    figure measured without it).
``moving_start``
    The log starts on the move (no static period; ``initial.static_s`` = 0). Off in
    ``realistic()`` unless asked for: it removes the alignment the other effects are measured with.
"""

from __future__ import annotations

from dataclasses import dataclass, fields, replace

import numpy as np

from ldvsurvey.units import RAD_PER_DEG as DEG  # noqa: E402  (rad per degree)


@dataclass(frozen=True)
class LdvDropouts:
    rate_per_min: float = 1.0  #: bursts per minute of driving
    burst_min_s: float = 0.1
    burst_max_s: float = 5.0
    static_bursts: int = 2  #: bursts placed inside the initial static period
    spikes_per_min: float = 0.2  #: isolated spikes flagged good
    spike_min_mps: float = 0.3
    spike_max_mps: float = 5.0


@dataclass(frozen=True)
class BodyAttitude:
    stance_pitch_rad: float = 0.3 * DEG  #: body pitch over its path at rest (nose up +)
    crab_rad: float = -0.2 * DEG  #: body yaw over its path (clockwise +)
    squat_rad_per_g: float = 2.0 * DEG  #: nose-up pitch per g of forward acceleration
    roll_rad_per_g: float = 2.0 * DEG  #: outward roll per g of lateral acceleration
    bounce_rad: float = 0.03 * DEG  #: bounce amplitude (pitch) at bounce_ref_mps
    bounce_hz: tuple = (1.3, 1.8)  #: pitch and roll bounce frequencies
    bounce_ref_mps: float = 15.0


@dataclass(frozen=True)
class GravityFieldSpec:
    seed: int = 1
    dov_min_arcsec: float = 5.0  #: the regional DOV magnitude is drawn in [min, max]
    dov_max_arcsec: float = 30.0
    local_dg_mgal: float = 20.0  #: peak Δg scale of local masses
    max_gradient_mgal_per_km: float = 3.0
    n_local: int = 5
    grid_step_arcmin: float = 0.5  #: step of the .gdf grids written beside the bundle


@dataclass(frozen=True)
class ImuErrorSpec:
    gyro_scale_ppm: tuple = (120.0, -60.0, 200.0)
    accel_scale_ppm: tuple = (80.0, -150.0, 40.0)
    gyro_nonorth_urad: tuple = (30.0, -20.0, 15.0, 40.0, -25.0, 10.0)  #: off-diagonal terms, row-major
    accel_nonorth_urad: tuple = (-35.0, 20.0, 25.0, -10.0, 45.0, -15.0)
    gyro_bi_frac: float = 0.3  #: Gauss–Markov σ as a share of the manifest's gyro bias
    accel_bi_frac: float = 0.3
    gyro_tau_s: float = 1800.0
    accel_tau_s: float = 900.0


@dataclass(frozen=True)
class ImuTiming:
    drops_per_min: float = 0.2
    drop_max_rows: int = 5
    jitter_s: float = 5e-5  #: σ of the time-tag jitter
    big_jitter_share: float = 1e-4  #: share of rows with a jitter of up to 2 ms


@dataclass(frozen=True)
class TurntableSpec:
    scheme: str = "4pos-seq"  #: "2pos", "4pos-seq", "4pos-paper", "continuous"
    dwell_s: float = 30.0
    dwell_spread: float = 0.3  #: dwell times uniform in dwell_s·(1 ± spread)
    rate_dps: float = 20.0  #: indexing rate, or the continuous rotation rate
    lsb_deg: float = 360.0 / 2**16
    jitter_lsb: int = 1


SCHEMES = ("2pos", "4pos-seq", "4pos-paper", "continuous")


@dataclass(frozen=True)
class GnssEffects:
    lever_arm_m: tuple = (0.3, 0.8, 1.6)
    outages_per_h: float = 3.0
    outage_s: tuple = (10.0, 120.0)
    degraded_per_h: float = 4.0
    degraded_s: tuple = (30.0, 300.0)
    multipath_per_h: float = 6.0
    multipath_m: tuple = (0.1, 0.5)
    multipath_s: tuple = (5.0, 60.0)


@dataclass(frozen=True)
class EngineVibration:
    freq_hz: tuple = (24.0, 37.0)  #: the lines' frequencies (Hz): firing frequency at idle and a second one
    accel_mps2: tuple = (1.5, 0.8)  #: amplitude of each line (m/s²) on the strongest axis
    rate_dps: tuple = (1.2, 0.6)  #: amplitude of each line (°/s) on the strongest axis
    axis_share: tuple = (0.6, 0.5, 1.0)  #: the amplitude's share on x, y, z
    accel_noise_mps2: float = 0.2  #: broadband σ per sample (m/s²)
    rate_noise_dps: float = 0.2  #: broadband σ per sample (°/s)


@dataclass(frozen=True)
class MovingStart:
    pass


@dataclass(frozen=True)
class Effects:
    """One switch per effect (None = off); see the module docstring for the models."""

    ldv_dropouts: LdvDropouts | None = None
    body_attitude: BodyAttitude | None = None
    gravity_field: GravityFieldSpec | None = None
    imu_errors: ImuErrorSpec | None = None
    imu_timing: ImuTiming | None = None
    turntable: TurntableSpec | None = None
    gnss: GnssEffects | None = None
    engine_vibration: EngineVibration | None = None
    moving_start: MovingStart | None = None
    seed: int = 1  #: seed of the effects' own random draws (independent of the sensor noise)

    @classmethod
    def ideal(cls) -> Effects:
        """Every effect off (the ideal simulation)."""
        return cls()

    @classmethod
    def realistic(cls, seed: int = 1, **overrides) -> Effects:
        """Every effect on (except ``engine_vibration`` and ``moving_start``) at magnitudes drawn from ``seed``.

        ``overrides``: effect name → False/None (off), True (on, drawn), or a parameter object.
        """
        rng = np.random.default_rng([seed, 13])
        u = rng.uniform
        sgn = lambda: rng.choice([-1.0, 1.0])  # noqa: E731
        drawn = dict(
            ldv_dropouts=LdvDropouts(rate_per_min=float(u(0.8, 1.5)), spikes_per_min=float(u(0.1, 0.3))),
            body_attitude=BodyAttitude(
                stance_pitch_rad=float(sgn() * u(0.15, 0.45) * DEG),
                crab_rad=float(sgn() * u(0.1, 0.4) * DEG),
                squat_rad_per_g=float(u(1.0, 3.0) * DEG),
                roll_rad_per_g=float(u(1.0, 3.0) * DEG),
                bounce_rad=float(u(0.02, 0.05) * DEG),
                bounce_hz=(float(u(1.0, 1.6)), float(u(1.4, 2.0))),
            ),
            gravity_field=GravityFieldSpec(seed=seed),
            imu_errors=ImuErrorSpec(
                gyro_scale_ppm=tuple(float(x) for x in rng.choice([-1, 1], 3) * u(10, 300, 3)),
                accel_scale_ppm=tuple(float(x) for x in rng.choice([-1, 1], 3) * u(10, 300, 3)),
                gyro_nonorth_urad=tuple(float(x) for x in u(-50, 50, 6)),
                accel_nonorth_urad=tuple(float(x) for x in u(-50, 50, 6)),
                gyro_tau_s=float(u(600, 3600)),
                accel_tau_s=float(u(600, 3600)),
            ),
            imu_timing=ImuTiming(),
            turntable=TurntableSpec(),
            gnss=GnssEffects(),
            engine_vibration=None,
            moving_start=None,
        )
        for name, val in overrides.items():
            if name not in drawn:
                raise KeyError(f"unknown effect '{name}' (known: {', '.join(effect_names())})")
            if val is True:
                drawn[name] = drawn[name] if drawn[name] is not None else _default(name)
            elif val is False or val is None:
                drawn[name] = None
            else:
                drawn[name] = val
        return cls(seed=seed, **drawn)

    @classmethod
    def only(cls, name: str, seed: int = 1) -> Effects:
        """One effect alone (at its realistic draw), everything else off."""
        full = cls.realistic(seed, **{name: True})
        return cls(seed=seed, **{name: getattr(full, name)})

    def with_(self, **overrides) -> Effects:
        """A copy with some switches changed (same meaning as in ``realistic``)."""
        kw = {}
        for name, val in overrides.items():
            if name not in effect_names():
                raise KeyError(f"unknown effect '{name}' (known: {', '.join(effect_names())})")
            kw[name] = _default(name) if val is True else None if val in (False, None) else val
        return replace(self, **kw)

    def on(self) -> list[str]:
        """Names of the effects switched on."""
        return [n for n in effect_names() if getattr(self, n) is not None]

    def describe(self) -> dict:
        """A JSON-able description (for truth.json)."""
        from dataclasses import asdict

        return {n: (None if getattr(self, n) is None else asdict(getattr(self, n))) for n in effect_names()}


def _default(name: str):
    return {
        "ldv_dropouts": LdvDropouts,
        "body_attitude": BodyAttitude,
        "gravity_field": GravityFieldSpec,
        "imu_errors": ImuErrorSpec,
        "imu_timing": ImuTiming,
        "turntable": TurntableSpec,
        "gnss": GnssEffects,
        "engine_vibration": EngineVibration,
        "moving_start": MovingStart,
    }[name]()


def effect_names() -> tuple[str, ...]:
    """The effect switches, in a fixed order (for robustness matrices)."""
    return tuple(f.name for f in fields(Effects) if f.name != "seed")


__all__ = [
    "Effects",
    "effect_names",
    "SCHEMES",
    "LdvDropouts",
    "BodyAttitude",
    "GravityFieldSpec",
    "ImuErrorSpec",
    "ImuTiming",
    "TurntableSpec",
    "GnssEffects",
    "EngineVibration",
    "MovingStart",
]
