"""Benchmark: ``navigate`` (GNSS aiding) beside KF-GINS on the same simulated INS/GNSS drive.

KF-GINS (i2Nav-WHU, open source, C++) is the loosely coupled GNSS/INS filter many users of
strapdown IMUs run today: an error-state EKF with IMU biases and scale factors, forward only. This
script simulates a drive without an LDV with the product's simulator (every real-drive effect that
applies to an IMU and a GNSS receiver on, GNSS outages of 30 and 60 s placed along the drive),
writes the bundle and KF-GINS's text inputs from it, runs both on the same data in one run and
prints their position and attitude errors against the simulator's truth, and the wall time of each.

Fair play: both get the same IMU increments (the rows of ``imu.csv``, turned from the bundle's
right-forward-up axes to KF-GINS's front-right-down), the same GNSS fixes with the σ the product
gives each fix quality, the same lever arm, the same IMU noise figures (the manifest's), the same
start position and the same initial attitude (the product's coarse alignment over the static
start, with the product's initial σ). KF-GINS is forward only: the product's forward filter is
printed beside its forward + RTS smoother solution. Wall time is end to end for both: one process
each reading its input files and writing its output (``ldv-survey run navigate`` with the numba
cache warm, KF-GINS's own binary); the preparation of KF-GINS's inputs is not counted.

KF-GINS is not part of the product (no code of it is kept here): get its public source once and
give the checkout (its binary is built here with cmake when missing; nothing is downloaded) or
the binary itself, with ``--kfgins`` or ``KFGINS_BIN``::

    git clone https://github.com/i2Nav-WHU/KF-GINS /path/to/KF-GINS

Run: ``KFGINS_BIN=/path/to/KF-GINS PYTHONPATH=backend .venv/bin/python benchmarks/bench_kfgins.py``
(``--minutes``, ``--grade``, ``--seed``, ``--keep DIR`` to keep the inputs and outputs). Prints
figures; asserts nothing.
"""

from __future__ import annotations

import argparse
import os
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

RAD = np.pi / 180.0
#: RFU (bundle sensor axes) <-> FRD (KF-GINS) and ENU (product) <-> NED (KF-GINS): both swap the
#: first two axes and flip the third, and each is its own inverse
SWAP = np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]])
#: IMU grades (turn-on bias °/h and µg, ARW °/√h, VRW µg/√Hz)
GRADES = {
    "tactical": dict(gyro_bias_dph=1.0, accel_bias_ug=250.0, gyro_arw_dprh=0.05, accel_vrw_ug_rthz=50.0),
    "navigation": dict(gyro_bias_dph=0.003, accel_bias_ug=20.0, gyro_arw_dprh=0.0005, accel_vrw_ug_rthz=5.0),
    #: the frame and time check: an error-free IMU, no effects, no outages (RTK noise only)
    "ideal": dict(gyro_bias_dph=1e-3, accel_bias_ug=1.0, gyro_arw_dprh=1e-5, accel_vrw_ug_rthz=0.1),
}
BUILD_HELP = """KF-GINS not found. Get its public source once and give the checkout (built here with
cmake when its binary is missing) or the binary:
    git clone https://github.com/i2Nav-WHU/KF-GINS /path/to/KF-GINS
    export KFGINS_BIN=/path/to/KF-GINS            (or pass --kfgins PATH; a checkout or its bin/KF-GINS)
Building by hand: cd /path/to/KF-GINS && mkdir -p build && cd build
    cmake .. -DCMAKE_BUILD_TYPE=Release && make -j2    (-> /path/to/KF-GINS/bin/KF-GINS)"""


def _give_up(message: str):
    """Say what is missing and exit 2 (nothing to compare without KF-GINS)."""
    print(message, file=sys.stderr)
    sys.exit(2)


