"""Entry point of separate worker processes: ``huey_consumer ldvsurvey.jobs.worker.huey -w 2 -k thread``.

Settings come from the environment (LDVSURVEY_DATABASE_URL, LDVSURVEY_REDIS_URL, LDVSURVEY_DATA_DIR).
At start, unless ``scripts/setup.sh`` (``ldv-survey warmup``) already filled numba's cache for this
very code, the compiled core is warmed in a background thread so the first job does not pay it.
"""

import logging

from ldvsurvey.jobs import runner
from ldvsurvey.pipelines.warmup import start_background_warmup
from ldvsurvey.settings import get_settings
from ldvsurvey.store.db import upgrade_head

_settings = get_settings()
_url = _settings.resolved_database_url()
upgrade_head(_url)
huey = runner.configure(_url, _settings)
_warmup_thread = start_background_warmup(log=logging.getLogger("ldvsurvey.warmup").info)
