"""A job's stored results read for the views and reports: the one place they meet the database."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from fastapi import HTTPException
from sqlalchemy.orm import Session

from ldvsurvey.api.views import MissingResult, read_csv_bytes
from ldvsurvey.store.jobs import result_file
from ldvsurvey.store.models import Job


def job_file(session: Session, job_id: int, name: str) -> bytes:
    """The bytes of a job's result file; 404 naming it when the job has none of that name."""
    f = result_file(session, job_id, name)
    if f is None:
        raise HTTPException(404, f"job {job_id} has no file '{name}'")
    return f.content


@dataclass
class JobTables:
    """:class:`ldvsurvey.api.views.Tables` of a stored job: its result CSVs and its first log's arrays
    (each read once)."""

    session: Session
    job: Job
    _cache: dict = field(default_factory=dict)

    def csv(self, name: str) -> dict[str, np.ndarray]:
        """The columns of the job's result CSV ``name`` (:class:`MissingResult` when it has none)."""
        if name not in self._cache:
            f = result_file(self.session, self.job.id, name)
            if f is None:
                raise MissingResult(f"job {self.job.id} has no file '{name}'")
            self._cache[name] = read_csv_bytes(f.content)
        return self._cache[name]

    def log_array(self, name: str) -> dict[str, np.ndarray] | None:
        """The columns of the stored array ``name`` (``imu``, ``ldv``, ``gnss``) of the job's first log, or None."""
        from ldvsurvey.store.logs import load_array

        key = ("log", name)
        if key not in self._cache:
            self._cache[key] = load_array(self.session, self.job.log_ids[0], name) if self.job.log_ids else None
        return self._cache[key]
