"""Gravity and damping rows of the robustness matrix (issue 13 §3), against the simulator's truth.

Shared by ``tests/robustness/test_matrix_gd.py`` and ``scripts/accuracy_table.py``. The pipelines
are called through their public entry (registry + ``run_pipeline``) only.

Gravity: ``catalog.realistic_gravity`` shortened to two repeated 5-km lines (~20 min), FIR 100 s,
SINS/GNSS comparison off (its own tests and the benchmark cover it); without the point-mass
effect its sinusoid field made five times steeper (``FIELD_GAIN``) so that the truth comparison
can fail. Figures:

* internal coincidence (summary ``total_mgal``) beside the pipeline's printed white-noise floor
  (summary ``noise_floor.total_mgal``: accelerometer and LDV white noise through the FIR);
* RMS against the truth: the simulator's Δg along the true track, filtered by the same zero-phase
  FIR, minus one constant over all lines (the vertical accelerometer bias is not observable), the
  method of ``tests/pipelines/test_gravity_robust.py``'s helper, with the FIR length a parameter.

Every pair of the gravity effects is run as well (``GRAVITY_PAIRS``, issue 29: interactions hide
from "alone" and, under the drift, from "all"), with the IMU timing of a sloppy logger
(``LOGGER_TIMING``); where the IMU timing is on, the very same simulated drive is also written by a
perfect logger (every row, true tags) and run, so that the logger's own cost is measured apart from
the other effects' draws (``coincidence_perfect_logger_mgal``).

Physical bounds (1-σ, a figure beyond 3 is a failure): the white floor for every effect but the
accelerometer's in-run errors; with those, the drift (Gauss–Markov σ the simulator states,
``accel_bi_frac`` × the manifest bias) is not separable from Δg while driving, so the bound is
√2·σ_drift (two lines differ by two independent drift states) plus the floor for the coincidence
and σ_drift plus the floor against the truth.

Damping: ``catalog.realistic_vessel`` with a 300-s mooring and 0.2 h straight run (2 m/s current).
Figures: velocity errors against the truth (the pipeline's error to GNSS plus the GNSS reference's
own error to the true velocity), position errors against GNSS (its σ of cm–m is negligible beside
the bounds). Bounds:

* conventional damping takes the water velocity as the ground velocity: it absorbs the current,
  so its velocity RMS is the current's magnitude (within 25 %);
* delayed-state: velocity-change measurements over the baseline B from LDV samples of σ_LDV at
  rate f, averaged over the period P, integrate to a random walk from the moored start:
  σ_v = σ_LDV/√(f·P) · √(2·T/B) over the T seconds under way; with the IMU's in-run bias drift
  (σ_a, σ_ω the simulator states) the Schuler-bounded amplitudes σ_a/ω_s and R·σ_ω are added in
  quadrature (velocity changes cannot see a slowly drifting bias); the position bound is σ_v·T.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from ldvsurvey.io.drivelog import parse_files
from ldvsurvey.nav.earth import MGAL
from ldvsurvey.nav.gravity import Lowpass
from ldvsurvey.pipelines.base import run_pipeline
from ldvsurvey.pipelines.registry import get
from ldvsurvey.sim import catalog
from ldvsurvey.sim.effects import Effects, ImuTiming
from ldvsurvey.sim.fields import SinusoidField
from ldvsurvey.sim.scenario import bundle_files, simulate

UG_MGAL = 9.80665e-6 / MGAL  #: one µg in mGal
GRAVITY_FIR_S = 100.0
GRAVITY_SEED = 3
GRAVITY_LINE_KM = 5.0
#: the survey's sinusoid field (≤ 3 mGal/km) varies by ~0.5 mGal RMS over the ~3.5 km a 5-km line
#: keeps after the FIR's end trims: a flat result would pass a 3-floor bound. Five times steeper
#: (≤ 15 mGal/km, ~2.8 mGal RMS), a flat or sign-flipped result fails.
FIELD_GAIN = 5.0
#: the effects that touch a fixed-IMU gravity drive (no turntable; a start on the move has no
#: alignment for the stop-and-go gravimetry drive)
GRAVITY_CONFIGS = ("ideal", "ldv_dropouts", "body_attitude", "gravity_field", "imu_errors", "imu_timing", "gnss", "all")
#: every pair of the gravity effects (issue 29: interactions, such as jittering time tags with lost
#: rows, were covered by neither "alone" nor "all")
GRAVITY_PAIRS = tuple(f"{a}+{b}" for i, a in enumerate(GRAVITY_CONFIGS[1:-1]) for b in GRAVITY_CONFIGS[1 + i + 1 : -1])
#: in the pairs, the IMU timing of a sloppy logger (issue 29): time tags jittering by σ 0.3 ms (rare
#: tags off by up to 2 ms) and a run of 1-5 lost rows a minute (the realistic draw: 50 µs, one in 5 min)
LOGGER_TIMING = ImuTiming(drops_per_min=1.0, drop_max_rows=5, jitter_s=3e-4)
DAMPING_SEED = 3
#: a vessel: no vehicle body attitude, no turntable, a moored start
DAMPING_CONFIGS = ("ideal", "ldv_dropouts", "gravity_field", "imu_errors", "imu_timing", "gnss", "all")


def _effects(config: str, seed: int, vessel: bool = False) -> Effects:
    if config == "ideal":
        return Effects.ideal()
    if "+" in config:  # a pair: both at their realistic draws (the IMU timing a sloppy logger's)
        full = Effects.realistic(seed, imu_timing=LOGGER_TIMING)
        return Effects(seed=seed, **{n: getattr(full, n) for n in config.split("+")})
    if config == "all":
        off = {"turntable": False, "moving_start": False}
        if vessel:
            off["body_attitude"] = False
        return Effects.realistic(seed, **off)
    return Effects.only(config, seed)


# --- gravity ---------------------------------------------------------------------------------------


def run_gravity_case(config: str, seed: int = GRAVITY_SEED) -> dict:
    sc = catalog.realistic_gravity(seed=seed, effects=_effects(config, seed), n_lines=2, line_km=GRAVITY_LINE_KM)
    if isinstance(sc.gravity_field, SinusoidField):  # no point-mass effect: the survey's sinusoids, steeper
        f = sc.gravity_field
        sc.gravity_field = replace(f, terms=[(a * FIELD_GAIN, lam, th, ph) for a, lam, th, ph in f.terms])
    sim = simulate(sc)
    out = {"sim": sim, "config": config}
    params = {"fir_length_s": GRAVITY_FIR_S, "gnss_comparison": False}
    try:
        out["gravity"] = run_pipeline(get("gravity"), [parse_files(bundle_files(sim))], params)
    except Exception as e:  # noqa: BLE001 - recorded as the case's failure
        out["gravity"] = e
    if "imu_keep" in sim.extras:  # IMU timing on: the very same drive from a perfect logger beside it
        out["gravity_perfect_logger"] = run_pipeline(get("gravity"), [parse_files(_perfect_logger(sim))], params)
    return out


def _perfect_logger(sim):
    """The bundle of ``sim`` written without the IMU timing effect (every row, true time tags): the
    same drive, sensor noise and other effects' draws, so that the timing's own cost is measured."""
    x = sim.extras
    saved = x["imu_keep"], x["imu_t_written"]
    x["imu_keep"], x["imu_t_written"] = np.ones(len(sim.imu.t_s), bool), sim.imu.t_s
    try:
        return bundle_files(sim)
    finally:
        x["imu_keep"], x["imu_t_written"] = saved


def gravity_truth_rms_mgal(sim, res, fir_s: float = GRAVITY_FIR_S) -> tuple[float, float]:
    """RMS over the lines of the result minus the equally filtered true Δg, after one constant;
    and the RMS of that true Δg itself about its mean (what a result of zeros would score)."""
    g = res.tables["gravity"]
    im = sim.imu
    mid = lambda a: 0.5 * (a[1:] + a[:-1])  # noqa: E731 - a local shorthand
    _, _, dg = sim.extras["gravity_field"](mid(im.lat_rad), mid(im.lon_rad), mid(im.h_m))
    tf = Lowpass(fir_s, 1.0 / float(np.median(np.diff(im.t_s)))).apply(dg) / MGAL
    on = np.array([x != "" for x in g["line"]]) & np.isfinite(g["dg_mgal"])
    truth = np.interp(g["t_s"][on], mid(im.t_s), tf)
    e = g["dg_mgal"][on] - truth
    e -= np.mean(e)
    return float(np.sqrt(np.mean(e**2))), float(np.std(truth))


def accel_drift_sigma_mgal(sim) -> float:
    """σ of the accelerometer's in-run bias drift the simulator draws (0 when off), in mGal."""
    spec = sim.scenario.effects.imu_errors
    return 0.0 if spec is None else float(spec.accel_bi_frac * sim.scenario.accel_bias_ug * UG_MGAL)


