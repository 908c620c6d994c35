"""Benchmark: ``import`` + ``navigate`` beside KF-GINS on REAL IMU + GNSS recordings.

The real-data yardstick of issue 34. A prepared set is a folder holding the recording in KF-GINS's
text format (``imu.txt``: GPS seconds of week, angle and velocity increments in the vehicle's
front-right-down axes; ``gnss.txt``: seconds of week, latitude, longitude, ellipsoidal height and
the fix σ), the partial manifest our importer needs (``partial.json``: date, the set's documented
IMU noise figures, the antenna lever arm) and ``set.json`` (what the set is). ``prepare`` writes
such a folder from a public recording's own files (see ``PREPARERS``); the source, licence and
what was done to it are in ``/work/realdata/STATUS.md`` and docs/accuracy.md.

Per set, three GNSS variants are run: every fix, five 30-s outages, four 60-s outages (fixes
withheld, 90 s after the start and then spread over the drive). Each variant is imported with
our CLI (``ldv-survey import --imu kf-gins:… --gnss kf-gins:…``), navigated with ``ldv-survey run
navigate --set aiding=gnss`` forward only (``smooth=false``) and smoothed, and run through KF-GINS
with the same noise figures, fix σ (the σ our filter gives each fix quality), lever arm and start
position; KF-GINS is given a levelled start over the standstill the GNSS speed shows, the GNSS
course once moving as initial heading and the gyros' static mean as initial bias (what the issue
asks our alignment to find by itself). Printed per solution: horizontal RMS against the fixes after
the first 60 s (the fixes' own σ beside it), heading − GNSS course RMS (speed > 3 m/s), and the
horizontal drift at the end of each outage against the withheld fix (RMS and max; for the smoothed
solution the largest error inside a gap), against the set's reference solution where it has one;
and the CPU and wall seconds of import, navigate and KF-GINS. Where ``navigate`` refuses, its
message is printed instead of figures.

Run (KF-GINS built from its public source, see bench_kfgins.py)::

    PYTHONPATH=backend .venv/bin/python benchmarks/bench_kfgins_real.py prepare rtklibexplorer-drive \\
        SRC_DIR /work/realdata/rtklibexplorer-drive0708
    KFGINS_BIN=/work/kfgins/bin/KF-GINS PYTHONPATH=backend .venv/bin/python benchmarks/bench_kfgins_real.py \\
        /work/realdata/rtklibexplorer-drive0708 [--static-s 30] [--noise standstill] [--outages 30x5,60x4] [--keep DIR]

``--static-s`` gives navigate ``initial.static_s`` (main needs it on this drive); ``--noise standstill``
raises both filters' white noise to what the standstill shows (an idling engine's vibration is far
above a MEMS datasheet's figure). The ``ldvsurvey`` this process imports (PYTHONPATH) is the one the
``import`` and ``navigate`` subprocesses run: point PYTHONPATH at another worktree's backend to
measure it. Prints figures; asserts nothing.
"""

from __future__ import annotations

import argparse
import datetime as dt
import json
import os
import resource
import shutil
import struct
import subprocess
import sys
import tempfile
import time
import zipfile
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_kfgins import c_of_euler_zyx, find_kfgins, write_kfgins_config  # noqa: E402

RAD = np.pi / 180.0
GPS_EPOCH = dt.date(1980, 1, 6)
#: GPS − UTC (s) from 2017-01-01 on (no leap second since)
GPS_UTC_S = 18.0
#: the placed outages: (count, length s), the first 90 s after the first IMU sample
OUTAGES = {"30-s": (5, 30.0), "60-s": (4, 60.0)}
EARTH_RATE_DPH = 15.041


# ----------------------------------------------------------------------------------------- prepare
def _tag_times(tag: bytes) -> tuple[float, float]:
    """Start (GPST as UNIX-style seconds) and span (s) of an RTKLIB ``str2str`` time-tag file:
    a 60-byte header, tick rate (u4), start time (u4 s + f8 s), then (tick ms, file position) u4 pairs."""
    if not tag.startswith(b"TIMETAG"):
        raise ValueError("not an RTKLIB time-tag file")
    sec = struct.unpack("<I", tag[64:68])[0] + struct.unpack("<d", tag[68:76])[0]
    last_tick = struct.unpack("<I", tag[-8:-4])[0]
    return sec, last_tick / 1000.0


