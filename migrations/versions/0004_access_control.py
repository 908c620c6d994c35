"""users, projects, memberships, sessions, API tokens; logs belong to a project

Revision ID: 0004
Revises: 0003
Create Date: 2026-11-21
"""

import sqlalchemy as sa
from alembic import op

revision = "0004"
down_revision = "0003"
branch_labels = None
depends_on = None


def upgrade() -> None:
    op.create_table(
        "users",
        sa.Column("id", sa.Integer, primary_key=True),
        sa.Column("username", sa.String(100), nullable=False, unique=True),
        sa.Column("password_hash", sa.String(300), nullable=False),
        sa.Column("is_admin", sa.Boolean, nullable=False),
        sa.Column("is_demo", sa.Boolean, nullable=False),
        sa.Column("created_at", sa.DateTime(timezone=True), nullable=False),
    )
    op.create_table(
        "projects",
        sa.Column("id", sa.Integer, primary_key=True),
        sa.Column("name", sa.String(200), nullable=False, unique=True),
        sa.Column("created_at", sa.DateTime(timezone=True), nullable=False),
    )
    op.create_table(
        "memberships",
        sa.Column("user_id", sa.Integer, sa.ForeignKey("users.id", ondelete="CASCADE"), primary_key=True),
        sa.Column("project_id", sa.Integer, sa.ForeignKey("projects.id", ondelete="CASCADE"), primary_key=True),
    )
    op.create_table(
        "sessions",
        sa.Column("token_hash", sa.String(64), primary_key=True),
        sa.Column("user_id", sa.Integer, sa.ForeignKey("users.id", ondelete="CASCADE"), nullable=False),
        sa.Column("csrf", sa.String(64), nullable=False),
        sa.Column("expires_at", sa.DateTime(timezone=True), nullable=False),
    )
    op.create_table(
        "api_tokens",
        sa.Column("id", sa.Integer, primary_key=True),
        sa.Column("token_hash", sa.String(64), nullable=False, unique=True),
        sa.Column("user_id", sa.Integer, sa.ForeignKey("users.id", ondelete="CASCADE"), nullable=False),
        sa.Column("name", sa.String(100), nullable=False),
        sa.Column("created_at", sa.DateTime(timezone=True), nullable=False),
    )
    with op.batch_alter_table("logs") as b:
        b.add_column(
            sa.Column(
                "project_id",
                sa.Integer,
                sa.ForeignKey("projects.id", ondelete="CASCADE", name="fk_logs_project"),
                nullable=True,
            )
        )
    with op.batch_alter_table("jobs") as b:
        b.add_column(sa.Column("user_id", sa.Integer, nullable=True))
    # the same bundle may live in several projects: uniqueness of the content is per project
    bind = op.get_bind()
    if bind.dialect.name == "sqlite":  # the inline constraint of 0001 is unnamed there
        with op.batch_alter_table(
            "logs", recreate="always", naming_convention={"uq": "uq_%(table_name)s_%(column_0_name)s"}
        ) as b:
            b.drop_constraint("uq_logs_sha256", type_="unique")
            b.create_unique_constraint("uq_logs_project_sha256", ["project_id", "sha256"])
    else:
        for u in sa.inspect(bind).get_unique_constraints("logs"):
            if u["column_names"] == ["sha256"]:
                op.drop_constraint(u["name"], "logs", type_="unique")
        op.create_unique_constraint("uq_logs_project_sha256", "logs", ["project_id", "sha256"])


def downgrade() -> None:
    with op.batch_alter_table("logs") as b:
        b.drop_constraint("uq_logs_project_sha256", type_="unique")
        b.drop_column("project_id")
    with op.batch_alter_table("jobs") as b:
        b.drop_column("user_id")
    for t in ("api_tokens", "sessions", "memberships", "projects", "users"):
        op.drop_table(t)
