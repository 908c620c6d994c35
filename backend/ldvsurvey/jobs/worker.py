"""Entry point of separate worker processes: ``huey_consumer ldvsurvey.jobs.worker.huey -w 2 -k thread``.

Settings come from the environment through :func:`ldvsurvey.settings.get_settings` (the same
``LDVSURVEY_*`` variables as the server: LDVSURVEY_DATABASE_URL, LDVSURVEY_REDIS_URL,
LDVSURVEY_DATA_DIR, LDVSURVEY_HEARTBEAT_S). ``huey`` is a module attribute only because
``huey_consumer`` looks it up by that dotted name; the runner itself holds no module state.
At start, unless ``scripts/setup.sh`` (``ldv-survey warmup``) already filled numba's cache for this
very code, the compiled core is warmed in a background thread so the first job does not pay it;
when it did, the pipelines' modules and libraries are imported here, before the first job comes.
"""

import logging

from ldvsurvey.jobs.runner import JobRunner
from ldvsurvey.pipelines.warmup import ready_for_jobs
from ldvsurvey.settings import get_settings
from ldvsurvey.store.db import upgrade_head


def make_runner(settings=None) -> JobRunner:
    """A runner on the settings' database (migrated to head first) and queue."""
    settings = settings or get_settings()
    url = settings.resolved_database_url()
    upgrade_head(url)
    return JobRunner(url, settings)


runner = make_runner()
huey = runner.huey
# the warm-up's thread when the cache is not warm (else the pipelines are imported now, before any job)
_warmup_thread = ready_for_jobs(log=logging.getLogger("ldvsurvey.warmup").info, wait=True)