def _c_body_of_imu(rpy_deg) -> np.ndarray:
    """The matrix taking IMU-axis vectors to the body (front-right-down) axes for a mounting stated as
    roll, pitch, yaw (deg) in Groves's convention (the rtklibexplorer configs'): Rx(φ)ᵀ-style passive
    rotations, C = R1(φ) R2(θ) R3(ψ)."""
    r, p, y = np.radians(rpy_deg)
    r1 = np.array([[1, 0, 0], [0, np.cos(r), np.sin(r)], [0, -np.sin(r), np.cos(r)]])
    r2 = np.array([[np.cos(p), 0, -np.sin(p)], [0, 1, 0], [np.sin(p), 0, np.cos(p)]])
    r3 = np.array([[np.cos(y), np.sin(y), 0], [-np.sin(y), np.cos(y), 0], [0, 0, 1]])
    return r1 @ r2 @ r3


def _gps_sow(gpst_unix: np.ndarray) -> np.ndarray:
    return np.mod(gpst_unix - 315964800.0, 604800.0)


def _read_rtklib_pos(path: Path) -> dict:
    """GPST calendar time, lat, lon, height, Q, σn, σe, σu, and vn, ve, vu where present."""
    rows = []
    for line in path.read_text().splitlines():
        if not line.strip() or line.startswith("%"):
            continue
        p = line.split()
        t = dt.datetime.strptime(p[0] + " " + p[1], "%Y/%m/%d %H:%M:%S.%f").replace(tzinfo=dt.UTC)
        rows.append([t.timestamp()] + [float(x) for x in p[2:]])
    a = np.array(rows)
    out = dict(t=a[:, 0], lat=a[:, 1], lon=a[:, 2], h=a[:, 3], q=a[:, 4].astype(int), sig=a[:, 6:9])
    if a.shape[1] >= 18:
        out["v_neu"] = a[:, 15:18]
    return out


def prepare_rtklibexplorer(src: Path, out: Path, which: str) -> None:
    """rtklibexplorer/GNSS_IMU ``data/drive_0708`` (car) or ``data/walk_0827`` (walking): the raw
    IMU CSV (accelerations in g, rates in °/s, IMU milliseconds) placed in GPST by its RTKLIB time
    tag as the set's own converter does (IMU ticks stretched over the tag's span, then the config's
    ``imu_t_off``), turned into the vehicle's FRD axes by the config's mounting (``imu_misalign``),
    and the RTK solution file (``gnss_*_sf.pos``, GPST) as the fixes."""
    cfg = {
        "drive": dict(stem="1934", rpy=(180.0, -6.79, 185.35), t_off=-0.125, lever_frd=(0.0, -0.05, 0.0)),
        "walk": dict(stem="1730", rpy=(180.0, 0.0, -90.0), t_off=0.0, lever_frd=(0.0, 0.0, 0.0)),
    }[which]
    stem = cfg["stem"]
    raw = np.genfromtxt(src / f"imu_{stem}.csv", delimiter=",", skip_header=1, skip_footer=1)
    start, span = _tag_times((src / f"imu_{stem}.csv.tag").read_bytes())
    ms = raw[:, 6] - raw[0, 6]
    # the ticks are the host's arrival times (8-11 ms steps around exactly 10 ms): the sensor samples at
    # a fixed rate, so the time base is the ticks' straight-line fit against the sample index
    ms = np.polyval(np.polyfit(np.arange(len(ms)), ms, 1), np.arange(len(ms)))
    ms -= ms[0]
    t = start + ms / 1000.0 * span / (ms[-1] / 1000.0) + cfg["t_off"]
    c = _c_body_of_imu(cfg["rpy"])
    f_frd = raw[:, 0:3] @ c.T * 9.80665  # the set's own g unit
    w_frd = np.radians(raw[:, 3:6]) @ c.T
    dt_s = np.diff(t, prepend=t[0] - np.median(np.diff(t)))
    sow = _gps_sow(t)
    imu = np.column_stack([sow, w_frd * dt_s[:, None], f_frd * dt_s[:, None]])
    out.mkdir(parents=True, exist_ok=True)
    np.savetxt(out / "imu.txt", imu, fmt=["%.4f"] + ["%.10e"] * 6)
    pos = _read_rtklib_pos(src / f"gnss_{stem}_sf.pos")
    g = np.column_stack([_gps_sow(pos["t"]), pos["lat"], pos["lon"], pos["h"], pos["sig"]])
    np.savetxt(out / "gnss.txt", g, fmt=["%.3f", "%.10f", "%.10f", "%.4f", "%.4f", "%.4f", "%.4f"])
    date = dt.datetime.fromtimestamp(t[0] - GPS_UTC_S, dt.UTC).date().isoformat()
    lever = cfg["lever_frd"]
    partial = {
        "name": f"rtklibexplorer GNSS_IMU {which} {stem}",
        "date": date,
        "platform": "vehicle",
        "imu": {
            "rotating": False,
            # the set's config: initial bias σ 0.2 °/s and 0.2 m/s², gyro noise 0.0038 °/s/√Hz, accel 70 µg/√Hz,
            # bias PSDs 3.8e-5 °/s²/√Hz and 7 µg/√Hz (their 1-h random walk as the in-run instability)
            "gyro_bias_dph": 720.0,
            "accel_bias_ug": 20000.0,
            "gyro_arw_deg_per_rth": 0.228,
            "accel_noise_ug_per_rthz": 70.0,
            "gyro_bias_instability_dph": 8.2,
            "accel_bias_instability_ug": 420.0,
            "bias_correlation_s": 3600.0,
        },
        "gnss": {"lever_arm_m": [lever[1], lever[0], -lever[2]]},  # FRD -> RFU
        "import": {"imu": {"static_gravity_tolerance": 0.03}},
    }
    (out / "partial.json").write_text(json.dumps(partial, indent=2) + "\n")
    meta = {"source": "rtklibexplorer/GNSS_IMU", "set": which, "grade": "consumer MEMS", "truth": "RTK fixes"}
    (out / "set.json").write_text(json.dumps(meta, indent=2) + "\n")
    print(f"{out}: {len(imu)} IMU rows ({1 / np.median(np.diff(t)):.1f} Hz), {len(g)} fixes, date {date}")


