"""Filtering, line cutting and the statistics of the ``gravity`` pipeline (methods §4, §4a).

Every figure in mGal; every line's statistics beside what gaps and trimming removed from it.
"""

from __future__ import annotations

import numpy as np

from ldvsurvey.errors import ParameterError
from ldvsurvey.nav.coincidence import along_track, common_points, crossovers, internal_coincidence
from ldvsurvey.nav.gravity import MGAL, half_wavelength_resolution_m, noise_floor_mgal, trim_line, zero_phase_lowpass
from ldvsurvey.pipelines.prep import local_metres

#: crossings at a smaller angle are repeated passes over the same road, not crossovers
CROSSOVER_MIN_ANGLE_DEG = 20.0


def evaluate(chains, lines, fir_s, spacing_m, trim_s):
    """Filter each chain, cut and trim the lines, put them on common points, compute the statistics.

    ``chains``: raw chains (see :mod:`gravity_chains`), ``lines``: [(name, chain index, t0, t1)].
    """
    filtered = [zero_phase_lowpass(ch["dg"], fir_s, ch["fs"]) for ch in chains]
    ref = None
    per_line = []
    for name, ci, a, b in lines:
        ch = chains[ci]
        whole = (ch["t_s"] >= a) & (ch["t_s"] <= b)
        k = trim_line(ch["t_s"], a, b, trim_s) & np.isfinite(filtered[ci])
        if k.sum() < 10:
            raise ParameterError(f"line {name} [{a}, {b}] s holds no data after trimming {trim_s:g} s at each end",
                                 field="lines" if trim_s == 0 else "line_end_trim_s")
        if ref is None:
            lat0, lon0 = ch["lat"][k][0], ch["lon"][k][0]
            e, n = local_metres(lat0, lon0, ch["lat"][k], ch["lon"][k])
            step = max(1, int(len(e) // 4000))
            ref = (lat0, lon0, e[::step], n[::step])
        e, n = local_metres(ref[0], ref[1], ch["lat"][k], ch["lon"][k])
        s, lateral = along_track(ref[2], ref[3], e, n)
        gaps = ch["imu_gaps"]
        in_line = (gaps["t_s"] >= a) & (gaps["t_s"] <= b)
        info = {"bridged_s": float(np.sum(ch["bridged"][whole]) / ch["fs"]),
                "bridged_share": float(np.mean(ch["bridged"][whole])) if whole.any() else 0.0,
                "imu_missing_rows": int(np.sum(gaps["missing"][in_line])),
                "duration_s": float(b - a), "trimmed_duration_s": float(max(0.0, b - a - 2 * trim_s))}
        per_line.append((name, ci, k, s, lateral, e, n, info))
    repeated = all(np.median(p[4]) < 50.0 for p in per_line)
    result = {"repeated": repeated, "filtered": filtered, "per_line": per_line}
    if repeated and len(per_line) >= 2:
        grid, vals = common_points([(p[3], filtered[p[1]][p[2]] / MGAL) for p in per_line], spacing_m)
        result["coincidence"] = internal_coincidence(vals, [p[0] for p in per_line], grid)
    step = max(1, int(round(chains[0]["fs"] * 2.0)))  # ~2 s along the tracks
    tracks = [(p[5][::step], p[6][::step], filtered[p[1]][p[2]][::step] / MGAL) for p in per_line]
    result["crossings"], result["crossover_mgal"] = crossovers(tracks, CROSSOVER_MIN_ANGLE_DEG)
    speeds = np.concatenate([chains[p[1]]["speed"][p[2]] for p in per_line])
    result["median_speed_mps"] = float(np.nanmedian(speeds))
    result["resolution_m"] = half_wavelength_resolution_m(result["median_speed_mps"], fir_s)
    return result


def floor_of(log, chain, fir_s):
    """White-noise floor of the coincidence for one chain, with where each noise figure came from."""
    acc = log.manifest.imu.accel_noise_ug_per_rthz
    out = {"accel_noise_ug_rthz": acc, "accel_noise_source": "manifest" if acc else "not given"}
    if chain["kind"] == "ldv":
        ldv_sig = getattr(log.manifest.ldv, "noise_mps", None)
        src = "manifest"
        if not isinstance(ldv_sig, (int, float)) or not ldv_sig > 0:
            ldv_sig, src = chain.get("ldv_noise_mps"), "estimated from the data (second differences)"
        out.update(ldv_noise_mps=ldv_sig, ldv_noise_source=src, ldv_rate_hz=log.manifest.ldv.rate_hz)
        out.update(noise_floor_mgal(fir_s, acc, ldv_sig, log.manifest.ldv.rate_hz))
    else:
        out.update(gnss_height_sigma_m=chain["height_sigma_m"], gnss_height_sigma_source="fix quality")
        out.update(noise_floor_mgal(fir_s, acc, height_noise_m=chain["height_sigma_m"], gnss_rate_hz=chain["fs"]))
    return out


def block(res, fir_s, trim_s, aiding, floor):
    """The summary block of one chain."""
    out = {"fir_length_s": fir_s, "aiding": aiding, "resolution_m": res["resolution_m"],
           "median_speed_mps": res["median_speed_mps"], "repeated_lines": res["repeated"],
           "line_end_trim_s": trim_s,
           "line_ends": f"{trim_s:g} s trimmed at both ends of every line (FIR leakage of turnarounds, "
                        "acceleration and braking)" if trim_s > 0 else "lines not trimmed",
           "noise_floor": floor}
    infos = {p[0]: p[7] for p in res["per_line"]}
    co = res.get("coincidence")
    if co is not None:
        out["lines"] = [{"name": nm, "max_mgal": float(mx), "min_mgal": float(mn), "rms_mgal": float(r),
                         "mean_mgal": float(me), "std_mgal": float(sd), **infos[nm]}
                        for nm, mx, mn, r, me, sd in zip(co.names, co.per_line_max, co.per_line_min,
                                                         co.per_line_rms, co.per_line_mean, co.per_line_std)]
        out["total_mgal"] = co.total
        out["common_length_m"] = float(co.distance_m[-1] - co.distance_m[0])
        out["floor_ratio"] = co.total / floor["total_mgal"] if floor.get("total_mgal") else None
    else:
        out["lines"] = [{"name": p[0], "max_mgal": None, "min_mgal": None, "rms_mgal": None, **p[7]}
                        for p in res["per_line"]]
        out["total_mgal"] = None
        out["floor_ratio"] = None
    out["crossover_mgal"] = res["crossover_mgal"]
    out["n_crossings"] = len(res["crossings"])
    out["bridged_s"] = float(sum(p[7]["bridged_s"] for p in res["per_line"]))
    return out


def chain_difference(res_a, chains_a, res_b, chains_b):
    """Per line: mean and RMS (mGal) of filtered chain A minus chain B at A's (trimmed) line samples."""
    out = []
    for pa, pb in zip(res_a["per_line"], res_b["per_line"]):
        ta = chains_a[pa[1]]["t_s"][pa[2]]
        tb = chains_b[pb[1]]["t_s"]
        fb = res_b["filtered"][pb[1]]
        ok = np.isfinite(fb)
        d = (res_a["filtered"][pa[1]][pa[2]] - np.interp(ta, tb[ok], fb[ok])) / MGAL
        d = d[np.isfinite(d)]
        out.append({"name": pa[0], "mean_mgal": float(np.mean(d)) if len(d) else None,
                    "rms_mgal": float(np.sqrt(np.mean(d ** 2))) if len(d) else None})
    return out
