"""Benchmark: ingest and each pipeline on simulated 1-, 2-, 4- and 8-hour logs, as a user runs them.

Every figure is one fresh process (``ldv-survey run``, or the ingest steps of an upload: read the
zip, parse and validate, quality report, store in SQLite), timed from outside, with its peak RSS
from ``wait4``. *warm*: numba's cache is the installation's (``ldv-survey warmup`` has run);
*cold*: an empty cache, so the process compiles what it needs (measured on the shortest log).

``--jobs``: also what a dashboard user waits for. The log is stored as an upload stores it (a SQLite
database and its blob folder in a temporary data directory), then a fresh worker process (it imports
what ``huey_consumer ldvsurvey.jobs.worker.huey`` imports: settings, migration, runner, the warm-up
check) runs two jobs of the same kind through the product's own job code, ``JobRunner.execute``
(the stored log loaded, the pipeline run, the results written to the database), each timed alone:
*job first*: the first job of the fresh worker (it imports the pipeline's modules and loads numba's
cached machine code); *job warm*: the second, in the now warm worker. The worker's start (imports) is
reported apart, with what the first job after ``scripts/setup.sh`` pays over a warm one: in a worker
that was already running, and in a process that starts with the job; on the shortest log one more
worker imports the pipeline before its job, splitting that extra into the pipeline's imports and the
rest (numba's cached code, first calls). Before the first worker the
numba cache in use is warmed as ``scripts/setup.sh`` does (``ldv-survey warmup``) when it is not warm
for this code. The peak RSS of a job is the worker's peak during that job (``VmHWM`` reset before it).

After a run (and in the doc) the marginal cost: per step and mode, the slope of time against log
length between the shortest and the longest log of one IMU rate (s per extra hour of log), the fixed
part it implies, and each longer log's time against linear scaling from the shortest (in samples).

Results accumulate in ``benchmarks/.results/scaling.json``; ``--doc`` writes the table and the plot
into ``docs/performance.md`` (between its ``bench`` markers) and ``docs/performance-scaling.png``.
Prints figures; asserts nothing; not part of the test suite.

Run: .venv/bin/python benchmarks/bench_scaling.py --hours 1 2 [--rate 100] [--pipelines navigate gravity] --doc
(``--pipelines`` with no name: the ingest alone; ``--load``: and the job side's loading of the stored log;
``--jobs``: and the job rows; ``--no-cli``: without the fresh-CLI-process rows)
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import signal
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
RESULTS = HERE / ".results" / "scaling.json"
DOC = ROOT / "docs" / "performance.md"
PLOT = ROOT / "docs" / "performance-scaling.png"
SETS = {"navigate": ["aiding=ldv+gnss"]}  # the acceptance figure: LDV + GNSS, forward filter + RTS

INGEST = r"""
import json, resource, shutil, sys, time, tempfile
t0 = time.perf_counter()
from ldvsurvey.io.drivelog import parse_files, read_bundle_path
from ldvsurvey.io.quality import quality_report
from ldvsurvey.store.db import session_scope, upgrade_head
from ldvsurvey.store.logs import store_log
tmp = tempfile.mkdtemp()
url = f"sqlite:///{tmp}/bench.db"
upgrade_head(url)
def cpu():  # CPU seconds of this process, all threads (less sensitive to other load than wall time)
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime
t1, c1 = time.perf_counter(), cpu()
log = parse_files(read_bundle_path(sys.argv[1]))
q = quality_report(log)
t2, c2 = time.perf_counter(), cpu()
with session_scope(url) as s:
    row, _ = store_log(s, log, q)