PREPARERS = {
    "rtklibexplorer-drive": lambda s, o: prepare_rtklibexplorer(s, o, "drive"),
    "rtklibexplorer-walk": lambda s, o: prepare_rtklibexplorer(s, o, "walk"),
}


# --------------------------------------------------------------------------------------- measuring
def run_timed(cmd, env=None) -> dict:
    """One run of a command: exit status, wall and CPU (user + system of the child) seconds, output."""
    r0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    r = subprocess.run(cmd, env=env, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = r1.ru_utime - r0.ru_utime + r1.ru_stime - r0.ru_stime
    return dict(rc=r.returncode, wall=wall, cpu=cpu, out=r.stdout, err=r.stderr)


def sow_minus_day_s(date: str) -> float:
    """GPS seconds of week minus the bundle clock (seconds since 00:00 UTC of ``date``)."""
    d = dt.date.fromisoformat(date)
    return ((d - GPS_EPOCH).days % 7) * 86400.0 + GPS_UTC_S


def enu_m(lat0, lon0, lat, lon, h, h0=0.0):
    """Local east/north/up offsets (m) of (lat, lon, h in deg, deg, m) from (lat0, lon0) (deg),
    small-area (the errors measured are metres over a few km)."""
    a, e2 = 6378137.0, 6.69437999014e-3
    s = np.sin(lat0 * RAD)
    rn = a / np.sqrt(1 - e2 * s * s)
    rm = rn * (1 - e2) / (1 - e2 * s * s)
    return np.column_stack(
        [(lon - lon0) * RAD * (rn + h0) * np.cos(lat0 * RAD), (lat - lat0) * RAD * (rm + h0), h - h0]
    )


def gnss_course(g: np.ndarray, min_speed=3.0, half_s=1.0):
    """Course over ground (deg, clockwise from north) and speed from central differences of the
    fixes over ±``half_s``; only where the speed exceeds ``min_speed`` (m/s)."""
    t = g[:, 0]
    e = enu_m(g[0, 1], g[0, 2], g[:, 1], g[:, 2], g[:, 3])
    i0 = np.searchsorted(t, t - half_s)
    i1 = np.clip(np.searchsorted(t, t + half_s, side="right") - 1, 0, len(t) - 1)
    d = e[i1] - e[i0]
    dt_s = np.maximum(t[i1] - t[i0], 1e-9)
    speed = np.hypot(d[:, 0], d[:, 1]) / dt_s
    ok = (speed > min_speed) & (t[i1] - t[i0] > 1.5 * half_s)
    return t[ok], np.degrees(np.arctan2(d[ok, 0], d[ok, 1])), speed


def standstill_end(g: np.ndarray, still_mps=0.1) -> float:
    """The end of the standstill the GNSS shows at the start: the last time before the speed first
    exceeds ``still_mps`` (central differences over ±1 s)."""
    _, _, speed = gnss_course(g, min_speed=-1.0)
    moving = np.flatnonzero(speed > still_mps)
    return float(g[max(moving[0] - 4, 0), 0]) if len(moving) else float(g[-1, 0])


def outage_windows(t0: float, t_end: float, count: int, length: float) -> list[tuple[float, float]]:
    """``count`` windows of ``length`` s from t0 + 90 s, spread evenly up to 30 s before the end."""
    first, last = t0 + 90.0, t_end - 30.0 - length
    starts = np.linspace(first, max(first, last), count)
    return [(float(a), float(a + length)) for a in starts]


def withhold(g: np.ndarray, windows) -> np.ndarray:
    """The fixes outside the outage windows."""
    keep = np.ones(len(g), bool)
    for a, b in windows:
        keep &= ~((g[:, 0] >= a) & (g[:, 0] < b))
    return g[keep]


def kfgins_start(imu: np.ndarray, g: np.ndarray, t_still: float) -> dict:
    """What KF-GINS is given: roll and pitch from the mean specific force over the standstill, the
    GNSS course over the first metres above 3 m/s as heading, the gyros' static mean as bias (°/h)."""
    k = imu[:, 0] <= t_still
    dtk = np.diff(imu[:, 0], prepend=imu[0, 0])[k][1:].sum()
    f = imu[k, 4:7].sum(0) / dtk  # FRD: at rest f = (0, 0, -g) rotated
    w = imu[k, 1:4].sum(0) / dtk
    roll, pitch = np.arctan2(-f[1], -f[2]), np.arctan2(f[0], np.hypot(f[1], f[2]))
    tc, course, _ = gnss_course(g)
    yaw = np.radians(course[0])
    return dict(att=(roll, pitch, yaw), bg_dph=np.degrees(w) * 3600.0, n_still=int(k.sum()), t_course=float(tc[0]))


def antenna_of(t, lat, lon, h, c_frd_ned, lever_frd):
    """Antenna latitude/longitude/height (deg, deg, m) from the IMU's and the body-to-NED matrices."""
    d = c_frd_ned @ np.asarray(lever_frd, float)  # N, E, D offsets (m)
    a, e2 = 6378137.0, 6.69437999014e-3
    s = np.sin(lat * RAD)
    rn = a / np.sqrt(1 - e2 * s * s)
    rm = rn * (1 - e2) / (1 - e2 * s * s)
    return lat + d[:, 0] / (rm + h) / RAD, lon + d[:, 1] / ((rn + h) * np.cos(lat * RAD)) / RAD, h - d[:, 2]


def solution_of_ours(out: Path, offset: float) -> dict:
    """Our trajectory.csv on GPS seconds of week: t, lat, lon, h, heading (deg), C_b^n (FRD->NED)."""
    from ldvsurvey.nav.attitude import c_bn_from_euler

    tab = np.genfromtxt(out / "trajectory.csv", delimiter=",", names=True, comments="#")
    c = c_bn_from_euler(np.radians(tab["pitch_deg"]), np.radians(tab["roll_deg"]), np.radians(tab["heading_deg"]))
    swap = np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]])
    return dict(
        t=tab["t_s"] + offset,
        lat=tab["lat_deg"],
        lon=tab["lon_deg"],
        h=tab["h_m"],
        heading=tab["heading_deg"],
        c=swap @ c @ swap,
    )


