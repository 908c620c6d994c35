"""Stress tool: run ``ldv-survey import`` (and ``validate`` of what it wrote) hundreds of times, in
parallel loops beside busy CPU burners, and count how each process ended.

A process must end with exit code 0 or 2 and nothing on stderr but the product's own ``error:`` /
``warning:`` lines (``tests/cli/clean_exit.py`` defines the cases and the lines). A rare abort at
interpreter exit (a native thread pool torn down while the interpreter finalises) shows only under
load, once in a few hundred runs: this tool is its reproduction; the test suite runs each case once.

Prints, per case: runs, exit codes, runs with foreign stderr lines by kind, and the first line of each
kind; asserts nothing. Bounded by ``--runs`` and ``--max-s``. With ``--cores DIR`` the processes may dump
core there (``ulimit -c``; the kernel's ``core_pattern`` must be a plain file name) for ``gdb``.

Run: PYTHONPATH=backend .venv/bin/python benchmarks/exit_stress.py [--runs 300] [--loops 2] [--burn 1]
     [--cases nmea,ubx,novatel-ascii] [--max-s 900] [--cores /tmp/cores]
"""

from __future__ import annotations

import argparse
import collections
import multiprocessing
import os
import resource
import sys
import tempfile
import threading
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from tests.cli.clean_exit import cases, cli, foreign_kind, foreign_lines  # noqa: E402


def _burn(stop_at: float) -> None:
    """Keep one CPU busy until ``stop_at`` (time.time())."""
    x = 0
    while time.time() < stop_at:
        for _ in range(100_000):
            x += 1


def _one(name: str, args: list[str], out: Path, core_dir: Path | None) -> list[tuple[str, int, list[str]]]:
    """One import of a case (and one validate of its bundle when written): (command, exit code, foreign lines)."""

    def allow_core():
        resource.setrlimit(resource.RLIMIT_CORE, (resource.RLIM_INFINITY, resource.RLIM_INFINITY))

    kw = {"cwd": str(core_dir), "preexec_fn": allow_core} if core_dir else {}
    zip_path = out / f"{name}-{threading.get_ident()}.zip"
    p = cli(["import", *args, "--out", str(zip_path)], **kw)
    done = [("import", p.returncode, foreign_lines(p.stderr))]
    if p.returncode == 0 and zip_path.exists():
        v = cli(["validate", str(zip_path)], **kw)
        done.append(("validate", v.returncode, foreign_lines(v.stderr)))
    return done


def main() -> None:
    """Parse the options, run the loops, print the counts."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=300, help="imports in all (each case in turn)")
    ap.add_argument("--loops", type=int, default=2, help="parallel loops")
    ap.add_argument("--burn", type=int, default=1, help="busy CPU processes beside the loops")
    ap.add_argument("--cases", default="nmea,ubx,novatel-ascii", help="comma-separated case names")
    ap.add_argument("--max-s", type=float, default=900.0, help="stop starting runs after this many seconds")
    ap.add_argument("--cores", default=None, help="folder where an aborting process may dump core")
    opt = ap.parse_args()
    work = Path(tempfile.mkdtemp(prefix="exit-stress-"))
    all_cases = cases(work)
    names = [n.strip() for n in opt.cases.split(",") if n.strip()]
    unknown = [n for n in names if n not in all_cases]
    if unknown:
        sys.exit(f"unknown case(s) {unknown}; known: {', '.join(all_cases)}")
    core_dir = Path(opt.cores) if opt.cores else None
    if core_dir:
        core_dir.mkdir(parents=True, exist_ok=True)
    t0 = time.time()
    stop_at = t0 + opt.max_s
    burners = [multiprocessing.Process(target=_burn, args=(stop_at,), daemon=True) for _ in range(opt.burn)]
    for b in burners:
        b.start()
    todo = collections.deque(names[k % len(names)] for k in range(opt.runs))
    lock = threading.Lock()
    codes: dict = collections.defaultdict(collections.Counter)
    kinds: dict = collections.defaultdict(collections.Counter)
    first: dict = {}

    def loop():
        while time.time() < stop_at:
            with lock:
                if not todo:
                    return
                name = todo.popleft()
            for cmd, rc, lines in _one(name, all_cases[name], work, core_dir):
                key = f"{name} {cmd}"
                with lock:
                    codes[key][rc] += 1
                    for kind in sorted({foreign_kind(ln) for ln in lines}):
                        kinds[key][kind] += 1
                        first.setdefault((key, kind), next(ln for ln in lines if foreign_kind(ln) == kind))

    threads = [threading.Thread(target=loop) for _ in range(opt.loops)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    for b in burners:
        b.terminate()
    elapsed = time.time() - t0
    total = sum(sum(c.values()) for c in codes.values())
    bad_rc = sum(n for c in codes.values() for rc, n in c.items() if rc not in (0, 2))
    dirty = sum(sum(k.values()) for k in kinds.values())
    print(f"{total} processes in {elapsed:.0f} s ({opt.loops} loops, {opt.burn} CPU burner(s), {os.cpu_count()} CPUs)")
    print(f"exit code not 0 or 2: {bad_rc}; runs with foreign stderr lines (counted per kind): {dirty}")
    for key in sorted(codes):
        rcs = ", ".join(f"rc {rc}: {n}" for rc, n in sorted(codes[key].items()))
        fk = "; ".join(f"{k}: {n}" for k, n in sorted(kinds[key].items())) or "none"
        print(f"  {key}: {rcs}; foreign stderr: {fk}")
        for k in sorted(kinds[key]):
            print(f"      first {k!r}: {first[(key, k)][:160]}")
    if core_dir:
        cores = sorted(p.name for p in core_dir.iterdir() if p.name.startswith("core"))
        print(f"core files in {core_dir}: {cores or 'none'}")


if __name__ == "__main__":
    main()
