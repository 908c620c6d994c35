"""large log files and arrays may live as files in the blob folder (``blob``), not in the row

Revision ID: 0006_log_blobs
Revises: 0005_people
Create Date: 2026-11-23
"""

import sqlalchemy as sa
from alembic import op

revision = "0006_log_blobs"
down_revision = "0005_people"
branch_labels = None
depends_on = None


def upgrade() -> None:
    # rows stored before keep their bytes in the row (blob NULL); new large ones name a file instead
    with op.batch_alter_table("log_files") as b:
        b.add_column(sa.Column("blob", sa.String(200), nullable=True))
        b.alter_column("content", existing_type=sa.LargeBinary, nullable=True)
    with op.batch_alter_table("log_arrays") as b:
        b.add_column(sa.Column("blob", sa.String(200), nullable=True))
        b.alter_column("parquet", existing_type=sa.LargeBinary, nullable=True)


def downgrade() -> None:
    with op.batch_alter_table("log_arrays") as b:
        b.alter_column("parquet", existing_type=sa.LargeBinary, nullable=False)
        b.drop_column("blob")
    with op.batch_alter_table("log_files") as b:
        b.alter_column("content", existing_type=sa.LargeBinary, nullable=False)
        b.drop_column("blob")