def solution_of_kfgins(out: Path) -> dict:
    nav = np.loadtxt(out / "KF_GINS_Navresult.nav")
    c = c_of_euler_zyx(*np.radians(nav[:, 8:11]).T)
    return dict(t=nav[:, 1], lat=nav[:, 2], lon=nav[:, 3], h=nav[:, 4], heading=nav[:, 10], c=c)


def _interp_sol(sol: dict, t: np.ndarray, lever_frd) -> np.ndarray:
    """Antenna position (lat, lon deg, h m) of a solution at times t (linear between epochs)."""
    lat, lon, h = antenna_of(sol["t"], sol["lat"], sol["lon"], sol["h"], sol["c"], lever_frd)
    return np.column_stack([np.interp(t, sol["t"], lat), np.interp(t, sol["t"], lon), np.interp(t, sol["t"], h)])


def horizontal_errors(sol: dict, g: np.ndarray, lever_frd) -> tuple[np.ndarray, np.ndarray]:
    """Times and horizontal distances (m) between a solution's antenna and the fixes g (within its span)."""
    g = g[(g[:, 0] >= sol["t"][0]) & (g[:, 0] <= sol["t"][-1])]
    p = _interp_sol(sol, g[:, 0], lever_frd)
    e = enu_m(g[0, 1], g[0, 2], p[:, 0], p[:, 1], p[:, 2]) - enu_m(g[0, 1], g[0, 2], g[:, 1], g[:, 2], g[:, 3])
    return g[:, 0], np.hypot(e[:, 0], e[:, 1])