def find_kfgins(path: str | None) -> Path:
    """KF-GINS's binary from ``--kfgins``/``KFGINS_BIN``: the binary itself, or a checkout of its
    source whose ``bin/KF-GINS`` is built here with cmake (its ThirdParty folder carries Eigen,
    Abseil and yaml-cpp) when absent. Nothing is downloaded. Exits 2 saying how to get it."""
    if not path:
        _give_up(BUILD_HELP)
    p = Path(path).expanduser()
    if p.is_file():
        return p
    if not (p / "CMakeLists.txt").is_file() or not (p / "src" / "kf_gins.cpp").is_file():
        _give_up(f"{p}: neither KF-GINS's binary nor a checkout of its source\n{BUILD_HELP}")
    binary = p / "bin" / "KF-GINS"
    if binary.is_file():
        return binary
    if shutil.which("cmake") is None:
        _give_up(f"building KF-GINS needs cmake and a C++ compiler (Debian: apt-get install cmake g++)\n{BUILD_HELP}")
    build = p / "build"
    build.mkdir(exist_ok=True)
    print(f"building KF-GINS in {build} (a few minutes the first time)", file=sys.stderr)
    for cmd in (["cmake", "..", "-DCMAKE_BUILD_TYPE=Release"], ["make", f"-j{os.cpu_count() or 1}"]):
        r = subprocess.run(cmd, cwd=build, capture_output=True, text=True)
        if r.returncode != 0:
            _give_up(f"{' '.join(cmd)} failed in {build}:\n{r.stdout[-3000:]}\n{r.stderr[-3000:]}")
    if not binary.is_file():
        _give_up(f"the build finished but {binary} is not there")
    return binary


def euler_zyx_of(c_frd_ned: np.ndarray) -> tuple[float, float, float]:
    """Roll, pitch, yaw (rad) of C_b^n (FRD body to NED), Z-Y-X order as KF-GINS states its attitude."""
    c = c_frd_ned
    return float(np.arctan2(c[2, 1], c[2, 2])), float(-np.arcsin(c[2, 0])), float(np.arctan2(c[1, 0], c[0, 0]))


def c_of_euler_zyx(roll, pitch, yaw) -> np.ndarray:
    """C_b^n (N, 3, 3), FRD body to NED, from Z-Y-X Euler angles (rad): Rz(yaw) Ry(pitch) Rx(roll)."""
    cr, sr, cp, sp, cy, sy = np.cos(roll), np.sin(roll), np.cos(pitch), np.sin(pitch), np.cos(yaw), np.sin(yaw)
    c = np.empty((len(roll), 3, 3))
    c[:, 0, 0], c[:, 0, 1], c[:, 0, 2] = cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr
    c[:, 1, 0], c[:, 1, 1], c[:, 1, 2] = sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr
    c[:, 2, 0], c[:, 2, 1], c[:, 2, 2] = -sp, cp * sr, cp * cr
    return c


def scenario(minutes: float, grade: str, drive: str = "effects"):
    """The simulated drive and its placed GNSS outages [(from, to, 0)] in seconds from the start.

    ``effects``: ``minutes`` long, every real-drive effect for an IMU and a receiver on (the effects
    add their own outages, degraded stretches and multipath jumps), outages of 30 and 60 s placed
    at 8 and 12 min, RTK fixes elsewhere. ``outages``: the drive of the outage table in
    docs/accuracy.md (no effects, three outages each of 10, 30 and 60 s from 6 min on, 120 s
    apart; ``minutes`` is ignored). The ``ideal`` grade: no effects and no outages (the frame check).
    """
    from ldvsurvey.sim import catalog
    from ldvsurvey.sim.effects import Effects

    if grade == "ideal":
        return catalog.drive(minutes=minutes, with_ldv=False, **GRADES[grade]), []
    if drive == "outages":
        sched, t = [], 360.0
        for length in (10.0, 30.0, 60.0) * 3:
            sched.append((t, t + length, 0))
            t += length + 120.0
        return catalog.drive(
            minutes=(t + 60.0) / 60.0 + 1.0, with_ldv=False, fix_schedule=sched, **GRADES[grade]
        ), sched
    sched = [(480.0, 510.0, 0), (720.0, 780.0, 0)]
    eff = Effects.realistic(seed=1, ldv_dropouts=False, turntable=False)
    return catalog.drive(minutes=minutes, with_ldv=False, fix_schedule=sched, effects=eff, **GRADES[grade]), sched


