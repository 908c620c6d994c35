"""Where the compiled core is cached: a folder keyed by the core's source, the same in child processes.

numba invalidates a cached function only when its own file changes, not when a function it inlines
from another file does; the key folder makes any change of the compiled core's source a fresh cache.
"""

import os
import shutil
import subprocess
import sys
from pathlib import Path

from ldvsurvey import compilecache

BACKEND = Path(__file__).resolve().parents[1] / "backend"


def _cache_dir_in_child(env: dict, backend: Path = BACKEND) -> str:
    code = "import ldvsurvey, os; print(os.environ['NUMBA_CACHE_DIR'])"
    env = {**env, "PYTHONPATH": str(backend)}
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True)
    return out.stdout.strip()


def test_the_folder_is_the_base_plus_the_key_of_the_core_source(tmp_path):
    env = {k: v for k, v in os.environ.items() if k not in ("NUMBA_CACHE_DIR", compilecache.ENV)}
    env[compilecache.ENV] = str(tmp_path)
    got = _cache_dir_in_child(env)
    assert Path(got).parent == tmp_path.resolve()
    assert Path(got).name == f"core-{compilecache.code_key()}"
    # a child of that process inherits NUMBA_CACHE_DIR (pointing at the core folder): no nesting
    env2 = {k: v for k, v in env.items() if k != compilecache.ENV}
    env2["NUMBA_CACHE_DIR"] = got
    assert _cache_dir_in_child(env2) == got


def test_a_change_of_an_inlined_function_s_file_changes_the_folder(tmp_path):
    """A copy of the package whose nav/attitude.py differs by one byte gets another folder; a file
    outside the compiled core (the API) does not change it."""
    pkg = tmp_path / "backend" / "ldvsurvey"
    shutil.copytree(BACKEND / "ldvsurvey", pkg, ignore=shutil.ignore_patterns("__pycache__"))
    env = {k: v for k, v in os.environ.items() if k != "NUMBA_CACHE_DIR"}
    env[compilecache.ENV] = str(tmp_path / "cache")
    before = _cache_dir_in_child(env, pkg.parent)
    assert Path(before).name == f"core-{compilecache.code_key()}"  # same source, same key
    (pkg / "api" / "app.py").write_text((pkg / "api" / "app.py").read_text() + "\n# not compiled\n")
    assert _cache_dir_in_child(env, pkg.parent) == before
    (pkg / "nav" / "attitude.py").write_text((pkg / "nav" / "attitude.py").read_text() + "\n")
    after = _cache_dir_in_child(env, pkg.parent)
    assert after != before and Path(after).parent == Path(before).parent