def rms(x) -> float:
    x = np.asarray(x, float)
    return float(np.sqrt(np.mean(x * x))) if len(x) else float("nan")


def heading_vs_course(sol: dict, g: np.ndarray, t_from: float) -> float:
    """RMS (deg) of the solution's heading minus the GNSS course, speed > 3 m/s, after t_from."""
    tc, course, _ = gnss_course(g)
    k = (tc >= t_from) & (tc >= sol["t"][0]) & (tc <= sol["t"][-1])
    hd = np.degrees(np.unwrap(np.radians(sol["heading"])))
    d = np.interp(tc[k], sol["t"], hd) - course[k]
    return rms((d + 180.0) % 360.0 - 180.0)


def outage_figures(sol: dict, g_all: np.ndarray, windows, lever_frd) -> tuple[list, list]:
    """Per window: the horizontal error at its last withheld fix, and the largest inside it (m)."""
    end, inside = [], []
    for a, b in windows:
        k = (g_all[:, 0] >= a) & (g_all[:, 0] < b)
        if not k.any():
            continue
        t, e = horizontal_errors(sol, g_all[k], lever_frd)
        if len(e):
            end.append(float(e[-1]))
            inside.append(float(e.max()))
    return end, inside


def _cli(env, *args) -> dict:
    return run_timed([sys.executable, "-m", "ldvsurvey.cli", *args], env)


def kfgins_inputs(vdir: Path, bundle: Path, set_dir: Path, start: dict, offset: float) -> dict:
    """KF-GINS's GNSS file (the fixes our filter takes, with its σ per quality) and its config figures."""
    from ldvsurvey.io.drivelog import load_bundle
    from ldvsurvey.nav.filter import ImuNoise
    from ldvsurvey.pipelines.stages.aids import gnss_aid, pipeline_cfg

    log = load_bundle(bundle)
    a = gnss_aid(log)
    g = np.column_stack(
        [a.t_s + offset, np.degrees(a.lat_rad), np.degrees(a.lon_rad), a.h_m, a.sigma_h_m, a.sigma_h_m, a.sigma_v_m]
    )
    np.savetxt(vdir / "gnss.txt", g, fmt=["%.4f", "%.10f", "%.10f", "%.4f", "%.3f", "%.3f", "%.3f"])
    lever_frd = np.array([a.lever_arm_m[1], a.lever_arm_m[0], -a.lever_arm_m[2]])
    c0 = c_of_euler_zyx(*[np.array([x]) for x in start["att"]])
    lat, lon, h = antenna_of(None, g[:1, 1], g[:1, 2], g[:1, 3], c0, -lever_frd)  # IMU under the antenna
    noise = ImuNoise.from_manifest(log.manifest.imu)
    cfg = pipeline_cfg()
    tilt_sd = max(np.degrees(noise.accel_bias_ug * 9.80665e-6 / 9.80665), 0.1)
    return dict(
        t0=float(np.loadtxt(set_dir / "imu.txt", max_rows=1)[0]),
        pos0=(lat[0] * RAD, lon[0] * RAD, h[0]),
        att0=start["att"],
        att_sigma0_deg=[tilt_sd, tilt_sd, 2.0],
        vel_sigma0=cfg.vel_sigma0_mps,
        pos_sigma0=cfg.pos_sigma0_m,
        noise=noise,
        lever_frd=lever_frd,
        rate_hz=float(log.manifest.imu.rate_hz),
        bg0_dph=start["bg_dph"],
        bg_sigma0_dph=3 * EARTH_RATE_DPH,
        imupath=set_dir / "imu.txt",
    )