def write_kfgins_inputs(sim, log, folder: Path, t_offset_s: float = 0.0) -> dict:
    """KF-GINS's IMU and GNSS text files from the bundle's data; returns what its config needs.

    The time column is the bundle clock (s) plus ``t_offset_s``: 0 for KF-GINS alone (it needs only
    one clock for both files), the GPS seconds of week of the bundle's midnight for files that
    ``ldv-survey import --imu kf-gins:… --gnss kf-gins:…`` reads as GPS seconds of week."""
    from ldvsurvey.pipelines.stages.aids import gnss_aid, initial_attitude, nav_inputs, pipeline_cfg

    t_imu, dth, dv = sim.imu.t_s, sim.dtheta_rad, sim.dvel_mps
    if "imu_keep" in sim.extras:  # the rows imu.csv holds (dropped rows, jittered time tags)
        keep = sim.extras["imu_keep"]
        t_imu, dth, dv = sim.extras["imu_t_written"][keep], dth[keep], dv[keep]
    rows = np.column_stack([t_imu + t_offset_s, dth @ SWAP.T, dv @ SWAP.T])
    np.savetxt(folder / "imu.txt", rows, fmt=["%.6f"] + ["%.12e"] * 6)
    g = gnss_aid(log)  # the fixes the product's filter takes, with its σ per fix quality
    t_g, lat, lon, h = g.t_s, np.degrees(g.lat_rad), np.degrees(g.lon_rad), g.h_m
    sh, sv = g.sigma_h_m, g.sigma_v_m
    gnss = np.column_stack([t_g, lat, lon, h, sh, sh, sv])
    gnss_text = gnss.copy()
    gnss_text[:, 0] += t_offset_s
    np.savetxt(folder / "gnss.txt", gnss_text, fmt=["%.3f", "%.10f", "%.10f", "%.4f", "%.3f", "%.3f", "%.3f"])
    inp = nav_inputs(log)
    c0 = initial_attitude(inp, None)  # C_s^n, RFU to ENU: the product's coarse alignment
    cfg = pipeline_cfg()
    return dict(
        t0=float(t_imu[0] + t_offset_s),
        pos0=inp.pos0,
        att0=euler_zyx_of(SWAP @ c0 @ SWAP),
        att_sigma0_deg=[a / RAD for a in cfg.att_sigma0_rad],
        vel_sigma0=cfg.vel_sigma0_mps,
        pos_sigma0=cfg.pos_sigma0_m,
        noise=inp.noise,
        lever_frd=SWAP @ np.asarray(log.manifest.gnss.lever_arm_m, float),
        rate_hz=float(log.manifest.imu.rate_hz),
        n_gnss=len(gnss),
        gnss=gnss,
    )


