"""The DOV grid cache a caller may provide to the pipelines, as a context variable.

The job runner sets it (the store's database cache) around every job, and ``ldv-survey run`` (the
CLI opens the database's cache and :func:`ldvsurvey.pipelines.registry.run_pipeline_cli` sets it)
around a pipeline that declares ``uses_grid_cache``; :mod:`ldvsurvey.pipelines.dov` and
:mod:`ldvsurvey.pipelines.stages.plumb_line` read it, so no pipeline opens the database itself. It
lives in this module of its own, which imports nothing heavy, so that setting it does not import the
``dov`` pipeline (and its numerical core) into a worker whose job does not need it.
"""

from __future__ import annotations

import contextvars

#: a grid cache the caller may provide (the store's database cache); get(key) -> DovGrid | None, put(key, grid)
GRID_CACHE: contextvars.ContextVar = contextvars.ContextVar("dov_grid_cache", default=None)
