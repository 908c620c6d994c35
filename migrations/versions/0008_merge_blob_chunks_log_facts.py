"""Join the two 0007 heads (blob chunks, log facts) that came from branches merged side by side.

Nothing to change in the schema: the two revisions touch different tables. Without this a fresh
server stops at ``alembic upgrade head`` ("Multiple head revisions").

Revision ID: 0008_merge_0007
Revises: 0007_blob_chunks, 0007_log_facts
"""

revision = "0008_merge_0007"
down_revision = ("0007_blob_chunks", "0007_log_facts")
branch_labels = None
depends_on = None


def upgrade() -> None:
    pass


def downgrade() -> None:
    pass
