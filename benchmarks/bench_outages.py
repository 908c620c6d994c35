"""Benchmark: position error after GNSS outages of 10, 30 and 60 s on a simulated INS/GNSS drive
without an LDV, against the simulator's truth, with the filter's own 1-σ beside each (forward filter,
as INS/GNSS papers and KF-GINS report it, and the RTS-smoothed solution). Prints a Markdown table
for docs/accuracy.md; asserts nothing.

Run: PYTHONPATH=backend:. .venv/bin/python benchmarks/bench_outages.py [--repeats 3]
"""

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from tests.pipelines.outages import GRADES, run_outages  # noqa: E402

LENGTHS = (10.0, 30.0, 60.0)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--repeats", type=int, default=3, help="outages of each length along the drive")
    ap.add_argument("--seed", type=int, default=1)
    args = ap.parse_args()
    lengths = [L for _ in range(args.repeats) for L in LENGTHS]
    print(
        "| IMU | solution | outage (s) | n | horizontal error RMS (max) (m) | filter 1-σ horizontal (m) "
        "| vertical error RMS (max) (m) | filter 1-σ vertical (m) |"
    )
    print("|---|---|---|---|---|---|---|---|")
    for grade in GRADES:
        for smooth in (False, True):
            out, elapsed, sc = run_outages(lengths, grade=grade, smooth=smooth, seed=args.seed)
            for L in LENGTHS:
                o = [x for x in out if x.length_s == L]
                h = np.array([x.horizontal_m for x in o])
                v = np.array([abs(x.vertical_m) for x in o])
                sh = np.sqrt(np.mean([x.horizontal_sigma_m**2 for x in o]))
                sv = np.sqrt(np.mean([x.vertical_sigma_m**2 for x in o]))
                print(
                    f"| {grade} | {'RTS smoothed' if smooth else 'forward filter'} | {L:.0f} | {len(o)} "
                    f"| {np.sqrt(np.mean(h**2)):.3f} ({h.max():.3f}) | {sh:.3f} "
                    f"| {np.sqrt(np.mean(v**2)):.3f} ({v.max():.3f}) | {sv:.3f} |"
                )
            print(
                f"<!-- {grade}, smooth={smooth}: {sc.t0_s:.0f}+, drive {len(lengths)} outages, navigate "
                f"{elapsed:.1f} s wall -->",
                file=sys.stderr,
            )


if __name__ == "__main__":
    main()
