"""Benchmark: what a user pays for a short drive, ``ldv-survey import`` + ``ldv-survey run navigate``,
beside KF-GINS on the same KF-GINS text files.

A 10-minute (``--minutes``) 100-Hz INS/GNSS drive without an LDV is simulated as in
``bench_kfgins.py`` (its scenario and its writer of KF-GINS's text files, times in GPS seconds of
week), then three commands are timed, each as its own fresh process, as a user runs them:

* ``ldv-survey import --imu kf-gins:imu.txt --gnss kf-gins:gnss.txt --manifest partial.json``
  (parse, put on the bundle clock and axes, the import's checks, write and validate the bundle);
* ``ldv-survey run navigate bundle.zip --set aiding=gnss --set output_rate_hz=100`` (read and
  validate the bundle, forward filter + RTS smoother, write the results at every IMU epoch, as
  KF-GINS writes its solution);
* KF-GINS on the same two text files (when ``KFGINS_BIN``/``--kfgins`` is given; see
  ``bench_kfgins.py`` for how to get it): parsing, its forward EKF and its three output files.

The figure to read is the CPU time (user + system of the child, from ``wait4``), median of
``--repeats`` runs: the machine this runs on is shared and loaded, so wall time swings with the
other processes; CPU time much less. Wall time (median and minimum) is printed beside it. numba's
cache is warmed by one untimed ``run`` first. Prints figures; asserts nothing.

Run: ``KFGINS_BIN=/path/to/KF-GINS/bin/KF-GINS PYTHONPATH=backend .venv/bin/python
benchmarks/bench_short_drive.py --repeats 5`` (``--keep DIR`` keeps the files; a folder that already
holds ``imu.txt``, ``gnss.txt``, ``partial.json`` and ``kf-gins.yaml`` is timed as it is, e.g. a second
run, or a real drive as ``bench_kfgins_real.py`` prepares it).
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import sys
import tempfile
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_kfgins import find_kfgins, scenario, timed, write_kfgins_config, write_kfgins_inputs  # noqa: E402


def make_drive(folder: Path, minutes: float, grade: str, seed: int) -> dict:
    """Simulate the drive; write ``imu.txt``, ``gnss.txt`` (KF-GINS text, GPS seconds of week), the
    partial manifest ``partial.json`` for the import and KF-GINS's YAML. Returns what KF-GINS's
    config needs (see ``bench_kfgins.write_kfgins_inputs``)."""
    import datetime as dt

    from ldvsurvey.io.drivelog import parse_files
    from ldvsurvey.io.importers import gpstime
    from ldvsurvey.sim.scenario import bundle_files, simulate

    sc, _ = scenario(minutes, grade)
    sim = simulate(sc, seed=seed)
    files = bundle_files(sim)
    log = parse_files(files)
    day = dt.date.fromisoformat(str(log.manifest.date))
    _, sow0 = gpstime.gps_week_of(day, gpstime.gps_minus_utc_s(day))
    k = write_kfgins_inputs(sim, log, folder, t_offset_s=sow0)
    write_kfgins_config(folder, k)
    partial = json.loads(files["manifest.json"])
    partial.pop("format")  # what the recordings hold is taken from them
    partial["imu"].pop("rate_hz")
    (folder / "partial.json").write_text(json.dumps(partial, indent=1))
    return k


def ours(folder: Path, rate_hz: float) -> dict:
    """The two commands of a user of ldv-survey on the drive's files."""
    py = [sys.executable, "-m", "ldvsurvey.cli"]
    return {
        "import": py
        + [
            "import",
            "--imu",
            f"kf-gins:{folder / 'imu.txt'}",
            "--gnss",
            f"kf-gins:{folder / 'gnss.txt'}",
            "--manifest",
            str(folder / "partial.json"),
            "--out",
            str(folder / "bundle.zip"),
        ],
        "run navigate": py
        + ["run", "navigate", str(folder / "bundle.zip"), "--out", str(folder / "ours")]
        + ["--set", "aiding=gnss", "--set", f"output_rate_hz={rate_hz:g}"],
    }


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--kfgins", default=os.environ.get("KFGINS_BIN"), help="KF-GINS's binary or checkout")
    ap.add_argument("--minutes", type=float, default=10.0, help="drive length incl. the 5-min static start")
    ap.add_argument("--grade", default="tactical")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--repeats", type=int, default=5, help="timed runs of each command (median)")
    ap.add_argument("--keep", type=Path, help="keep (and reuse) the drive's files here")
    ap.add_argument(
        "--backend",
        type=Path,
        default=Path(__file__).resolve().parents[1] / "backend",
        help="the ldvsurvey to time (a checkout's backend folder; default this one's), e.g. to compare two commits",
    )
    ap.add_argument("--output-rate-hz", type=float, help="navigate's output_rate_hz (default: the IMU rate)")
    args = ap.parse_args()
    kfgins = find_kfgins(args.kfgins) if args.kfgins else None

    folder = args.keep or Path(tempfile.mkdtemp(prefix="bench-short-"))
    folder.mkdir(parents=True, exist_ok=True)
    if not (folder / "partial.json").is_file():
        make_drive(folder, args.minutes, args.grade, args.seed)
    n_imu = sum(1 for _ in open(folder / "imu.txt"))
    n_gnss = sum(1 for _ in open(folder / "gnss.txt"))
    t = np.loadtxt(folder / "imu.txt", usecols=0, max_rows=1000)
    rate = float(round(1.0 / float(np.median(np.diff(t)))))  # the nominal rate (the tags jitter)
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([str(args.backend.resolve()), env.get("PYTHONPATH", "")])
    cmds = ours(folder, args.output_rate_hz or rate)
    for cmd in cmds.values():  # untimed: numba's cache, the page cache
        timed(cmd, env)
    rows = {name: timed(cmd, env, args.repeats) for name, cmd in cmds.items()}
    if kfgins is not None:
        (folder / "kfgins-out").mkdir(exist_ok=True)
        timed([str(kfgins), str(folder / "kf-gins.yaml")])
        rows["KF-GINS (parse, forward EKF, write)"] = timed(
            [str(kfgins), str(folder / "kf-gins.yaml")], None, args.repeats
        )
    print(
        f"{n_imu} IMU rows at {rate:g} Hz ({n_imu / rate / 60:.1f} min), {n_gnss} GNSS fixes; {folder}; "
        f"ldvsurvey from {args.backend}; navigate output_rate_hz={args.output_rate_hz or rate:g}; "
        f"load average {os.getloadavg()[0]:.1f}"
    )
    print(f"| command | CPU user+sys, median of {args.repeats} (s) | wall median (min) (s) |")
    print("|---|---|---|")
    for name, (med, lo, cpu) in rows.items():
        print(f"| {name} | {cpu:.2f} | {med:.2f} ({lo:.2f}) |")
    total = rows["import"][2] + rows["run navigate"][2]
    print(f"| import + run navigate | {total:.2f} | {rows['import'][0] + rows['run navigate'][0]:.2f} |")
    if kfgins is None:
        print("(KF-GINS not given: set KFGINS_BIN or --kfgins to time it on the same files)")
    if args.keep is None:
        shutil.rmtree(folder, ignore_errors=True)


if __name__ == "__main__":
    main()
