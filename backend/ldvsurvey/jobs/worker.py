"""Entry point of separate worker processes: ``huey_consumer ldvsurvey.jobs.worker.huey -w 2 -k thread``.

Settings come from the environment (LDVSURVEY_DATABASE_URL, LDVSURVEY_REDIS_URL, LDVSURVEY_DATA_DIR).
"""

from ldvsurvey.jobs import runner
from ldvsurvey.settings import get_settings
from ldvsurvey.store.db import upgrade_head

_settings = get_settings()
_url = _settings.resolved_database_url()
upgrade_head(_url)
huey = runner.configure(_url, _settings)
