"""The code's shape, kept (issue 30): measured with Python's ``ast`` over ``backend/ldvsurvey``.

* no function over 100 lines, numba-compiled loops over 150;
* no function with more than 8 positional parameters (``self``/``cls`` not counted; options after
  ``*`` are keyword-only and free), compiled ones included: they take small NamedTuple structs;
* at most 5 % of the public functions (module level and public methods of public classes) without
  a docstring;
* nothing below the job layer (``nav``, ``io``, ``sim``, ``pipelines``) imports ``ldvsurvey.store``
  (docs/architecture.md: pipelines never touch the database; grids come through an injected reader).

Each rule is also checked against a small synthetic module, so that a broken counter cannot pass.
"""

from __future__ import annotations

import ast
import pathlib

import pytest

PACKAGE = pathlib.Path(__file__).resolve().parents[1] / "backend" / "ldvsurvey"
MAX_LINES, MAX_LINES_COMPILED, MAX_POSITIONAL, MAX_UNDOCUMENTED = 100, 150, 8, 0.05
BELOW_JOBS = ("nav", "io", "sim", "pipelines")


def _compiled(fn: ast.FunctionDef) -> bool:
    return any("jit" in ast.unparse(d) for d in fn.decorator_list)


def _functions(tree: ast.Module):
    return [n for n in ast.walk(tree) if isinstance(n, (ast.FunctionDef, ast.AsyncFunctionDef))]


def long_functions(tree: ast.Module, where: str) -> list[str]:
    """Functions longer than the limit, as ``where:line name (n lines)``."""
    out = []
    for fn in _functions(tree):
        n = fn.end_lineno - fn.lineno + 1
        if n > (MAX_LINES_COMPILED if _compiled(fn) else MAX_LINES):
            out.append(f"{where}:{fn.lineno} {fn.name} ({n} lines)")
    return out


def positional_heavy(tree: ast.Module, where: str) -> list[str]:
    """Functions with more than the limit of positional parameters."""
    out = []
    for fn in _functions(tree):
        args = fn.args.posonlyargs + fn.args.args
        n = len(args) - (1 if args and args[0].arg in ("self", "cls") else 0)
        if n > MAX_POSITIONAL:
            out.append(f"{where}:{fn.lineno} {fn.name} ({n} positional)")
    return out


def public_functions(tree: ast.Module, where: str) -> list[tuple[str, bool]]:
    """(name, documented) for each public function and public method of a public class."""
    out = []

    def visit(body, prefix):
        for node in body:
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)) and not node.name.startswith("_"):
                out.append((f"{where}:{node.lineno} {prefix}{node.name}", bool(ast.get_docstring(node))))
            elif isinstance(node, ast.ClassDef) and not node.name.startswith("_"):
                visit(node.body, node.name + ".")

    visit(tree.body, "")
    return out


def store_imports(tree: ast.Module, where: str, layer: str) -> list[str]:
    """Imports of ``ldvsurvey.store`` in a module of a layer below the jobs."""
    if layer not in BELOW_JOBS:
        return []
    out = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            names = [node.module or ""] if not node.level else []
            if node.level and layer and (node.module or "").split(".")[0] == "store":
                names = ["ldvsurvey.store"]
        else:
            continue
        if any(n == "ldvsurvey.store" or n.startswith("ldvsurvey.store.") for n in names):
            out.append(f"{where}:{node.lineno}")
    return out


def _modules():
    for path in sorted(PACKAGE.rglob("*.py")):
        rel = path.relative_to(PACKAGE)
        layer = rel.parts[0] if len(rel.parts) > 1 else ""
        yield str(rel), layer, ast.parse(path.read_text(encoding="utf-8"))


MODULES = list(_modules())


def test_no_long_functions():
    found = [f for where, _, tree in MODULES for f in long_functions(tree, where)]
    assert not found, "split at named stages:\n" + "\n".join(found)


def test_no_function_takes_more_than_eight_positional_parameters():
    found = [f for where, _, tree in MODULES for f in positional_heavy(tree, where)]
    assert not found, "group into structs or make options keyword-only:\n" + "\n".join(found)


def test_public_functions_are_documented():
    funcs = [f for where, _, tree in MODULES for f in public_functions(tree, where)]
    missing = [name for name, documented in funcs if not documented]
    assert len(funcs) > 300  # the walk found the package
    assert len(missing) <= MAX_UNDOCUMENTED * len(funcs), (
        f"{len(missing)} of {len(funcs)} public functions without a docstring:\n" + "\n".join(missing)
    )


def test_nothing_below_the_jobs_imports_the_store():
    found = [f for where, layer, tree in MODULES for f in store_imports(tree, where, layer)]
    assert not found, "inject a reader from the job/CLI layer instead:\n" + "\n".join(found)


SYNTHETIC = (
    '''
import numba as nb
from ldvsurvey.store.db import upgrade_head
from ..store import blobs


def documented(a, b, *, c=1):
    """Yes."""


def bare(a, b, c, d, e, f, g, h, i):
    pass


class Thing:
    def method(self, a, b, c, d, e, f, g, h):
        """Eight, self not counted."""

    def _private(self):
        pass


@nb.njit(cache=True)
def loop(x):
'''
    + "    x += 1\n" * 120
)


@pytest.mark.parametrize("layer", ["pipelines", "api"])
def test_the_counters_count(layer):
    """The rules on a module built to break each of them once (and to pass where it should)."""
    tree = ast.parse(SYNTHETIC)
    assert long_functions(tree, "m") == []  # 121 lines, compiled: within 150
    tree_long = ast.parse(SYNTHETIC.replace("@nb.njit(cache=True)\n", ""))
    assert [f.split()[1] for f in long_functions(tree_long, "m")] == ["loop"]
    assert [f.split()[1] for f in positional_heavy(tree, "m")] == ["bare"]
    assert public_functions(tree, "m") == [
        ("m:7 documented", True),
        ("m:11 bare", False),
        ("m:16 Thing.method", True),
        ("m:24 loop", False),
    ]
    assert len(store_imports(tree, "m", layer)) == (2 if layer == "pipelines" else 0)