def write_kfgins_config(folder: Path, k: dict) -> Path:
    """KF-GINS's YAML from the same figures the product reads from the manifest (``k`` may also give
    ``bg0_dph``/``bg_sigma0_dph``, the initial gyro bias and its σ in °/h, and ``imupath``)."""
    n = k["noise"]
    g_bi = n.gyro_bias_instability_dph or n.gyro_bias_dph
    a_bi = n.accel_bias_instability_ug or n.accel_bias_ug
    tau_h = (n.bias_correlation_s or 3600.0) / 3600.0
    ug_to_mgal = 9.80665e-6 / 1e-5  # KF-GINS's bias unit mGal is 1e-5 m/s²
    vrw = n.accel_vrw_ug_rthz * 9.80665e-6 * 60.0  # µg/√Hz -> m/s/√h
    lat, lon, h = k["pos0"]
    v3 = lambda x: "[ " + ", ".join(f"{float(v):.10g}" for v in np.broadcast_to(x, 3)) + " ]"  # noqa: E731
    text = f"""# written by benchmarks/bench_kfgins.py
imupath: "{k.get("imupath", folder / "imu.txt")}"
gnsspath: "{folder / "gnss.txt"}"
outputpath: "{folder / "kfgins-out"}"
imudatalen: 7
imudatarate: {k["rate_hz"]:g}
starttime: {k["t0"]:.6f}
endtime: -1
initpos: {v3([lat / RAD, lon / RAD, h])}
initvel: [ 0.0, 0.0, 0.0 ]
initatt: {v3(np.degrees(k["att0"]))}
initgyrbias: {v3(k.get("bg0_dph", 0.0))}
initaccbias: [ 0, 0, 0 ]
initgyrscale: [ 0, 0, 0 ]
initaccscale: [ 0, 0, 0 ]
initposstd: {v3(k["pos_sigma0"])}
initvelstd: {v3(k["vel_sigma0"])}
initattstd: {v3(k["att_sigma0_deg"])}
initbgstd: {v3(k.get("bg_sigma0_dph", n.gyro_bias_dph))}
initbastd: {v3(n.accel_bias_ug * ug_to_mgal)}
imunoise:
  arw: {v3(n.gyro_arw_dprh)}
  vrw: {v3(vrw)}
  gbstd: {v3(g_bi)}
  abstd: {v3(a_bi * ug_to_mgal)}
  gsstd: [ 1000.0, 1000.0, 1000.0 ]
  asstd: [ 1000.0, 1000.0, 1000.0 ]
  corrtime: {tau_h:.6g}
antlever: {v3(k["lever_frd"])}
"""
    (folder / "kfgins-out").mkdir(exist_ok=True)
    path = folder / "kf-gins.yaml"
    path.write_text(text)
    return path


def timed(cmd, env=None, repeats=1) -> tuple[float, float, float]:
    """Median and minimum wall time (s) of ``repeats`` runs of a command (its exit status checked),
    and its median CPU time (user + system, s): on a shared machine the CPU time is the steadier figure."""
    wall, cpu = [], []
    for _ in range(repeats):
        r0 = resource.getrusage(resource.RUSAGE_CHILDREN)
        t0 = time.perf_counter()
        r = subprocess.run(cmd, env=env, capture_output=True, text=True)
        wall.append(time.perf_counter() - t0)
        r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
        cpu.append(r1.ru_utime - r0.ru_utime + r1.ru_stime - r0.ru_stime)
        if r.returncode != 0:
            sys.exit(f"{cmd[0]} failed ({r.returncode}):\n{r.stdout[-2000:]}\n{r.stderr[-2000:]}")
    return statistics.median(wall), min(wall), statistics.median(cpu)


def errors(sim, t, lat_deg, lon_deg, h_m, c_rfu_enu) -> dict:
    """Position (E, N, U in m) and attitude (tilt E, N and heading in deg) errors against truth."""
    from ldvsurvey.nav.earth import enu_offset_m

    im = sim.imu
    e = enu_offset_m(
        np.interp(t, im.t_s, im.lat_rad),
        np.interp(t, im.t_s, im.lon_rad),
        np.interp(t, im.t_s, im.h_m),
        np.radians(lat_deg),
        np.radians(lon_deg),
        h_m,
    )
    k = np.clip(np.searchsorted(im.t_s, t), 0, len(im.t_s) - 1)
    d = c_rfu_enu @ np.swapaxes(im.c_bn[k], 1, 2)  # C_est C_trueᵀ = I + [φ×], φ in ENU
    phi = 0.5 * np.column_stack([d[:, 2, 1] - d[:, 1, 2], d[:, 0, 2] - d[:, 2, 0], d[:, 1, 0] - d[:, 0, 1]])
    return {"t": t, "enu": e, "att_deg": np.degrees(phi)}


def summary_row(name, err, wall, sc, sched) -> str:
    e, a, t = err["enu"], err["att_deg"], err["t"]
    hz = np.hypot(e[:, 0], e[:, 1])
    rms = lambda x: float(np.sqrt(np.mean(np.square(x))))  # noqa: E731
    outs = []
    for a0, b0, _ in sched:
        k = (t >= sc.t0_s + a0) & (t < sc.t0_s + b0)
        outs.append(f"{hz[k].max():.2f}/{np.abs(e[k, 2]).max():.2f}")
    return (
        f"| {name} | {rms(hz):.3f} | {rms(e[:, 2]):.3f} | {hz.max():.2f} | {np.abs(e[:, 2]).max():.2f} "
        f"| {' · '.join(outs)} | {rms(np.hypot(a[:, 0], a[:, 1])) * 60:.2f} | {rms(a[:, 2]) * 60:.2f} "
        f"| {wall} |"
    )