def run_variant(name, set_dir, folder, g_rows, partial, env, kfgins, start, offset) -> dict:
    """Import, navigate (forward, smoothed) and KF-GINS on one GNSS variant; their solutions and costs."""
    vdir = folder / name
    vdir.mkdir(parents=True, exist_ok=True)
    np.savetxt(vdir / "fixes.txt", g_rows, fmt=["%.4f", "%.10f", "%.10f", "%.4f", "%.4f", "%.4f", "%.4f"])
    (vdir / "partial.json").write_text(json.dumps(partial, indent=2))
    bundle = vdir / "bundle.zip"
    res = {"import": _cli(env, "import", "--imu", f"kf-gins:{set_dir / 'imu.txt'}", "--gnss",
                          f"kf-gins:{vdir / 'fixes.txt'}", "--manifest", str(vdir / "partial.json"),
                          "--out", str(bundle))}  # fmt: skip
    if res["import"]["rc"] != 0:
        return res
    rate = json.loads(zipfile.ZipFile(bundle).read("manifest.json"))["imu"]["rate_hz"]
    for smooth in (False, True):
        out = vdir / ("smoothed" if smooth else "forward")
        r = _cli(env, "run", "navigate", str(bundle), "--out", str(out), "--set", "aiding=gnss",
                 "--set", f"smooth={str(smooth).lower()}", "--set", f"output_rate_hz={rate:g}")  # fmt: skip
        if r["rc"] == 0:
            r["sol"] = solution_of_ours(out, offset)
            r["summary"] = json.loads((out / "summary.json").read_text())
        res["smoothed" if smooth else "forward"] = r
    k = kfgins_inputs(vdir, bundle, set_dir, start, offset)
    cfg = write_kfgins_config(vdir, k)
    r = run_timed([str(kfgins), str(cfg)])
    if r["rc"] == 0:
        r["sol"] = solution_of_kfgins(vdir / "kfgins-out")
    res["kfgins"], res["lever_frd"] = r, k["lever_frd"]
    return res


def _fail(r) -> str:
    lines = [x for x in (r["err"] + r["out"]).splitlines() if x.strip()]
    return f"refused (exit {r['rc']}): {lines[-1][:300] if lines else '?'}"


SOLUTIONS = (
    ("forward", "`navigate`, forward filter"),
    ("smoothed", "`navigate`, smoothed"),
    ("kfgins", "KF-GINS (forward)"),
)


