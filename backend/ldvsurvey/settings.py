"""Application settings: one pydantic-settings class, environment prefix ``LDVSURVEY_``."""

from __future__ import annotations

import re
from functools import lru_cache
from pathlib import Path

from pydantic import field_validator
from pydantic_settings import BaseSettings, SettingsConfigDict

#: a raster tile URL: http(s), a host, and the {z}, {x}, {y} placeholders; nothing that could break
#: out of the Content-Security-Policy it is written into (no spaces, quotes, semicolons or commas)
TILE_URL = re.compile(r"https?://[A-Za-z0-9.\-]+(:\d{1,5})?/[^\s'\";,]*")


class Settings(BaseSettings):
    """All settings, read from ``LDVSURVEY_*`` environment variables."""

    model_config = SettingsConfigDict(env_prefix="LDVSURVEY_", extra="ignore")

    data_dir: Path = Path("data")
    database_url: str | None = None  # default: sqlite file in data_dir
    max_upload_bytes: int = 512 * 1024 * 1024
    max_unzipped_bytes: int = 2 * 1024 * 1024 * 1024
    max_zip_ratio: float = 200.0  # uncompressed/compressed per member (zip bomb guard)
    redis_url: str | None = None  # RedisHuey transport (scale-out); default SqliteHuey in data_dir
    run_consumer: bool = True  # start the huey consumer inside the server process
    workers: int = 2  # consumer worker threads in the server process
    heartbeat_s: float = 5.0  # running jobs refresh their heartbeat this often
    stale_s: float = 60.0  # a running job without heartbeat for this long is re-queued
    reap_every_s: float = 30.0
    clean_every_s: float = 600.0  # leftovers of stopped uploads (staging folders, .part blobs) removed this often
    auth_enabled: bool = True  # users, projects, sessions; off only for local single-user use
    demo_mode: bool = False  # visitors act as the clearly marked demo account
    admin_user: str | None = None  # first admin, created at start when set
    admin_password: str | None = None
    cookie_secure: bool = False  # set behind HTTPS
    session_hours: float = 12.0
    max_active_jobs_per_user: int = 4
    uploads_per_minute: int = 30
    login_failures_per_account: int = 10  # within login_window_s, then that account's logins wait
    login_failures_per_client: int = 30  # within login_window_s, then that client's logins wait
    login_window_s: float = 900.0
    trusted_proxies: str = ""  # comma-separated addresses/networks whose X-Forwarded-For is believed
    max_zip_members: int = 64  # a bundle has a handful of files
    security_headers: bool = True
    # a raster basemap for the maps, e.g. https://tile.openstreetmap.org/{z}/{x}/{y}.png (None: plain
    # maps in projected metres, nothing fetched from elsewhere); the Content-Security-Policy admits its origin
    basemap_tile_url: str | None = None
    basemap_attribution: str = ""  # shown on the map, e.g. "© OpenStreetMap contributors"
    # numba's compiled-code cache; read before numba is imported (see ldvsurvey.compilecache for the default)
    numba_cache_dir: Path | None = None

    @field_validator("basemap_tile_url")
    @classmethod
    def _tile_url(cls, v: str | None) -> str | None:
        if v in (None, ""):
            return None
        if not TILE_URL.fullmatch(v) or not all(p in v for p in ("{z}", "{x}", "{y}")):
            raise ValueError(
                "LDVSURVEY_BASEMAP_TILE_URL: give an http(s) tile URL with {z}, {x} and {y}, "
                "e.g. https://tile.openstreetmap.org/{z}/{x}/{y}.png"
            )
        return v

    def basemap_origin(self) -> str | None:
        """The scheme://host[:port] of the basemap tiles (what the Content-Security-Policy admits)."""
        if not self.basemap_tile_url:
            return None
        m = re.match(r"https?://[^/]+", self.basemap_tile_url)
        return m.group(0) if m else None

    def resolved_database_url(self) -> str:
        """SQLAlchemy URL: ``LDVSURVEY_DATABASE_URL`` or ``sqlite:///<data_dir>/ldvsurvey.db``."""
        if self.database_url:
            return self.database_url
        self.data_dir.mkdir(parents=True, exist_ok=True)
        return f"sqlite:///{(self.data_dir / 'ldvsurvey.db').resolve()}"


@lru_cache
def get_settings() -> Settings:
    """Process-wide settings (cached; tests clear the cache after changing the environment)."""
    return Settings()
