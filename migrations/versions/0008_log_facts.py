"""logs keep the facts the pipelines' applicability checks need (sensors, repeated survey lines)

Revision ID: 0008_log_facts
Revises: 0007_blob_chunks
Create Date: 2026-11-26
"""

import sqlalchemy as sa
from alembic import op

revision = "0008_log_facts"
down_revision = "0007_blob_chunks"
branch_labels = None
depends_on = None


def upgrade() -> None:
    # rows stored before keep NULL: their facts are computed from their stored arrays on first use
    # (ldvsurvey.store.logs.facts_of) and kept then
    with op.batch_alter_table("logs") as b:
        b.add_column(sa.Column("facts", sa.JSON, nullable=True))


def downgrade() -> None:
    with op.batch_alter_table("logs") as b:
        b.drop_column("facts")
