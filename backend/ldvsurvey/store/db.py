"""Engine and sessions. SQLite by default (WAL, foreign keys on); any SQLAlchemy URL otherwise."""

from __future__ import annotations

import threading
from contextlib import contextmanager
from pathlib import Path

from sqlalchemy import create_engine, event
from sqlalchemy.engine import Engine
from sqlalchemy.orm import Session, sessionmaker

_lock = threading.Lock()
_engines: dict[str, Engine] = {}
MIGRATIONS_DIR = Path(__file__).resolve().parents[3] / "migrations"


def _sqlite_pragmas(dbapi_conn, _record) -> None:
    cur = dbapi_conn.cursor()
    cur.execute("PRAGMA journal_mode=WAL")
    cur.execute("PRAGMA foreign_keys=ON")
    cur.execute("PRAGMA busy_timeout=30000")
    cur.execute("PRAGMA synchronous=NORMAL")
    cur.close()


def get_engine(url: str) -> Engine:
    """One engine per URL and process."""
    with _lock:
        eng = _engines.get(url)
        if eng is None:
            if url.startswith("sqlite"):
                eng = create_engine(url, connect_args={"check_same_thread": False, "timeout": 30})
                event.listen(eng, "connect", _sqlite_pragmas)
            else:
                eng = create_engine(url, pool_pre_ping=True, pool_size=10, max_overflow=20)
            _engines[url] = eng
        return eng


def ping(url: str) -> str:
    """Run ``SELECT 1`` on the database at ``url``; returns its dialect name (``sqlite``, ``postgresql``)."""
    with get_engine(url).connect() as conn:
        conn.exec_driver_sql("SELECT 1")
        return conn.dialect.name


def dispose_engines() -> None:
    """Close every pooled connection (tests, forks)."""
    with _lock:
        for eng in _engines.values():
            eng.dispose()
        _engines.clear()


def upgrade_head(url: str) -> None:
    """Run Alembic ``upgrade head`` on the database at ``url``."""
    from alembic import command
    from alembic.config import Config

    cfg = Config()
    cfg.set_main_option("script_location", str(MIGRATIONS_DIR))
    cfg.set_main_option("sqlalchemy.url", url.replace("%", "%%"))
    eng = get_engine(url)
    if eng.dialect.name == "sqlite":
        # tables are recreated to change them (batch mode): with foreign keys on, dropping the old
        # table would cascade into its children. The pragma only works outside a transaction.
        with eng.connect() as conn:
            conn.exec_driver_sql("PRAGMA foreign_keys=OFF")
            conn.commit()  # ends SQLAlchemy's autobegun (empty) transaction
            try:
                with conn.begin():
                    cfg.attributes["connection"] = conn
                    command.upgrade(cfg, "head")
                bad = conn.exec_driver_sql("PRAGMA foreign_key_check").fetchall()
                conn.commit()
                if bad:
                    raise RuntimeError(f"migration left rows without their parent: {bad[:5]}")
            finally:
                conn.rollback()
                conn.exec_driver_sql("PRAGMA foreign_keys=ON")
                conn.commit()
        return
    with eng.begin() as conn:
        if conn.dialect.name == "postgresql":  # several API workers start at once: one migrates
            conn.exec_driver_sql("SELECT pg_advisory_xact_lock(7274001)")
        cfg.attributes["connection"] = conn
        command.upgrade(cfg, "head")


def session_factory(url: str) -> sessionmaker[Session]:
    """The session maker of the database at ``url`` (one engine per URL; objects stay readable after commit)."""
    return sessionmaker(bind=get_engine(url), expire_on_commit=False)


@contextmanager
def session_scope(url: str):
    """A session committed on success and rolled back on any error."""
    s = session_factory(url)()
    try:
        yield s
        s.commit()
    except BaseException:
        s.rollback()
        raise
    finally:
        s.close()
