"""The huey transport: SqliteHuey in the data directory by default, RedisHuey with LDVSURVEY_REDIS_URL."""

from __future__ import annotations

from huey import RedisHuey, SqliteHuey


def make_huey(settings):
    """The job queue of these settings: a RedisHuey on ``settings.redis_url`` when set, else a SqliteHuey
    in ``settings.data_dir/huey.db`` (the folder made if missing); results are not kept in the queue."""
    if settings.redis_url:
        from redis import ConnectionPool

        return RedisHuey("ldvsurvey", connection_pool=ConnectionPool.from_url(settings.redis_url), results=False)
    settings.data_dir.mkdir(parents=True, exist_ok=True)
    return SqliteHuey("ldvsurvey", filename=str(settings.data_dir / "huey.db"), results=False, fsync=False, timeout=30)
