"""Tables built to trip a view up (a time gap, missing values, paths that are not functions of x,
more rows than a trace may carry) and summaries to go with them; used by the view and report tests."""

import numpy as np

GAP_T = (1200, 1500)  #: rows removed from every time series: a 30-s gap at 10 Hz
NAN_ROWS = (2000, 2100)  #: a stretch where the values are missing
#: WGS-84 (the track's east/north metres turned into latitude/longitude on the test's own formulas)
A_M, F = 6378137.0, 1 / 298.257223563
LAT0_DEG, LON0_DEG = 28.4861, 113.0623  #: where tests/bundles.py puts its GNSS fixes


def _t(n=3000, rate_hz=10.0):
    keep = np.ones(n, bool)
    keep[GAP_T[0] : GAP_T[1]] = False
    return 30000.0 + np.arange(n)[keep] / rate_hz


def _nan(a):
    a = np.array(a, float)
    a[NAN_ROWS[0] : NAN_ROWS[1]] = np.nan
    return a


def lat_lon(e_m, n_m):
    """Latitude, longitude (deg) of east/north offsets from (LAT0, LON0), meridian and prime-vertical
    radii of WGS-84 at LAT0 (a small area: the offsets are a few km)."""
    e2 = F * (2 - F)
    s = np.sin(np.radians(LAT0_DEG))
    rn = A_M / np.sqrt(1 - e2 * s * s)
    rm = A_M * (1 - e2) / (1 - e2 * s * s) ** 1.5
    return LAT0_DEG + np.degrees(n_m / rm), LON0_DEG + np.degrees(e_m / (rn * np.cos(np.radians(LAT0_DEG))))


def path():
    """A figure-of-eight drive sampled at 10 Hz (at most 4.5 m per row), its time and east/north (m)."""
    t = _t(4000)
    s = (t - t[0]) * 10.0
    ph = 2 * np.pi * s / s[-1]
    return t, 2000.0 * np.sin(ph), 1000.0 * np.sin(2 * ph) + 0.2 * s