def gnss_floor_row(sim, gnss, lever_rfu) -> str:
    """The aid itself: the GNSS fixes both filters take, against the true antenna position. Over
    hours with degraded stretches its correlated error is what neither filter can remove."""
    from ldvsurvey.nav.earth import enu_offset_m

    im = sim.imu
    t = gnss[:, 0]
    k = np.clip(np.searchsorted(im.t_s, t), 0, len(im.t_s) - 1)
    e = enu_offset_m(
        np.interp(t, im.t_s, im.lat_rad),
        np.interp(t, im.t_s, im.lon_rad),
        np.interp(t, im.t_s, im.h_m),
        np.radians(gnss[:, 1]),
        np.radians(gnss[:, 2]),
        gnss[:, 3],
    ) - np.einsum("kij,j->ki", im.c_bn[k], np.asarray(lever_rfu, float))
    hz = np.hypot(e[:, 0], e[:, 1])
    rms = lambda x: float(np.sqrt(np.mean(np.square(x))))  # noqa: E731
    return (
        f"| the GNSS fixes taken (antenna, at {len(t)} fixes: the aid, not a solution) | {rms(hz):.3f} "
        f"| {rms(e[:, 2]):.3f} | {hz.max():.2f} | {np.abs(e[:, 2]).max():.2f} | – | – | – | – | – |"
    )