t3, c3 = time.perf_counter(), cpu()
info = {"import_s": t1 - t0, "parse_s": t2 - t1, "store_s": t3 - t2, "parse_cpu_s": c2 - c1, "store_cpu_s": c3 - c2,
        "duration_s": q["duration_s"], "imu_rows": int(len(log.imu.t_s)),
        "ingest_rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024}
if len(sys.argv) > 2:  # the job side too: the stored log back as arrays, as a worker loads it
    del log
    from ldvsurvey.store.logs import load_drivelog
    t4 = time.perf_counter()
    with session_scope(url) as s:
        back = load_drivelog(s, row.id)
    info["load_s"] = time.perf_counter() - t4
shutil.rmtree(tmp, ignore_errors=True)
print(json.dumps(info))
"""


STORE = r"""
import json, sys
from pathlib import Path
from ldvsurvey.io.drivelog import parse_files, read_bundle_path
from ldvsurvey.io.quality import quality_report
from ldvsurvey.settings import Settings
from ldvsurvey.store.db import session_scope, upgrade_head
from ldvsurvey.store.logs import store_log
url = Settings(data_dir=Path(sys.argv[2])).resolved_database_url()  # the server's layout: data dir, blobs beside
upgrade_head(url)
log = parse_files(read_bundle_path(sys.argv[1]))
q = quality_report(log)
with session_scope(url) as s:
    row, _ = store_log(s, log, q)
print(json.dumps({"log_id": row.id, "duration_s": q["duration_s"], "imu_rows": int(len(log.imu.t_s))}))
"""

WORKER = r"""
import json, resource, sys, time
t0, spawned = time.perf_counter(), float(sys.argv[4])
def cpu():  # CPU seconds of this process so far, all threads
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime
def hwm_mb():  # peak RSS since the last reset_hwm (VmHWM), else of the process
    try:
        for line in open("/proc/self/status"):
            if line.startswith("VmHWM:"):
                return int(line.split()[1]) / 1024
    except OSError:
        pass
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
def reset_hwm():
    try:
        with open("/proc/self/clear_refs", "w") as f:
            f.write("5")
        return True
    except OSError:
        return False
import ldvsurvey.jobs.worker as worker  # what huey_consumer imports at start
t1 = time.perf_counter()
info = {"start_s": time.time() - spawned, "import_s": t1 - t0, "start_cpu_s": cpu(), "start_rss_mb": hwm_mb(),
        "warming": worker._warmup_thread is not None, "jobs": []}
if len(sys.argv) > 6:  # the breakdown: the pipeline's modules imported before its first job, timed apart
    from ldvsurvey.pipelines.registry import get
    ta, ca = time.perf_counter(), cpu()
    get(sys.argv[1])
    info["pipeline_import_s"], info["pipeline_import_cpu_s"] = time.perf_counter() - ta, cpu() - ca
from sqlalchemy import func, select
from ldvsurvey.store.db import session_scope
from ldvsurvey.store.models import Job, JobFile
runner = worker.runner
for k in range(int(sys.argv[5])):
    with session_scope(runner.database_url) as s:  # as the API's submit does
        job = Job(pipeline=sys.argv[1], log_ids=[int(sys.argv[2])], parameters=json.loads(sys.argv[3]),
                  status="queued", stage="queued", progress=0.0)
        s.add(job)
        s.flush()
        job_id = job.id
    per_job_rss = reset_hwm()
    ta, ca = time.perf_counter(), cpu()
    status = runner.execute(job_id)  # the worker's task: load the stored log, run, store the results
    tb, cb = time.perf_counter(), cpu()
    with session_scope(runner.database_url) as s:
        j = s.get(Job, job_id)
        stages = [e for e in j.stage_log or [] if e["stage"] != "started"]
        n_files = s.scalar(select(func.count()).select_from(JobFile).where(JobFile.job_id == job_id))
        info["jobs"].append({"status": status, "wall_s": tb - ta, "cpu_s": cb - ca, "rss_mb": hwm_mb(),
                             "per_job_rss": per_job_rss, "first_stage_s": stages[0]["t_s"] if stages else None,
                             "error": j.error or "", "files": n_files})
print(json.dumps(info))
"""

MAX_RSS_MB = 6144.0  # a child above this is stopped (the machine is shared): reported as "stopped"


def _watch(pid: int, stop: threading.Event, killed: list) -> None:
    while not stop.wait(0.2):
        try:
            status = Path(f"/proc/{pid}/status").read_text()
        except OSError:
            return
        for line in status.splitlines():
            if line.startswith("VmRSS:") and int(line.split()[1]) / 1024.0 > MAX_RSS_MB:
                killed.append(True)
                os.kill(pid, signal.SIGKILL)
                return


def _run(cmd: list[str], env: dict) -> tuple[float, float, int, str, float]:
    """Wall time (s), peak RSS (MB), exit code (-9: stopped above MAX_RSS_MB), stdout of one child
    (with the end of its stderr when it failed) and its CPU time, user + system (s): on a shared,
    loaded machine the wall time says more about the neighbours than about the code."""
    t0 = time.perf_counter()
    with tempfile.TemporaryFile() as out, tempfile.TemporaryFile() as err:
        p = subprocess.Popen(cmd, env=env, stdout=out, stderr=err)
        stop, killed = threading.Event(), []
        watcher = threading.Thread(target=_watch, args=(p.pid, stop, killed), daemon=True)
        watcher.start()
        _, status, ru = os.wait4(p.pid, 0)
        stop.set()
        wall = time.perf_counter() - t0
        p.returncode = os.waitstatus_to_exitcode(status)
        out.seek(0)
        text = out.read().decode(errors="replace")
        if p.returncode != 0:
            err.seek(0)
            text += "\n" + err.read().decode(errors="replace")[-600:]
    return wall, ru.ru_maxrss / 1024.0, p.returncode, text, ru.ru_utime + ru.ru_stime


def _env(cache: str | None) -> dict:
    env = {**os.environ, "PYTHONPATH": str(ROOT / "backend") + os.pathsep + os.environ.get("PYTHONPATH", "")}
    env.pop("LDVSURVEY_NUMBA_CACHE_DIR", None)
    if cache:
        env["LDVSURVEY_NUMBA_CACHE_DIR"] = cache
    return env


def load() -> list[dict]:
    return json.loads(RESULTS.read_text()) if RESULTS.exists() else []


def save(rows: list[dict]) -> None:
    RESULTS.parent.mkdir(exist_ok=True)
    RESULTS.write_text(json.dumps(rows, indent=1))


def _put(rows: list[dict], row: dict) -> None:
    key = ("hours", "rate_hz", "what", "mode")
    rows[:] = [r for r in rows if tuple(r[k] for k in key) != tuple(row[k] for k in key)] + [row]
    print(
        f"{row['what']:>9} {row['mode']:>9} {row['hours']:g} h {row['rate_hz']:g} Hz: {row['wall_s']:7.1f} s "
        f"({row['s_per_h']:.2f} s/h), CPU {row.get('cpu_s', float('nan')):.1f} s, "
        f"peak RSS {row['rss_mb']:.0f} MB{'' if row['ok'] else '  FAILED'}",
        flush=True,
    )


def _best(cmd: list[str], env: dict, repeat: int) -> tuple[float, float, int, str, float, list[float]]:
    """The fastest of ``repeat`` runs (the least disturbed by other load), and all wall times."""
    runs = [_run(cmd, env) for _ in range(max(1, repeat))]
    ok = [r for r in runs if r[2] == 0] or runs
    best = min(ok, key=lambda r: r[4])
    return (*best, [round(r[0], 2) for r in runs])


def _job_env(cache: str | None, data_dir: Path) -> dict:
    """A worker's environment: the server's settings on a data directory of its own (SQLite, no Redis)."""
    env = _env(cache)
    for k in ("LDVSURVEY_DATABASE_URL", "LDVSURVEY_REDIS_URL"):
        env.pop(k, None)
    env["LDVSURVEY_DATA_DIR"] = str(data_dir)
    return env


def _ensure_warm(cache: str | None) -> None:
    """What ``scripts/setup.sh`` does: ``ldv-survey warmup`` unless numba's cache in use is warm for this code
    (else the worker would warm it in a background thread, beside the jobs measured)."""
    py, env = sys.executable, _env(cache)
    probe = "import sys; from ldvsurvey.pipelines.warmup import is_warm; sys.exit(0 if is_warm() else 1)"
    if subprocess.run([py, "-c", probe], env=env).returncode == 0:
        return
    print("numba's cache is not warm for this code: ldv-survey warmup, as scripts/setup.sh does ...", flush=True)
    wall, rss, rc, text, cpu = _run([py, "-m", "ldvsurvey.cli", "warmup"], env)
    print(f"warmup: {wall:.0f} s wall, CPU {cpu:.0f} s{'' if rc == 0 else '  FAILED: ' + text[-300:]}", flush=True)


def bench_jobs(
    rows: list[dict],
    h: float,
    rate: float,
    bundle: Path,
    pipelines: list[str],
    cache: str | None,
    repeat: int,
    breakdown: bool = True,
) -> None:
    """The job rows of one log: stored once, then per pipeline ``repeat`` fresh workers of two jobs each
    (the fastest first job and the fastest second job by CPU time are kept); with ``breakdown`` one more
    worker that imports the pipeline before its job."""
    py = sys.executable
    with tempfile.TemporaryDirectory() as tmp:
        env = _job_env(cache, Path(tmp) / "data")
        wall, rss, rc, text, cpu = _run([py, "-c", STORE, str(bundle), str(Path(tmp) / "data")], env)
        if rc != 0:
            print(f"storing {bundle.name} failed: {text[-600:]}", flush=True)
            return
        stored = json.loads(text.strip().splitlines()[-1])
        log_h = stored["duration_s"] / 3600.0
        for name in pipelines:
            params = dict(x.split("=", 1) for x in SETS.get(name, []))
            runs = []
            for _ in range(max(1, repeat)):
                cmd = [py, "-c", WORKER, name, str(stored["log_id"]), json.dumps(params), repr(time.time()), "2"]
                wall, rss, rc, text, cpu = _run(cmd, env)
                info = json.loads(text.strip().splitlines()[-1]) if rc == 0 else {}
                jobs = info.get("jobs", [])
                ok = rc == 0 and len(jobs) == 2 and all(j["status"] == "succeeded" for j in jobs)
                err = "" if ok else (text[-600:] if rc else "; ".join(j["error"] for j in jobs)[-600:])
                runs.append((ok, info, rss, err))
            good = [r for r in runs if r[0]] or runs
            for k, mode in ((0, "job first"), (1, "job warm")):
                ok, info, proc_rss, err = min(good, key=lambda r: r[1]["jobs"][k]["cpu_s"] if r[0] else float("inf"))
                j = info["jobs"][k] if ok else {}
                row = dict(
                    hours=h,
                    rate_hz=rate,
                    what=name,
                    mode=mode,
                    ok=ok,
                    wall_s=j.get("wall_s", float("nan")),
                    cpu_s=j.get("cpu_s", float("nan")),
                    cpu_s_per_h=j.get("cpu_s", float("nan")) / log_h,
                    log_h=log_h,
                    s_per_h=j.get("wall_s", float("nan")) / log_h,
                    rss_mb=j.get("rss_mb", proc_rss) if j.get("per_job_rss") else proc_rss,
                    proc_rss_mb=proc_rss,
                    load_s=j.get("first_stage_s"),  # pipeline imported, log checked and loaded: its first stage
                    start_s=info.get("start_s"),
                    import_s=info.get("import_s"),
                    start_cpu_s=info.get("start_cpu_s"),
                    warming=info.get("warming"),
                    walls_s=[round(r[1]["jobs"][k]["wall_s"], 2) for r in runs if r[0]],
                    error=err,
                )
                _put(rows, row)
            first, warm = (
                next(
                    r for r in rows if r["what"] == name and r["hours"] == h and r["rate_hz"] == rate and r["mode"] == m
                )
                for m in ("job first", "job warm")
            )
            # the breakdown of the first job's extra: a third fresh worker imports the pipeline before its job
            pre = {}
            if breakdown:
                cmd = [py, "-c", WORKER, name, str(stored["log_id"]), json.dumps(params), repr(time.time()), "1", "1"]
                _, _, rc, text, _ = _run(cmd, env)
                pre = json.loads(text.strip().splitlines()[-1]) if rc == 0 else {}
            if pre.get("jobs") and pre["jobs"][0]["status"] == "succeeded":
                first["pipeline_import_s"] = pre["pipeline_import_s"]
                first["pipeline_import_cpu_s"] = pre["pipeline_import_cpu_s"]
                first["after_import_cpu_s"] = pre["jobs"][0]["cpu_s"]
                first["after_import_s"] = pre["jobs"][0]["wall_s"]
            if first["ok"] and warm["ok"]:
                first["extra_s"] = first["wall_s"] - warm["wall_s"]
                first["extra_cpu_s"] = first["cpu_s"] - warm["cpu_s"]
                first["extra_new_process_s"] = first["start_s"] + first["wall_s"] - warm["wall_s"]
                print(
                    f"{'':>20}worker start {first['start_s']:.2f} s (imports {first['import_s']:.2f} s, "
                    f"CPU {first['start_cpu_s']:.2f} s){'  WARM-UP THREAD RUNNING' if first['warming'] else ''}; "
                    f"log loaded at {first['load_s']:.2f} s (first) / {warm['load_s']:.2f} s (warm) into the job\n"
                    f"{'':>20}first job after setup pays +{first['extra_s']:.2f} s wall "
                    f"(+{first['extra_cpu_s']:.2f} s CPU) over a warm one in a running worker; "
                    f"+{first['extra_new_process_s']:.2f} s in a process that starts with the job",
                    flush=True,
                )
                if "pipeline_import_cpu_s" in first:
                    print(
                        f"{'':>20}of which: the pipeline's imports {first['pipeline_import_s']:.2f} s "
                        f"(CPU {first['pipeline_import_cpu_s']:.2f} s); the first job after them "
                        f"{first['after_import_s']:.2f} s (CPU {first['after_import_cpu_s']:.2f} s: +"
                        f"{first['after_import_cpu_s'] - warm['cpu_s']:.2f} s over warm: numba's cached code, "
                        "first calls)",
                        flush=True,
                    )


def marginal(rows: list[dict]) -> list[dict]:
    """Per step and mode: each longer log against the shortest (fewest IMU samples). Marginal cost, the
    slope of time against log length (s per extra hour of log), only between logs of one IMU rate, with
    the fixed part it implies; and time over linear scaling (in samples) from the shortest log."""

    def wall(r):
        return r["parse_s"] + r["store_s"] if r["what"] == "ingest" else r["wall_s"]

    def cpu(r):
        return r["parse_cpu_s"] + r["store_cpu_s"] if r["what"] == "ingest" else r.get("cpu_s")

    groups: dict[tuple, list[dict]] = {}
    for r in rows:
        if r["ok"] and (r["what"] != "ingest" or "parse_s" in r):
            groups.setdefault((r["what"], r["mode"]), []).append(r)
    out = []
    for (what, mode), rs in sorted(groups.items()):
        rs = sorted(rs, key=lambda r: r["log_h"] * r["rate_hz"])
        ref = rs[0]
        for r in rs[1:]:
            same = r["rate_hz"] == ref["rate_hz"] and r["log_h"] > ref["log_h"]
            dh = r["log_h"] - ref["log_h"]
            slope = (wall(r) - wall(ref)) / dh if same else None
            cpu_slope = (cpu(r) - cpu(ref)) / dh if same and cpu(r) is not None and cpu(ref) is not None else None
            out.append(
                dict(
                    what=what,
                    mode=mode,
                    ref_h=ref["log_h"],
                    ref_hz=ref["rate_hz"],
                    log_h=r["log_h"],
                    rate_hz=r["rate_hz"],
                    slope_s_per_h=slope,
                    cpu_slope_s_per_h=cpu_slope,
                    fixed_s=wall(ref) - slope * ref["log_h"] if slope is not None else None,
                    cpu_fixed_s=cpu(ref) - cpu_slope * ref["log_h"] if cpu_slope is not None else None,
                    vs_linear=wall(r) / (wall(ref) * r["log_h"] * r["rate_hz"] / (ref["log_h"] * ref["rate_hz"])),
                )
            )
    return out


def _fmt(x, spec=".2f", none="–") -> str:
    return none if x is None else format(x, spec)


def print_marginal(rows: list[dict]) -> None:
    for m in marginal(rows):
        print(
            f"{m['what']:>9} {m['mode']:>9} {m['ref_h']:.2f} h {m['ref_hz']:g} Hz -> {m['log_h']:.2f} h "
            f"{m['rate_hz']:g} Hz: marginal {_fmt(m['slope_s_per_h'])} s wall (CPU {_fmt(m['cpu_slope_s_per_h'])} s) "
            f"per extra hour, fixed {_fmt(m['fixed_s'])} s (CPU {_fmt(m['cpu_fixed_s'])} s); "
            f"{m['vs_linear']:.2f} × linear scaling",
            flush=True,
        )


def bench(
    hours: list[float],
    rate: float,
    pipelines: list[str],
    cold: bool,
    repeat: int = 1,
    with_load: bool = False,
    warm_cache: str | None = None,
    cli: bool = True,
    jobs: bool = False,
) -> None:
    sys.path.insert(0, str(HERE))
    from simlogs import bundle_path

    rows = load()
    py = sys.executable
    if jobs and pipelines:
        _ensure_warm(warm_cache)
    for h in hours:
        bundle = bundle_path(h, rate)
        wall, rss, rc, text, cpu, walls = _best(
            [py, "-c", INGEST, str(bundle)] + (["--load"] if with_load else []), _env(None), repeat
        )
        info = json.loads(text.strip().splitlines()[-1]) if rc == 0 else {}
        info["walls_s"] = walls
        log_h = info.get("duration_s", h * 3600.0) / 3600.0
        _put(
            rows,
            dict(
                hours=h,
                rate_hz=rate,
                what="ingest",
                mode="warm",
                ok=rc == 0,
                wall_s=wall,
                rss_mb=rss,
                cpu_s=cpu,
                log_h=log_h,
                s_per_h=(info.get("parse_s", 0) + info.get("store_s", 0)) / log_h,
                **info,
            ),
        )
        modes = [("warm", warm_cache)] + ([("cold", "fresh")] if cold and h == min(hours) else [])
        for name in pipelines if cli else []:
            for mode, cache in modes:
                with tempfile.TemporaryDirectory() as tmp:
                    cache_dir = (str(Path(tmp) / "numba") if cache == "fresh" else cache) if cache else None
                    cmd = [py, "-m", "ldvsurvey.cli", "run", name, str(bundle), "--out", str(Path(tmp) / "out")]
                    for s in SETS.get(name, []):
                        cmd += ["--set", s]
                    wall, rss, rc, text, cpu, walls = _best(cmd, _env(cache_dir), repeat if mode == "warm" else 1)
                _put(
                    rows,
                    dict(
                        hours=h,
                        rate_hz=rate,
                        what=name,
                        mode=mode,
                        ok=rc == 0,
                        wall_s=wall,
                        rss_mb=rss,
                        cpu_s=cpu,
                        cpu_s_per_h=cpu / log_h,
                        log_h=log_h,
                        s_per_h=wall / log_h,
                        error=text[-600:] if rc else "",
                        walls_s=walls,
                    ),
                )
        if jobs and pipelines:
            bench_jobs(rows, h, rate, bundle, pipelines, warm_cache, repeat, breakdown=h == min(hours))
        save(rows)
    print_marginal([r for r in rows if r["rate_hz"] == rate and r["hours"] in hours])


def _machine() -> str:
    cpu = platform.processor() or platform.machine()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    commit = subprocess.run(
        ["git", "rev-parse", "--short", "HEAD"], cwd=ROOT, capture_output=True, text=True
    ).stdout.strip()
    return f"{cpu}, {os.cpu_count()} cores, Python {platform.python_version()}, commit {commit or '?'}"


MODES = ("warm", "cold", "job first", "job warm")  # the table's order within a step


def write_doc(rows: list[dict]) -> None:
    rows = sorted(
        rows,
        key=lambda r: (
            r["what"] != "ingest",
            r["what"],
            r["mode"].startswith("job"),
            r["rate_hz"],
            r["hours"],
            MODES.index(r["mode"]) if r["mode"] in MODES else len(MODES),
        ),
    )
    lines = [
        f"Measured on {_machine()}, {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}.",
        "",
        "| step | mode | log | IMU rate | wall time | s per hour of log | CPU user+sys per hour | peak RSS |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        if not r["ok"]:
            last = [ln for ln in r.get("error", "").splitlines() if ln.strip()][-1:] or [""]
            wall = (
                f"stopped above {MAX_RSS_MB / 1024:.0f} GB"
                if r["rss_mb"] >= MAX_RSS_MB
                else f"failed: {last[0][:90].replace('|', '/')}"
            )
            per_h = "–"
        elif r["what"] == "ingest":
            wall = f"{r['parse_s'] + r['store_s']:.2f} s (process {r['wall_s']:.1f} s)"
            per_h = f"{r['s_per_h']:.2f}"
        elif r["mode"] == "job first" and r.get("start_s") is not None:
            wall, per_h = f"{r['wall_s']:.1f} s (worker start {r['start_s']:.1f} s)", f"{r['s_per_h']:.2f}"
        else:
            wall, per_h = f"{r['wall_s']:.1f} s", f"{r['s_per_h']:.2f}"
        cpu = r.get("cpu_s")
        cpu_h = f"{cpu / r['log_h']:.2f} s" if cpu is not None and r["ok"] else "–"
        lines.append(
            f"| {r['what']} | {r['mode']} | {r['log_h']:.2f} h | {r['rate_hz']:g} Hz | "
            f"{wall} | {per_h} | {cpu_h} | {'≥ ' if not r['ok'] else ''}{r['rss_mb']:.0f} MB |"
        )
    firsts = [r for r in rows if r["mode"] == "job first" and r.get("extra_s") is not None]
    if firsts:
        lines += ["", "First job after setup (numba's cache warmed by `ldv-survey warmup`), over a warm job:", ""]
        lines += [
            f"- {r['what']}, {r['log_h']:.2f} h at {r['rate_hz']:g} Hz: +{r['extra_s']:.2f} s "
            f"(+{r['extra_cpu_s']:.2f} s CPU) in a worker already running; +{r['extra_new_process_s']:.2f} s "
            f"in a worker process that starts with the job"
            for r in firsts
        ]
    margins = marginal(rows)
    if margins:
        lines += [
            "",
            "Marginal cost: each longer log against the shortest of the same step and mode. The slope is the time "
            "per extra hour of log (logs of one IMU rate), the fixed part what the shortest log costs beyond it; "
            "the last column is the time over linear scaling (in IMU samples) from the shortest log.",
            "",
            "| step | mode | from | to | wall s per extra hour | CPU s per extra hour | fixed part, wall (CPU) "
            "| vs linear |",
            "|---|---|---|---|---|---|---|---|",
        ]
        lines += [
            f"| {m['what']} | {m['mode']} | {m['ref_h']:.2f} h {m['ref_hz']:g} Hz | {m['log_h']:.2f} h "
            f"{m['rate_hz']:g} Hz | {_fmt(m['slope_s_per_h'])} | {_fmt(m['cpu_slope_s_per_h'])} | "
            f"{_fmt(m['fixed_s'], '.1f')}{'' if m['fixed_s'] is None else ' s'}"
            f"{'' if m['cpu_fixed_s'] is None else ' (' + format(m['cpu_fixed_s'], '.1f') + ' s)'} | "
            f"{m['vs_linear']:.2f} × |"
            for m in margins
        ]
    lines += ["", "![Wall time against log length](performance-scaling.png)"]
    _plot(rows)
    text = DOC.read_text()
    a, b = text.index("<!-- bench:start -->"), text.index("<!-- bench:end -->")
    DOC.write_text(text[:a] + "<!-- bench:start -->\n" + "\n".join(lines) + "\n" + text[b:])
    print(f"wrote {DOC}")


def _plot(rows: list[dict]) -> None:
    import plotly.graph_objects as go

    fig = go.Figure()
    for what in sorted({r["what"] for r in rows}):
        for mode, label, dash in (("warm", "", "solid"), ("job warm", " (job, warm worker)", "dash")):
            pts = sorted(
                (r["log_h"], r["wall_s"] if what != "ingest" else r["parse_s"] + r["store_s"], r["rate_hz"])
                for r in rows
                if r["what"] == what and r["mode"] == mode and r["ok"]
            )
            if pts:
                fig.add_trace(
                    go.Scatter(
                        x=[p[0] for p in pts],
                        y=[p[1] for p in pts],
                        mode="lines+markers",
                        name=what + label,
                        line={"dash": dash},
                        text=[f"{p[2]:g} Hz" for p in pts],
                    )
                )
    fig.update_layout(
        title="Warm wall time against log length (solid: fresh CLI process; dashed: job in a warm worker)",
        xaxis_title="log length (h)",
        yaxis_title="wall time (s)",
        width=800,
        height=480,
        template="plotly_white",
    )
    try:
        fig.write_image(str(PLOT))
    except Exception as exc:  # kaleido missing or no Chrome: a self-contained HTML instead
        html = PLOT.with_suffix(".html")
        fig.write_html(str(html), include_plotlyjs=True)
        print(f"no PNG ({exc}); wrote {html}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--hours", type=float, nargs="*", default=[1, 2, 4])
    ap.add_argument("--rate", type=float, default=100.0, help="IMU rate of the simulated logs (Hz)")
    ap.add_argument("--pipelines", nargs="*", default=["navigate", "gravity", "calibrate"])
    ap.add_argument("--no-cold", action="store_true", help="skip the cold (empty cache) runs")
    ap.add_argument("--repeat", type=int, default=1, help="warm runs per figure; the fastest is kept")
    ap.add_argument(
        "--load",
        action="store_true",
        help="also time loading the stored log back (the job side: "
        "load_s; the peak RSS then covers both, ingest_rss_mb the ingest alone)",
    )
    ap.add_argument(
        "--jobs",
        action="store_true",
        help="also the job rows: the stored log, two jobs per fresh worker process through JobRunner.execute",
    )
    ap.add_argument("--no-cli", action="store_true", help="skip the fresh-CLI-process rows of the pipelines")
    ap.add_argument("--doc", action="store_true", help="write docs/performance.md and the plot")
    ap.add_argument("--max-rss-gb", type=float, default=MAX_RSS_MB / 1024, help="stop a child above this RSS")
    ap.add_argument(
        "--numba-cache",
        default=None,
        help="numba cache directory of the warm runs (default: the installation's); warm it first, e.g. with one run",
    )
    a = ap.parse_args()
    globals()["MAX_RSS_MB"] = a.max_rss_gb * 1024
    if a.hours:
        bench(
            a.hours,
            a.rate,
            a.pipelines,
            cold=not a.no_cold,
            repeat=a.repeat,
            with_load=a.load,
            warm_cache=a.numba_cache,
            cli=not a.no_cli,
            jobs=a.jobs,
        )
    if a.doc:
        write_doc(load())


if __name__ == "__main__":
    main()