def tables():
    t = _t()
    rng = np.random.default_rng(7)
    w = np.sin((t - t[0]) / 40.0)
    h_gnss = np.full(len(t), np.nan)
    h_gnss[::10] = 100.0 + w[::10]
    fix = np.where((np.arange(len(t)) // 500) % 2 == 0, 4, 2)
    height = {
        "t_s": t,
        "h_m": _nan(100.0 + w + 0.01 * rng.standard_normal(len(t))),
        "h_uncompensated_m": 100.0 + w + 0.3 * np.cos(t / 7.0),
        "h_gnss_m": h_gnss,
        "fix_quality": fix.astype(float),
    }
    attitude = {"t_s": t}
    for k in ("pitch_raw_deg", "pitch_deg", "roll_raw_deg", "roll_deg"):
        attitude[k] = _nan(rng.standard_normal(len(t)).cumsum() * 0.01)
    tt, e, n = path()
    lat, lon = lat_lon(e, n)
    track = {"t_s": tt, "lat_deg": lat, "lon_deg": lon, "h_m": np.full(len(tt), 100.0)}
    g_lat, g_lon = lat_lon(e[::10] + 0.5, n[::10] - 0.5)
    gnss = {"t_s": tt[::10], "lat_deg": g_lat, "lon_deg": g_lon, "fix": np.where(np.arange(len(g_lat)) < 150, 4, 2)}
    # gravity: two 11-km lines, 10 m apart rows; L2 driven back (distance falls with time); the
    # SINS/GNSS chain missing over 3-6 km; coincidence rows missing 5.0-5.5 km on L1
    cols = ("t_s", "line", "distance_m", "lat_deg", "lon_deg", "dg_mgal", "dg_sins_gnss_mgal", "dg_gnss_aided_mgal")
    grav = {k: [] for k in cols}
    coin = {k: [] for k in ("line", "distance_m", "dg_mgal", "mean_mgal", "residual_mgal")}
    d = np.arange(0.0, 11000.0 + 1e-9, 10.0)
    t0 = 40000.0
    for name, dd in (("L1", d), ("", np.full(60, np.nan)), ("L2", d[::-1])):
        m = len(dd)
        grav["t_s"].append(t0 + np.arange(m))
        grav["line"] += [name] * m
        grav["distance_m"].append(dd)
        g = 10 * np.sin(dd / 900.0) + 0.2 * rng.standard_normal(m)
        grav["dg_mgal"].append(g)
        grav["dg_sins_gnss_mgal"].append(np.where((dd > 3000) & (dd < 6000), np.nan, g + 0.3))
        grav["dg_gnss_aided_mgal"].append(g - 0.1)
        la, lo = lat_lon(np.nan_to_num(dd, nan=-500.0) * 0.6, np.nan_to_num(dd, nan=-500.0) * 0.8)
        grav["lat_deg"].append(la)
        grav["lon_deg"].append(lo)
        t0 += m + 100.0
    for name in ("L1", "L2"):
        keep = ~((d > 5000) & (d < 5500)) if name == "L1" else np.ones(len(d), bool)
        dd = d[keep]
        mean = 10 * np.sin(dd / 900.0)
        res = 0.2 * rng.standard_normal(len(dd))
        coin["line"] += [name] * len(dd)
        coin["distance_m"].append(dd)
        coin["dg_mgal"].append(mean + res)
        coin["mean_mgal"].append(mean)
        coin["residual_mgal"].append(res)
    grav = {k: (np.array(v, dtype=object) if k == "line" else np.concatenate(v)) for k, v in grav.items()}
    coin = {k: (np.array(v, dtype=object) if k == "line" else np.concatenate(v)) for k, v in coin.items()}
    # a network adjustment's values on the line rows (in the gravity table's order) and one base tie
    on = grav["line"] != ""
    adjusted = {
        "line": grav["line"][on],
        "lat_deg": grav["lat_deg"][on],
        "lon_deg": grav["lon_deg"][on],
        "dg_mgal": grav["dg_mgal"][on] + 3.0,
        "sigma_mgal": np.full(int(on.sum()), 0.3),
    }
    tie_lat, tie_lon = lat_lon(np.array([0.6 * 5000.0]), np.array([0.8 * 5000.0]))
    residuals = {
        "kind": np.array(["tie"], dtype=object),
        "line": np.array(["T1"], dtype=object),
        "lat_deg": tie_lat,
        "lon_deg": tie_lon,
        "residual_mgal": np.array([-0.2]),
    }
    dov = {"t_s": t, "xi_arcsec": _nan(3 * w), "eta_arcsec": -2 * w}
    for mth in ("direct", "rk4", "theoretical"):
        dov[f"dn_{mth}_m"] = _nan(0.1 * w * (t - t[0]) / 100)
        dov[f"de_{mth}_m"] = 0.05 * w
    damping = {"t_s": t}
    for mth in ("undamped", "conventional", "delayed_state"):
        damping[f"{mth}_north_error_m"] = _nan(np.sin((t - t[0]) / 500.0) * (3 if mth == "undamped" else 1))
    return {
        "height.csv": height,
        "attitude.csv": attitude,
        "trajectory.csv": track,
        "calibration_track.csv": track,
        "gravity.csv": grav,
        "gravity_adjusted.csv": adjusted,
        "network_residuals.csv": residuals,
        "coincidence.csv": coin,
        "dov.csv": dov,
        "damping.csv": damping,
    }, {"gnss": gnss}


SUMMARIES = {
    "height": {
        "std_error_m": 0.41,
        "max_error_m": -1.78,
        "n_reference": 270,
        "std_error_m_fix4": 0.05,
        "max_error_m_fix4": -0.13,
        "n_reference_fix4": 140,
    },
    "tilt": {"alpha_rad": 1e-4, "beta_rad": -2e-4},
    "gravity": {
        "total_mgal": 0.2,
        "noise_floor": {"total_mgal": 0.15, "drift_mgal": 0.05, "combined_mgal": 0.16},
        "fir_length_s": 120,
        "resolution_m": 900,
        "line_end_trim_s": 60,
        "lines": [{"name": "L1"}, {"name": "L2"}],
        "gnss_comparison": {
            "total_mgal": 0.9,
            "noise_floor": {"total_mgal": 0.5},
            "ldv_minus_gnss": [{"name": "L1", "rms_mgal": 0.31}, {"name": "L2", "rms_mgal": 0.29}],
        },
    },
    "dov": {"dov_source": "EGM2008 to degree 2190"},
    "damping": {"position_improvement_pct": 41.5},
    "navigate": {},
    "calibrate": {},
}


#: what a gravity job that adjusted a survey network adds to its summary (the network map shows only then)
NETWORK = {
    "network": {
        "datum": "ties",
        "datum_sigma_mgal": 0.1,
        "crossover_rms_after_mgal": 0.2,
        "repeat_rms_after_mgal": 0.2,
        "noise_floor_mgal": 0.39,
        "lines": [{"resolution_m": 1966.0}],
    }
}


def summary_of(view: str) -> dict:
    """The summary of a job that has something to show in ``view``."""
    from ldvsurvey.api.views import VIEWS

    s = SUMMARIES.get(VIEWS[view].pipeline, {})
    return {**s, **NETWORK} if view == "gravity_network_map" else s


def csv_bytes(table: dict) -> bytes:
    """A table as the pipelines write it: a header, then one row per sample ('' for an empty line name)."""
    cols = list(table)
    out = [",".join(cols)]
    for i in range(len(table[cols[0]])):
        out.append(",".join(str(table[c][i]) if table[c].dtype == object else repr(float(table[c][i])) for c in cols))
    return ("\n".join(out) + "\n").encode()


def store_job(database_url: str, log_ids: list[int], pipeline: str, files: dict, summary: dict) -> int:
    """A succeeded job with its result files stored directly (what a worker would have written)."""
    import json

    from ldvsurvey.store.db import session_scope
    from ldvsurvey.store.models import Job, JobFile

    with session_scope(database_url) as s:
        j = Job(
            pipeline=pipeline,
            log_ids=log_ids,
            parameters={},
            status="succeeded",
            stage="done",
            progress=100,
            summary=summary,
        )
        s.add(j)
        s.flush()
        for name, t in {**files, "summary.json": None}.items():
            data = json.dumps(summary).encode() if t is None else csv_bytes(t)
            s.add(JobFile(job_id=j.id, name=name, size_bytes=len(data), content=data))
        return j.id


def provenance(pipeline: str, sha: str) -> dict:
    """The provenance keys every summary carries (docs/results.md), with known values to look for."""
    return {
        "pipeline": pipeline,
        "format_version": "ldv-drive-log/1",
        "inputs": [
            {"bundle": "test drive", "file": "imu.csv", "sha256": sha},
            {"bundle": "test drive", "file": "gnss.nmea", "sha256": sha[::-1]},
        ],
        "parameters": {"fir_length_s": 120.0, "drift_correction": "none", "gnss_fixes": "4,5"},
        "software_version": "9.8.7-test",
        "started_at": "2026-01-02T03:04:05+00:00",
        "elapsed_s": 12.5,
        "warnings": ["line L2: 30 s of IMU gap bridged"],
    }