def gravity_figures(case: dict) -> dict | None:
    sim, r = case["sim"], case["gravity"]
    if isinstance(r, Exception):
        return None
    s = r.summary
    floor = float(s["noise_floor"]["total_mgal"])
    drift = accel_drift_sigma_mgal(sim)
    rms, signal = gravity_truth_rms_mgal(sim, r)
    return {
        "coincidence_mgal": float(s["total_mgal"]),
        "floor_mgal": floor,
        "drift_sigma_mgal": drift,
        "coincidence_bound_mgal": np.sqrt(2) * drift + floor,
        "truth_rms_mgal": rms,
        "signal_rms_mgal": signal,
        "truth_bound_mgal": drift + floor,
        "bridged_s": float(s["bridged_s"]),
        "warnings": list(s["warnings"]),
        # the stop tie (σ from the stops' own data): the largest |drift|/σ over the stops, the last
        # stop's against the first (the drift over the survey) and the χ² probability of "no drift"
        "drift_max_sigmas": s["drift_correction"].get("max_drift_sigmas"),
        "drift_end_sigmas": _end_sigmas(s["drift_correction"]),
        "no_drift_p_value": s["drift_correction"].get("no_drift_p_value"),
        "lost_imu_gaps": int(s["imu_gaps"].get("lost_gaps", 0)),
        "coincidence_perfect_logger_mgal": (
            float(case["gravity_perfect_logger"].summary["total_mgal"]) if "gravity_perfect_logger" in case else None
        ),
    }


