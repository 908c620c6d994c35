"""Run ``ldv-survey`` as a process of its own (``main()`` reading ``sys.argv``, as the installed
command does) and see what it loaded."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

BACKEND = Path(__file__).resolve().parents[2] / "backend"


def run_own_process(argv: list[str]) -> tuple[int, set[str]]:
    """``ldv-survey ARGV`` in a fresh interpreter: main's return code and the modules then loaded."""
    code = (
        "import sys, json\n"
        "from ldvsurvey.cli import main\n"
        f"sys.argv = ['ldv-survey'] + {list(argv)!r}\n"
        "rc = main()\n"
        "print(json.dumps({'rc': rc, 'modules': sorted(sys.modules)}))\n"
    )
    env = {**os.environ, "PYTHONPATH": str(BACKEND)}
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True)
    got = json.loads(out.stdout.strip().splitlines()[-1])
    return got["rc"], set(got["modules"])
