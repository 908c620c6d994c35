"""people and access: disabled users, expiring API tokens, shared login-failure counters;
job stage logs; job and log ids never reused (SQLite AUTOINCREMENT)

Revision ID: 0005_people
Revises: 0004
Create Date: 2026-11-23
"""

import sqlalchemy as sa
from alembic import op

revision = "0005_people"
down_revision = "0004"
branch_labels = None
depends_on = None


def upgrade() -> None:
    sqlite = op.get_bind().dialect.name == "sqlite"
    with op.batch_alter_table("users") as b:
        b.add_column(sa.Column("disabled", sa.Boolean, nullable=False, server_default=sa.false()))
    with op.batch_alter_table("api_tokens") as b:
        b.add_column(sa.Column("expires_at", sa.DateTime(timezone=True), nullable=True))
        b.add_column(sa.Column("last_used_at", sa.DateTime(timezone=True), nullable=True))
    op.create_table(
        "login_failures",
        sa.Column("id", sa.Integer, primary_key=True),
        sa.Column("key", sa.String(300), nullable=False, index=True),
        sa.Column("at", sa.DateTime(timezone=True), nullable=False, index=True),
    )
    # ids are never handed out twice: SQLite reuses the largest rowid after a delete unless the table
    # says AUTOINCREMENT (PostgreSQL sequences never go back). The store runs migrations with
    # foreign keys off, so recreating the tables does not cascade into their children.
    kw = {"recreate": "always", "table_kwargs": {"sqlite_autoincrement": True}} if sqlite else {}
    with op.batch_alter_table("jobs", **kw) as b:
        b.add_column(sa.Column("stage_log", sa.JSON, nullable=True))
    if sqlite:
        with op.batch_alter_table("logs", **kw):
            pass


def downgrade() -> None:
    with op.batch_alter_table("jobs") as b:
        b.drop_column("stage_log")
    op.drop_table("login_failures")
    with op.batch_alter_table("api_tokens") as b:
        b.drop_column("last_used_at")
        b.drop_column("expires_at")
    with op.batch_alter_table("users") as b:
        b.drop_column("disabled")
