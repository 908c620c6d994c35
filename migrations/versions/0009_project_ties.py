"""a project keeps its base stations (absolute gravity ties) once, for every gravity job of the project

Revision ID: 0009_project_ties
Revises: 0008_log_facts
Create Date: 2026-11-26
"""

import sqlalchemy as sa
from alembic import op

revision = "0009_project_ties"
down_revision = "0008_log_facts"
branch_labels = None
depends_on = None


def upgrade() -> None:
    op.create_table(
        "project_ties",
        sa.Column("id", sa.Integer, primary_key=True),
        sa.Column(
            "project_id",
            sa.Integer,
            sa.ForeignKey("projects.id", ondelete="CASCADE", name="fk_project_ties_project"),
            nullable=False,
            index=True,
        ),
        sa.Column("name", sa.String(100), nullable=False),
        sa.Column("lat_deg", sa.Float, nullable=False),
        sa.Column("lon_deg", sa.Float, nullable=False),
        sa.Column("h_m", sa.Float, nullable=False),
        sa.Column("g_mgal", sa.Float, nullable=False),
        sa.Column("sigma_mgal", sa.Float, nullable=False),
        sa.Column("note", sa.String(500), nullable=False),
        # who entered it (NULL: open mode): the demo account changes only the ties it entered
        sa.Column("user_id", sa.Integer, nullable=True),
        sa.Column("created_at", sa.DateTime(timezone=True), nullable=False),
        sa.UniqueConstraint("project_id", "name", name="uq_project_ties_project_name"),
    )


def downgrade() -> None:
    op.drop_table("project_ties")
