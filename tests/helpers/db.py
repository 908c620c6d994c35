"""A server database (PostgreSQL in CI) emptied between tests."""

from sqlalchemy import MetaData, text

from ldvsurvey.store.db import get_engine, upgrade_head


def reset_database(url: str) -> None:
    """Drop every table (including Alembic's) and migrate from scratch."""
    eng = get_engine(url)
    md = MetaData()
    md.reflect(bind=eng)
    with eng.begin() as conn:
        if conn.dialect.name == "postgresql":
            for t in md.sorted_tables:
                conn.execute(text(f'DROP TABLE IF EXISTS "{t.name}" CASCADE'))
        else:
            md.drop_all(bind=conn)
    upgrade_head(url)
