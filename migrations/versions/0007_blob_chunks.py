"""blobs in the database: large files and arrays as 1-MiB chunks of ``blob_chunks`` (PostgreSQL)

With PostgreSQL the large originals and Parquet arrays of a log live in the database (a key
``db:…`` in ``log_files.blob`` / ``log_arrays.blob``), so that workers on other machines need no
shared folder; SQLite keeps its blob folder (the table stays empty). Blobs already in a folder stay
readable and move with ``ldv-survey blobs migrate`` (docs/installing.md).

Revision ID: 0007_blob_chunks
Revises: 0006_log_blobs
Create Date: 2026-11-26
"""

import sqlalchemy as sa
from alembic import op

revision = "0007_blob_chunks"
down_revision = "0006_log_blobs"
branch_labels = None
depends_on = None


def upgrade() -> None:
    op.create_table(
        "blob_chunks",
        sa.Column("key", sa.String(200), nullable=False),
        sa.Column("seq", sa.Integer, nullable=False),
        sa.Column("data", sa.LargeBinary, nullable=False),
        sa.PrimaryKeyConstraint("key", "seq"),
    )
    if op.get_bind().dialect.name == "postgresql":
        # the chunks are Parquet (compressed already) or CSV read once per job: stored out of line
        # without pglz's attempt to compress each one (which costs more time than it saves room)
        op.execute("ALTER TABLE blob_chunks ALTER COLUMN data SET STORAGE EXTERNAL")


def downgrade() -> None:
    op.drop_table("blob_chunks")
