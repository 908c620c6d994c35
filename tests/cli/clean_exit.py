"""The CLI runs of the clean-exit test (``tests/cli/test_clean_exit.py``) and of its stress tool
(``benchmarks/exit_stress.py``): one ``import`` per kind of real recording, and what counts as the
product's own output on stderr.

The product writes to stderr only lines of its own making: ``error: <message>`` (exit 2) and
``warning: <message>`` (each warning of an import or validation). Anything else there (a library's
``nanobind: leaked …`` report, ``terminate called without an active exception``, ``Fatal Python
error``, a ``Traceback``, a Python warning ``…: DeprecationWarning: …``) is foreign: the user did not
ask for it and cannot act on it.
"""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
REAL = ROOT / "tests" / "fixtures" / "real"
EXAMPLES = ROOT / "docs" / "examples"

#: the product's own stderr lines: ``error: …`` and ``warning: …`` (see the CLI's main)
OWN_LINE = re.compile(r"^(error|warning): \S")
#: foreign lines by what they are, to name them in counts (any other line not of OWN_LINE is "other")
FOREIGN_KINDS = {
    "nanobind leak report": re.compile(r"nanobind|leaked |skipped remainder|refleaks"),
    "std::terminate (SIGABRT)": re.compile(r"terminate called"),
    "fatal Python error": re.compile(r"Fatal Python error"),
    "traceback": re.compile(r"Traceback|^\s+File \""),
    "Python warning": re.compile(r"\w+Warning: "),
}

#: the ubx manifest: the NEO-M8U's axes, and its accelerometer's 2.3 % scale error accepted
UBX_PARTIAL = {"initial": {"static_s": 2.0}, "import": {"imu": {"axes": "FLU", "static_gravity_tolerance": 0.03}}}


def cases(work: Path) -> dict[str, list[str]]:
    """``ldv-survey import`` arguments per kind of recording, the bundle written under ``work``
    (``<kind>.zip`` when the import succeeds).

    Real recordings where the repository has them (NovAtel ASCII and binary, NMEA, u-blox, RTKLIB);
    the KF-GINS text example of ``docs/examples`` (no real KF-GINS file is kept). The NovAtel logs of
    ``tests/fixtures/real/novatel`` hold no raw IMU messages the import can use: they are refused
    (exit 2), which is what a NovAtel import of them must do, cleanly. ``docs/examples/novatel/span.log``
    (RAWIMUSX and BESTGNSSPOS) is the NovAtel import that succeeds.
    """
    work.mkdir(parents=True, exist_ok=True)
    (work / "ubx.json").write_text(json.dumps(UBX_PARTIAL))
    real_ex = EXAMPLES / "real"
    span = EXAMPLES / "novatel" / "span.log"
    return {
        "novatel-ascii": [
            *("--imu", f"novatel:{span}", "--gnss", f"novatel:{span}", "--ldv", f"native:{EXAMPLES / 'ldv.csv'}"),
            *("--manifest", str(EXAMPLES / "partial.json")),
        ],
        "novatel-ascii-real": [
            *("--imu", f"novatel:{REAL / 'novatel' / 'edie-test-logs.asc'}", "--manifest", str(work / "ubx.json")),
        ],
        "novatel-binary-real": [
            *("--imu", f"novatel:{REAL / 'novatel' / 'oem7-driver-ins2-imuratecorrimus.gps'}"),
            *("--manifest", str(work / "ubx.json")),
        ],
        "nmea": [
            *("--imu", f"kf-gins:{real_ex / 'telit-imu.txt'}", "--gnss", f"nmea:{real_ex / 'telit-he910.nmea'}"),
            *("--ldv", f"native:{real_ex / 'telit-ldv.csv'}", "--manifest", str(real_ex / "telit-partial.json")),
        ],
        "ubx": [
            *("--imu", f"ubx:{REAL / 'ublox-neo-m8u.log'}", "--gnss", f"ubx:{REAL / 'ublox-neo-m8u.log'}"),
            *("--manifest", str(work / "ubx.json")),
        ],
        "rtklib": [
            *("--imu", f"kf-gins:{real_ex / 'rtklib-imu.txt'}", "--gnss", f"rtklib:{real_ex / 'rtklib-demo5.pos'}"),
            *("--ldv", f"native:{real_ex / 'rtklib-ldv.csv'}", "--manifest", str(real_ex / "rtklib-partial.json")),
        ],
        "kf-gins": [
            *("--imu", f"kf-gins:{EXAMPLES / 'kf-gins' / 'imu.txt'}"),
            *("--gnss", f"kf-gins:{EXAMPLES / 'kf-gins' / 'gnss.txt'}", "--manifest", str(EXAMPLES / "partial.json")),
        ],
    }


def cli(args: list[str], timeout_s: float = 120.0, **kw) -> subprocess.CompletedProcess:
    """``ldv-survey ARGS`` as a process of its own (``python -m ldvsurvey.cli``, this checkout's backend)."""
    env = {**os.environ, "PYTHONPATH": str(ROOT / "backend")}
    env.pop("PYTHONWARNINGS", None)  # the user's default: warnings as Python shows them
    return subprocess.run(
        [sys.executable, "-m", "ldvsurvey.cli", *args], env=env, capture_output=True, text=True, timeout=timeout_s, **kw
    )


def foreign_lines(stderr: str) -> list[str]:
    """The lines of ``stderr`` that are not the product's own (:data:`OWN_LINE`), empty lines included."""
    return [ln for ln in stderr.splitlines() if not OWN_LINE.match(ln)]


def foreign_kind(line: str) -> str:
    """What a foreign stderr line is (a key of :data:`FOREIGN_KINDS`, else ``other``)."""
    return next((k for k, rx in FOREIGN_KINDS.items() if rx.search(line)), "other")
