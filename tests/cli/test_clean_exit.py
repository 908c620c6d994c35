"""``ldv-survey import`` and ``validate`` as processes of their own, once per kind of recording (issue 35): the
exit code is 0 or 2 (never 1, never a signal) and stderr holds nothing but the product's own ``error:`` and
``warning:`` lines (``tests/cli/clean_exit.py`` defines the cases and the lines). A NovAtel import used to end
with a page of ``nanobind: leaked ...`` lines. A rare abort at teardown (once in a few hundred runs under load)
is not for one run to see: ``benchmarks/exit_stress.py`` repeats these runs and counts.
"""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor

import pytest

from ldvsurvey import __version__
from tests.cli.clean_exit import cases, cli, foreign_lines

pytest.importorskip("novatel_edie")

#: the exit code each case must end with: the NovAtel fixtures hold no raw IMU message (refused, 2)
EXPECTED = {"novatel-ascii-real": 2, "novatel-binary-real": 2}


def _import_then_validate(name: str, args: list[str], work) -> list[tuple[str, int, str]]:
    """(command, exit code, stderr) of the import of one case and, when it wrote the bundle, its validation;
    what they print on stdout must have reached the pipe (the process ends without the interpreter's flush)."""
    out = work / f"{name}.zip"
    p = cli(["import", *args, "--out", str(out)])
    runs = [(f"{name} import", p.returncode, p.stderr)]
    if p.returncode == 0:
        assert out.is_file(), f"{name}: exit 0 without a bundle"
        assert p.stdout.startswith(f"{out}: ") and "check: IMU rate" in p.stdout, p.stdout
        v = cli(["validate", str(out)])
        assert v.stdout.startswith(f"{out}: valid "), v.stdout
        runs.append((f"{name} validate", v.returncode, v.stderr))
    else:
        assert not out.exists(), f"{name}: refused but wrote {out}"
    return runs


def test_every_kind_of_recording_imports_and_validates_with_a_clean_exit(tmp_path):
    todo = cases(tmp_path)
    with ThreadPoolExecutor(max_workers=2) as pool:  # two processes at a time: a few seconds each
        done = list(pool.map(lambda kv: _import_then_validate(*kv, tmp_path), todo.items()))
    runs = [r for case in done for r in case]
    assert {cmd.split()[0] for cmd, _, _ in runs} == set(todo)
    problems = []
    for cmd, rc, err in runs:
        want = EXPECTED.get(cmd.split()[0], 0) if cmd.endswith("import") else 0
        if rc != want:
            problems.append(f"{cmd}: exit {rc}, expected {want}\n{err[-2000:]}")
        foreign = foreign_lines(err)
        if foreign:
            problems.append(f"{cmd}: {len(foreign)} foreign stderr line(s), the first: {foreign[:3]}")
    assert not problems, "\n".join(problems)
    # the refusals said why, as the product's own error line
    refused = {cmd: err for cmd, rc, err in runs if rc == 2}
    assert "only corrected ones: 766 IMURATECORRIMUS" in refused["novatel-binary-real import"]
    assert all(err.startswith("error: ") for err in refused.values())


def test_the_exit_code_of_argparse_and_of_a_refusal_survive_the_deterministic_exit(tmp_path):
    """--version prints and exits 0, an unknown command is a usage error (2), a missing file a refusal (2)."""
    v = cli(["--version"])
    assert (v.returncode, v.stdout.strip(), v.stderr) == (0, f"ldv-survey {__version__}", "")
    u = cli(["no-such-command"])
    assert u.returncode == 2 and "invalid choice" in u.stderr
    m = cli(["validate", str(tmp_path / "missing.zip")])
    assert m.returncode == 2 and m.stderr.startswith("error: ") and not foreign_lines(m.stderr)
