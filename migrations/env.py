"""Alembic environment: uses the connection handed over by ldvsurvey.store.db.upgrade_head,
or the URL from alembic.ini / LDVSURVEY_DATABASE_URL when run from the alembic CLI."""

from alembic import context
from sqlalchemy import create_engine

from ldvsurvey.store.models import Base

config = context.config
target_metadata = Base.metadata


def run_migrations_online() -> None:
    conn = config.attributes.get("connection")
    if conn is not None:
        context.configure(
            connection=conn, target_metadata=target_metadata, render_as_batch=conn.dialect.name == "sqlite"
        )
        with context.begin_transaction():
            context.run_migrations()
        return
    from ldvsurvey.settings import get_settings

    url = config.get_main_option("sqlalchemy.url") or get_settings().resolved_database_url()
    engine = create_engine(url)
    with engine.begin() as connection:
        context.configure(
            connection=connection, target_metadata=target_metadata, render_as_batch=connection.dialect.name == "sqlite"
        )
        with context.begin_transaction():
            context.run_migrations()


def run_migrations_offline() -> None:
    context.configure(url=config.get_main_option("sqlalchemy.url"), target_metadata=target_metadata, literal_binds=True)
    with context.begin_transaction():
        context.run_migrations()


if context.is_offline_mode():
    run_migrations_offline()
else:
    run_migrations_online()
