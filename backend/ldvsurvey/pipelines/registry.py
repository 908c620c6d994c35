"""All pipelines by name, and the ``ldv-survey run`` entry point.

The registry is lazy: a pipeline's module (and with it numba, scipy and the numerical core it
needs) is imported the first time that pipeline is looked up, so ``ldv-survey run height`` does not
pay for importing the dov or gravity pipelines. Iterating the names costs nothing; listing the
pipelines themselves (``values()``, ``items()``: ``GET /api/pipelines``, the warm-up) imports them all.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable, Iterator, Mapping

from ldvsurvey.errors import ParameterError

#: pipeline name -> module defining it as ``PIPELINE`` (in the order they are listed)
MODULES: dict[str, str] = {
    "calibrate": "ldvsurvey.pipelines.calibrate",
    "tilt": "ldvsurvey.pipelines.tilt",
    "height": "ldvsurvey.pipelines.height",
    "navigate": "ldvsurvey.pipelines.navigate",
    "gravity": "ldvsurvey.pipelines.gravity",
    "dov": "ldvsurvey.pipelines.dov",
    "damping": "ldvsurvey.pipelines.damping",
}


class _Registry(Mapping):
    """``{name: Pipeline}`` importing each pipeline's module on first access."""

    def __init__(self, modules: dict[str, str]):
        self._modules = modules
        self._loaded: dict = {}

    def __getitem__(self, name: str):
        p = self._loaded.get(name)
        if p is None:
            p = importlib.import_module(self._modules[name]).PIPELINE  # KeyError for an unknown name
            if p.name != name:
                raise RuntimeError(f"module {self._modules[name]} defines pipeline '{p.name}', registered as '{name}'")
            self._loaded[name] = p
        return p

    def __iter__(self) -> Iterator[str]:
        return iter(self._modules)

    def __len__(self) -> int:
        return len(self._modules)

    def __contains__(self, name) -> bool:
        return name in self._modules


PIPELINES: Mapping = _Registry(MODULES)


def get(name: str):
    """The :class:`~ldvsurvey.pipelines.base.Pipeline` called ``name`` (its module imported now)."""
    if name not in PIPELINES:
        raise ParameterError(f"unknown pipeline '{name}' (known: {', '.join(sorted(PIPELINES))})", field="PIPELINE")
    return PIPELINES[name]


def run_pipeline_cli(
    name: str, bundles: list[str], out: str, sets: list[str], open_grid_cache: Callable[[], object] | None = None
) -> int:
    """``ldv-survey run``: load the bundles, run, write summary.json and the CSV tables.

    Parameters
    ----------
    name : str
        The pipeline.
    bundles : list of str
        Bundle folders or zip files.
    out : str
        Folder for the result files.
    sets : list of str
        ``KEY=VALUE`` parameters.
    open_grid_cache : callable or None
        Opens the grid cache (``get(key)``, ``put(key, grid)``) a pipeline that
        :attr:`~ldvsurvey.pipelines.base.Pipeline.uses_grid_cache` keeps its grids in (the CLI
        passes the database's; the pipelines never open it themselves).

    Returns
    -------
    int
        The exit code (0).
    """
    import sys

    from ldvsurvey.io.drivelog import load_bundle
    from ldvsurvey.pipelines.base import LogFacts, Progress, parse_set_args, run_pipeline, write_result
    from ldvsurvey.pipelines.stages.grid_cache import GRID_CACHE

    pipe = get(name)
    # unknown, malformed or out-of-range parameters fail before any work; validated once, here
    params = pipe.validate(parse_set_args(sets))
    logs = [load_bundle(b) for b in bundles]
    pipe.check([LogFacts.of_log(log) for log in logs], params)  # and a pipeline that cannot apply

    def report(stage, frac):
        print(f"[{frac * 100:5.1f} %] {stage}", file=sys.stderr)

    opened = pipe.uses_grid_cache and open_grid_cache is not None
    token = GRID_CACHE.set(open_grid_cache()) if opened else None  # for this run only
    try:
        result = run_pipeline(pipe, logs, params, Progress(report))
    finally:
        if token is not None:
            GRID_CACHE.reset(token)
    for p in write_result(result, out):
        print(p)
    return 0