def report(set_dir: Path, runs: dict, g: np.ndarray, windows: dict, t0: float) -> None:
    """The figures table (each beside its floor) and the cost table."""
    full = runs["all"]
    print(f"\n## {set_dir.name}\n")
    print("| solution | horizontal RMS after 60 s (m) | heading − GNSS course RMS (°) "
          + " ".join(f"| {w} outages ({len(v)}), drift at the end RMS / max (m)" for w, v in windows.items())
          + " |")  # fmt: skip
    print("|---|---|---" + "|---" * len(windows) + "|")
    for key, label in SOLUTIONS:
        r = full.get(key)
        if r is None or "sol" not in r:
            print(f"| {label} | {_fail(r) if r else 'not run'} |" + " |" * (1 + len(windows)))
            continue
        t, e = horizontal_errors(r["sol"], g, full["lever_frd"])
        cells = [f"{rms(e[t > t0 + 60.0]):.3f}", f"{heading_vs_course(r['sol'], g, t0 + 60.0):.2f}"]
        for w, win in windows.items():
            rw = runs[w].get(key)
            if rw is None or "sol" not in rw:
                cells.append(_fail(rw) if rw else "not run")
                continue
            end, inside = outage_figures(rw["sol"], g, win, full["lever_frd"])
            cell = f"{rms(end):.2f} / {max(end):.2f}"
            if key == "smoothed":
                cell += f" (largest inside a gap {rms(inside):.2f} RMS, {max(inside):.2f} max)"
            cells.append(cell)
        print(f"| {label} | " + " | ".join(cells) + " |")
    sig = np.hypot(g[:, 4], g[:, 5])
    print(f"| the fixes' own σ (floor; the filters take {0.03:g} m per RTK fix) | {rms(sig):.3f} | – "
          + "| – " * len(windows) + "|")  # fmt: skip
    for key, label in SOLUTIONS:  # what each solution started from, and what its filter threw away
        r = full.get(key)
        if r is None or "sol" not in r:
            continue
        line = f"{label}: heading at the first epoch {r['sol']['heading'][0]:.1f}°"
        if "summary" in r:
            rej = r["summary"].get("rejected_measurements", {})
            line += f", rejected: {rej.get('gnss', '?')} of {len(g)} fixes, {rej.get('zupt', '?')} ZUPTs"
        print(f"\n{line}", end="")
    print()
    n = runs["all"].get("repeats", 1)
    print(f"\n| step (every fix; median of {n}) | wall (s) | CPU (s) |\n|---|---|---|")
    for key, label in (("import", "`ldv-survey import`"),) + SOLUTIONS:
        r = full.get(key)
        if r is not None:
            print(f"| {label} | {r['wall']:.2f} (min {r.get('wall_min', r['wall']):.2f}) "
                  f"| {r['cpu']:.2f} (min {r.get('cpu_min', r['cpu']):.2f}) |")  # fmt: skip


def standstill_noise(imu: np.ndarray, t_still: float) -> tuple[float, float]:
    """White noise the standstill itself shows (engine vibration included), largest axis: the gyros'
    angle random walk (°/√h) and the accelerometers' (µg/√Hz), from the sample scatter times √Δt."""
    k = imu[:, 0] <= t_still
    dt_s = float(np.median(np.diff(imu[:, 0])))
    w = imu[k, 1:4] / dt_s
    f = imu[k, 4:7] / dt_s
    arw = float(np.degrees(w.std(0).max()) * np.sqrt(dt_s) * 60.0)
    vrw = float(f.std(0).max() * np.sqrt(dt_s) / 9.80665e-6)
    return arw, vrw


