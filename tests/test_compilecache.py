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


def test_blas_preloaded_alone_serves_numba_and_a_later_scipy_linalg(tmp_path):
    """compilecache.preload_blas: numba's BLAS (a matrix product) and LAPACK (a solve) calls run on
    the modules loaded alone, with the numbers of numpy's own; scipy.linalg imported afterwards works
    and finds the same modules (no second copy)."""
    code = (
        "import sys, numpy as np\n"
        "from ldvsurvey import compilecache\n"
        "assert compilecache.preload_blas()\n"
        "assert 'scipy.linalg' not in sys.modules\n"
        "blas = sys.modules['scipy.linalg.cython_blas']\n"
        "import numba\n"
        "@numba.njit\n"
        "def f(a, b):\n"
        "    return a @ b, np.linalg.solve(a, b)\n"
        "rng = np.random.default_rng(1)\n"
        "a, b = rng.normal(size=(20, 20)) + 20 * np.eye(20), rng.normal(size=(20, 3))\n"
        "p, x = f(a, b)\n"
        "assert 'scipy.linalg' not in sys.modules\n"
        "assert np.allclose(p, a @ b, rtol=1e-14, atol=1e-14) and np.allclose(a @ x, b, atol=1e-12)\n"
        "import scipy.linalg\n"
        "from scipy.linalg import cython_blas\n"
        "assert cython_blas is blas and np.allclose(scipy.linalg.solve(a, b), x, atol=1e-12)\n"
        "print('ok')\n"
    )
    env = {**os.environ, "PYTHONPATH": str(BACKEND), compilecache.ENV: str(tmp_path)}
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True)
    assert out.returncode == 0, out.stderr[-2000:]
    assert out.stdout.strip() == "ok"
