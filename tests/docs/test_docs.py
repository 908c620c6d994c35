"""The documentation stays true: its shell examples run, its links stay inside the repository,
and every pipeline parameter of the code is documented with its default."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

from tests.helpers.server import free_port

ROOT = Path(__file__).resolve().parents[2]
DOCS = ROOT / "docs"
PAGES = sorted(DOCS.rglob("*.md")) + [ROOT / "README.md"]
FENCE = re.compile(r"^```([^\n`]*)\n(.*?)^```", re.S | re.M)
LINK = re.compile(r"(?<!!)\[[^\]]*\]\(([^)\s]+)(?:\s+\"[^\"]*\")?\)|<(https?://[^>]+)>")


def shell_blocks(page: Path) -> list[str]:
    return [body for info, body in FENCE.findall(page.read_text()) if info.strip().split() == ["sh", "test"]]


@pytest.mark.parametrize("page", [p for p in PAGES if shell_blocks(p)], ids=lambda p: p.name)
def test_shell_examples_run(page, tmp_path):
    """Each page's ``sh test`` blocks run in order in one shell, in a scratch folder that sees docs/."""
    (tmp_path / "docs").symlink_to(DOCS)
    bindir = tmp_path / ".bin"
    bindir.mkdir()
    wrapper = bindir / "ldv-survey"
    wrapper.write_text(f'#!/bin/sh\nexec "{sys.executable}" -m ldvsurvey.cli "$@"\n')
    wrapper.chmod(0o755)
    env = {
        **os.environ,
        "PATH": f"{bindir}:{os.environ.get('PATH', '')}",
        "PYTHONPATH": str(ROOT / "backend"),
        "PORT": str(free_port()),
        "LDVSURVEY_DATA_DIR": str(tmp_path / "data"),
    }
    for k in ("LDVSURVEY_DATABASE_URL", "LDVSURVEY_REDIS_URL"):
        env.pop(k, None)
    script = "set -euo pipefail\n" + "\n".join(shell_blocks(page))
    r = subprocess.run(["bash", "-c", script], cwd=tmp_path, env=env, capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, f"{page.name} examples failed:\nSTDOUT:\n{r.stdout[-3000:]}\nSTDERR:\n{r.stderr[-3000:]}"


def _slug(heading: str) -> str:
    s = heading.strip().lower()
    s = re.sub(r"[^\w\- ]", "", s)
    return s.replace(" ", "-")


def _anchors(page: Path) -> set[str]:
    text = FENCE.sub("", page.read_text())
    return {_slug(m) for m in re.findall(r"^#+\s+(.*)$", text, re.M)}


@pytest.mark.parametrize("page", PAGES, ids=lambda p: str(p.relative_to(ROOT)))
def test_links_stay_inside_the_repository(page):
    text = FENCE.sub("", page.read_text())
    for m in LINK.finditer(text):
        target = m.group(1) or m.group(2)
        assert not re.match(r"^[a-z][a-z0-9+.-]*:", target, re.I), f"{page.name}: link leaves the repository: {target}"
        assert not target.startswith("/"), f"{page.name}: absolute path: {target}"
        path, _, anchor = target.partition("#")
        dest = (page.parent / path).resolve() if path else page
        assert dest == ROOT or ROOT in dest.parents, f"{page.name}: link points outside the repository: {target}"
        assert dest.exists(), f"{page.name}: broken link: {target}"
        if anchor and dest.suffix == ".md":
            assert anchor in _anchors(dest), f"{page.name}: no heading for #{anchor} in {dest.name}"


def test_every_pipeline_parameter_is_documented_with_its_default():
    from ldvsurvey.pipelines.registry import PIPELINES

    text = (DOCS / "pipelines.md").read_text()
    sections = re.split(r"^## ", text, flags=re.M)
    by_name = {s.split("\n", 1)[0].strip(): s for s in sections}
    for pipe in PIPELINES.values():
        assert pipe.name in by_name, f"pipelines.md has no section for {pipe.name}"
        sec = by_name[pipe.name]
        for p in pipe.params:
            row = re.search(rf"^\| `{re.escape(p.name)}` \| ([^|]+) \|", sec, re.M)
            assert row, f"{pipe.name}: parameter {p.name} not documented"
            assert row.group(1).strip() == str(p.default), (
                f"{pipe.name}.{p.name}: documented default {row.group(1).strip()!r}, code {p.default!r}"
            )


def test_the_link_check_itself_catches_bad_links(tmp_path):
    """The checker is not vacuous: an outside link and a broken one are found."""
    bad = "[a](../../shared/spec.md) [b](https://example.org) [c](missing.md)"
    found = [m.group(1) or m.group(2) for m in LINK.finditer(bad)]
    assert found == ["../../shared/spec.md", "https://example.org", "missing.md"]