def run_set(
    set_dir: Path,
    kfgins: Path,
    static_s: float | None,
    folder: Path,
    noise: str = "datasheet",
    outages=None,
    repeats: int = 1,
) -> None:
    """Every variant of one prepared set, then its tables."""
    import ldvsurvey

    partial = json.loads((set_dir / "partial.json").read_text())
    if static_s is not None:
        partial.setdefault("initial", {})["static_s"] = static_s
    g = np.loadtxt(set_dir / "gnss.txt", ndmin=2)
    imu = np.loadtxt(set_dir / "imu.txt")
    t0, t_end = float(imu[0, 0]), float(imu[-1, 0])
    t_still = standstill_end(g)
    print(f"ldvsurvey from {Path(ldvsurvey.__file__).parent}", file=sys.stderr)
    if noise == "standstill":  # both filters get the noise the standstill shows, where above the datasheet's
        arw, vrw = standstill_noise(imu, t_still)
        m = partial["imu"]
        m["gyro_arw_deg_per_rth"] = max(m["gyro_arw_deg_per_rth"], round(arw, 3))
        m["accel_noise_ug_per_rthz"] = max(m["accel_noise_ug_per_rthz"], round(vrw, 1))
        print(f"noise from the standstill: ARW {arw:.3f} °/√h, VRW {vrw:.0f} µg/√Hz (largest axis)", file=sys.stderr)
    start = kfgins_start(imu, g, t_still)
    offset = sow_minus_day_s(partial["date"])
    windows = {w: outage_windows(t0, t_end, n, length) for w, (n, length) in (outages or OUTAGES).items()}
    print(
        f"{set_dir.name}: {len(imu)} IMU rows over {t_end - t0:.0f} s, {len(g)} fixes; GNSS standstill until "
        f"{t_still - t0:.1f} s ({start['n_still']} IMU rows); KF-GINS start: roll {np.degrees(start['att'][0]):+.2f}°, "
        f"pitch {np.degrees(start['att'][1]):+.2f}°, heading {np.degrees(start['att'][2]):+.2f}° (GNSS course at "
        f"{start['t_course'] - t0:.1f} s), gyro bias {np.round(start['bg_dph'], 1).tolist()} °/h (FRD)"
        + (f"; manifest initial.static_s={static_s:g}" if static_s is not None else ""),
        file=sys.stderr,
    )
    # the subprocesses run the very tree this process imports (PYTHONPATH decides: another worktree's
    # backend measures that worktree)
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([str(Path(ldvsurvey.__file__).resolve().parents[1]), env.get("PYTHONPATH", "")])
    run_variant("all", set_dir, folder, g, partial, env, kfgins, start, offset)  # numba's cache warm
    timed_runs = [run_variant("all", set_dir, folder, g, partial, env, kfgins, start, offset) for _ in range(repeats)]
    runs = {"all": timed_runs[-1]}
    runs["all"]["repeats"] = repeats
    for key in ("import", "forward", "smoothed", "kfgins"):  # the median and the least of the repeats
        if all(key in r for r in timed_runs):
            for what in ("wall", "cpu"):
                vals = [r[key][what] for r in timed_runs]
                runs["all"][key][what], runs["all"][key][what + "_min"] = float(np.median(vals)), min(vals)
    for w, win in windows.items():
        runs[w] = run_variant(w, set_dir, folder, withhold(g, win), partial, env, kfgins, start, offset)
    if runs["all"]["import"]["rc"] != 0:
        print(f"import failed: {_fail(runs['all']['import'])}")
        return
    for key, _ in SOLUTIONS[:2]:
        r = runs["all"].get(key)
        if r is not None:
            notes = [x for x in (r["err"]).splitlines() if "warn" in x.lower() or "static" in x.lower()]
            for x in notes[:6]:
                print(f"<!-- navigate {key}: {x.strip()[:300]} -->")
    report(set_dir, runs, g, windows, t0)


def main():
    if len(sys.argv) > 1 and sys.argv[1] == "prepare":
        ap = argparse.ArgumentParser(description="write a prepared set from a public recording's own files")
        ap.add_argument("prepare")
        ap.add_argument("kind", choices=sorted(PREPARERS))
        ap.add_argument("src", type=Path)
        ap.add_argument("out", type=Path)
        a = ap.parse_args()
        PREPARERS[a.kind](a.src, a.out)
        return
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("sets", nargs="+", type=Path, help="prepared set folders (imu.txt, gnss.txt, partial.json)")
    ap.add_argument("--kfgins", default=os.environ.get("KFGINS_BIN"), help="KF-GINS's binary or checkout")
    ap.add_argument("--static-s", type=float, help="give navigate initial.static_s (the baseline of main)")
    ap.add_argument("--keep", type=Path, help="keep every bundle and output here")
    ap.add_argument(
        "--noise",
        choices=("datasheet", "standstill"),
        default="datasheet",
        help="IMU white noise for both filters: the set's figures, or raised to what the standstill shows",
    )
    ap.add_argument("--repeats", type=int, default=1, help="timed runs of the every-fix variant (median)")
    ap.add_argument("--outages", help="outage runs as LENGTHxCOUNT,... in s (default 30x5,60x4)")
    args = ap.parse_args()
    kfgins = find_kfgins(args.kfgins)
    outages = None
    if args.outages:
        outages = {f"{a}-s": (int(b), float(a)) for a, b in (x.split("x") for x in args.outages.split(","))}
    for set_dir in args.sets:
        folder = (args.keep / set_dir.name) if args.keep else Path(tempfile.mkdtemp(prefix="bench-kfgins-real-"))
        folder.mkdir(parents=True, exist_ok=True)
        run_set(set_dir, kfgins, args.static_s, folder, args.noise, outages, args.repeats)
        if args.keep is None:
            shutil.rmtree(folder, ignore_errors=True)


if __name__ == "__main__":
    main()