def _end_sigmas(report) -> float | None:
    """|drift|/σ of the last stop (the drift over the survey, the first stop's level being kept)."""
    stops = report.get("stops") or []
    if len(stops) < 2 or not stops[-1].get("drift_sigma_mgal"):
        return None
    return abs(stops[-1]["drift_mgal"]) / stops[-1]["drift_sigma_mgal"]


# --- damping ---------------------------------------------------------------------------------------


def run_damping_case(config: str, seed: int = DAMPING_SEED) -> dict:
    sc = catalog.realistic_vessel(seed=seed, effects=_effects(config, seed, vessel=True), hours=0.2, mooring_s=300.0)
    sim = simulate(sc)
    log = parse_files(bundle_files(sim))
    out = {"sim": sim, "config": config, "log": log}
    try:
        out["damping"] = run_pipeline(get("damping"), [log], {})
    except Exception as e:  # noqa: BLE001
        out["damping"] = e
    return out


def _gnss_velocity_error(log, sim, t_s):
    """(east, north) error (m/s) of the GNSS-derived reference velocity against the truth at t_s:
    the central difference of the fixes, as a 1-Hz reference is built, minus the true velocity."""
    from ldvsurvey.nav.earth import radii

    g = log.gnss
    k = np.isin(g.fix, (4, 5, 2)) & np.isfinite(g.lat_deg)
    t, lat, lon, h = g.t_s[k], np.radians(g.lat_deg[k]), np.radians(g.lon_deg[k]), g.h_m[k]
    d = np.gradient(np.column_stack([lat, lon]), t, axis=0)
    rm, rn = radii(lat)
    ve, vn = d[:, 1] * (rn + h) * np.cos(lat), d[:, 0] * (rm + h)
    im = sim.imu
    return (
        np.interp(t_s, t, ve) - np.interp(t_s, im.t_s, im.v_n[:, 0]),
        np.interp(t_s, t, vn) - np.interp(t_s, im.t_s, im.v_n[:, 1]),
    )


def damping_figures(case: dict, params=None) -> dict | None:
    sim, r = case["sim"], case["damping"]
    if isinstance(r, Exception):
        return None
    p = {"period_s": 1.0, "delayed_baseline_s": 60.0, **(params or {})}
    sc = sim.scenario
    tab = r.tables["damping"]
    ref_e, ref_n = _gnss_velocity_error(case["log"], sim, tab["t_s"])
    out = {}
    for mode in ("undamped", "conventional", "delayed_state"):
        ve = tab[f"{mode}_east_velocity_error_mps"] + ref_e
        vn = tab[f"{mode}_north_velocity_error_mps"] + ref_n
        v = np.hypot(ve, vn)
        pos = np.hypot(tab[f"{mode}_east_error_m"], tab[f"{mode}_north_error_m"])
        out[mode] = {
            "rms_velocity_mps": float(np.sqrt(np.nanmean(v**2))),
            "rms_position_m": float(np.sqrt(np.mean(pos**2))),
            "max_position_m": float(pos.max()),
        }
    t_run = float(sim.motion.t_end_s - sc.t0_s - sc.static_s)
    sig_mean = sc.ldv.noise_mps / np.sqrt(sc.ldv_rate_hz * p["period_s"])
    sv = float(sig_mean * np.sqrt(2 * t_run / p["delayed_baseline_s"]))
    spec = sc.effects.imu_errors
    if spec is not None:  # in-run bias drift: velocity changes cannot see it; Schuler-bounded amplitudes
        g, r_e = 9.80665, 6.371e6
        w_s = np.sqrt(g / r_e)
        acc = spec.accel_bi_frac * sc.accel_bias_ug * 1e-6 * g / w_s
        gyr = spec.gyro_bi_frac * np.radians(sc.gyro_bias_dph) / 3600.0 * r_e
        sv = float(np.sqrt(sv**2 + acc**2 + gyr**2))
    out.update(
        current_mps=float(np.linalg.norm(sc.current_n_mps)),
        run_s=t_run,
        velocity_floor_mps=sv,
        position_floor_m=sv * t_run,
        warnings=list(r.summary["warnings"]),
    )
    return out