def segment_row(name, err, t_from, t_to) -> str:
    """Mean and RMS errors over one stretch (the frame and time check: static, straight line)."""
    k = (err["t"] >= t_from) & (err["t"] < t_to)
    e, a = err["enu"][k], err["att_deg"][k] * 60.0
    f = lambda x: f"{np.mean(x):+.3f} / {np.sqrt(np.mean(x**2)):.3f}"  # noqa: E731
    return f"| {name} | {f(e[:, 0])} | {f(e[:, 1])} | {f(e[:, 2])} | {f(a[:, 0])} | {f(a[:, 1])} | {f(a[:, 2])} |"


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument(
        "--kfgins",
        default=os.environ.get("KFGINS_BIN"),
        help="KF-GINS's binary, or a checkout of its source (built when needed); default KFGINS_BIN",
    )
    ap.add_argument("--minutes", type=float, default=60.0, help="drive length incl. the 5-min static start")
    ap.add_argument("--grade", choices=sorted(GRADES), default="tactical")
    ap.add_argument(
        "--drive",
        choices=("effects", "outages"),
        default="effects",
        help="every effect with a 30-s and a 60-s outage, or the outage table's drive (3 x 10, 30, 60 s)",
    )
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--repeats", type=int, default=3, help="timed runs of each program (median)")
    ap.add_argument("--keep", type=Path, help="keep the bundle, KF-GINS's inputs and both outputs here")
    args = ap.parse_args()
    kfgins = find_kfgins(args.kfgins)

    from ldvsurvey.io.drivelog import parse_files
    from ldvsurvey.nav.attitude import c_bn_from_euler
    from ldvsurvey.sim.scenario import bundle_files, simulate

    folder = args.keep or Path(tempfile.mkdtemp(prefix="bench-kfgins-"))
    folder.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    sc, sched = scenario(args.minutes, args.grade, args.drive)
    sim = simulate(sc, seed=args.seed)
    files = bundle_files(sim)
    bundle = folder / "bundle"
    bundle.mkdir(exist_ok=True)
    for name, data in files.items():
        (bundle / name).write_bytes(data)
    log = parse_files(files)
    k = write_kfgins_inputs(sim, log, folder)
    cfg = write_kfgins_config(folder, k)
    n_imu = len(log.imu.t_s)
    print(
        f"simulated {(sim.imu.t_s[-1] - sim.imu.t_s[0]) / 60:.0f}-min {args.grade}-grade INS/GNSS drive "
        "(no LDV, effects: "
        f"{', '.join(sc.effects.on())}), {n_imu} IMU rows at {k['rate_hz']:g} Hz, {k['n_gnss']} GNSS fixes "
        f"taken; inputs written in {time.perf_counter() - t0:.1f} s to {folder}",
        file=sys.stderr,
    )

    # our side: one fresh process each, as a user runs it (a first run untimed: numba cache)
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(
        [str(Path(__file__).resolve().parents[1] / "backend"), env.get("PYTHONPATH", "")]
    )
    ours = {}
    for smooth in (True, False):
        out = folder / ("ours-smoothed" if smooth else "ours-forward")
        cmd = [sys.executable, "-m", "ldvsurvey.cli", "run", "navigate", str(bundle), "--out", str(out)]
        cmd += [
            "--set",
            "aiding=gnss",
            "--set",
            f"smooth={str(smooth).lower()}",
            "--set",
            f"output_rate_hz={k['rate_hz']:g}",
        ]
        if smooth:
            subprocess.run(cmd, env=env, capture_output=True)
        ours[smooth] = timed(cmd, env, args.repeats), out
    kf = timed([str(kfgins), str(cfg)], repeats=args.repeats)

    rows, checks = [], []
    stretches = [("static", sc.t0_s + 10.0, sc.t0_s + sc.static_s - 10.0)]
    stretches.append(("straight", sc.t0_s + sc.static_s + 40.0, sc.t0_s + sc.static_s + 90.0))
    for smooth in (False, True):
        (med, lo, cpu), out = ours[smooth]
        tab = np.genfromtxt(out / "trajectory.csv", delimiter=",", names=True, comments="#")
        c = c_bn_from_euler(np.radians(tab["pitch_deg"]), np.radians(tab["roll_deg"]), np.radians(tab["heading_deg"]))
        err = errors(sim, tab["t_s"], tab["lat_deg"], tab["lon_deg"], tab["h_m"], c)
        name = "ldv-survey navigate, forward + RTS smoother" if smooth else "ldv-survey navigate, forward filter"
        rows.append(summary_row(name, err, f"{med:.2f} (min {lo:.2f}) | {cpu:.2f}", sc, sched))
        checks += [segment_row(f"{name}, {w}", err, a, b) for w, a, b in stretches]
    nav = np.loadtxt(folder / "kfgins-out" / "KF_GINS_Navresult.nav")
    c = SWAP @ c_of_euler_zyx(*np.radians(nav[:, 8:11]).T) @ SWAP  # FRD->NED to RFU->ENU
    err = errors(sim, nav[:, 1], nav[:, 2], nav[:, 3], nav[:, 4], c)
    rows.append(summary_row("KF-GINS (forward EKF)", err, f"{kf[0]:.2f} (min {kf[1]:.2f}) | {kf[2]:.2f}", sc, sched))
    checks += [segment_row(f"KF-GINS, {w}", err, a, b) for w, a, b in stretches]

    print(
        "| solution | horizontal RMS (m) | vertical RMS (m) | horizontal max (m) | vertical max (m) "
        f"| max in each placed outage ({', '.join(f'{b - a:.0f}' for a, b, _ in sched)} s), horizontal/vertical (m) "
        "| tilt RMS (′) | heading RMS (′) "
        "| wall time, end to end (s) | CPU time (s) |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        print(r)
    print(gnss_floor_row(sim, k["gnss"], log.manifest.gnss.lever_arm_m))
    print()
    print("| solution, stretch | east mean / RMS (m) | north (m) | up (m) | tilt E (′) | tilt N (′) | heading (′) |")
    print("|---|---|---|---|---|---|---|")
    for r in checks:
        print(r)
    print(f"<!-- median of {args.repeats} runs; errors over the whole log, {len(nav)} epochs -->")
    if args.keep is None:
        shutil.rmtree(folder, ignore_errors=True)


if __name__ == "__main__":
    main()
