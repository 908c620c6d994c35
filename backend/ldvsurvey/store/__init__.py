"""Storage: SQLAlchemy models, Alembic migrations, Parquet blobs."""
