"""people: named users with hashed tokens and roles, the rig's safety events, who asked
for each job

Revision ID: 0006
Revises: 0005
Create Date: 2026-11-26

``users`` (name, role operator|viewer, the SHA-256 of the token: the token itself is shown
once and never stored), ``rig_events`` (emergency stops and their acknowledgements, holds of
the rig and their releases, each naming who) and ``jobs.user_name``. Existing jobs keep
NULL: nobody was named then.
"""

from collections.abc import Sequence

import sqlalchemy as sa
from alembic import op

# revision identifiers, used by Alembic.
revision: str = "0006"
down_revision: str | Sequence[str] | None = "0005"
branch_labels: str | Sequence[str] | None = None
depends_on: str | Sequence[str] | None = None


def upgrade() -> None:
    """Upgrade schema."""
    op.create_table(
        "users",
        sa.Column("id", sa.Integer(), nullable=False),
        sa.Column("name", sa.String(length=40), nullable=False),
        sa.Column("role", sa.String(length=20), nullable=False),
        sa.Column("token_sha256", sa.String(length=64), nullable=False),
        sa.Column("created_at", sa.Float(precision=53), nullable=False),
        sa.CheckConstraint("role IN ('operator', 'viewer')", name=op.f("ck_users_role")),
        sa.PrimaryKeyConstraint("id", name=op.f("pk_users")),
        sa.UniqueConstraint("name", name=op.f("uq_users_name")),
        sa.UniqueConstraint("token_sha256", name=op.f("uq_users_token_sha256")),
    )
    op.create_table(
        "rig_events",
        sa.Column("id", sa.Integer(), nullable=False),
        sa.Column("rig_name", sa.String(length=200), nullable=False),
        sa.Column("t_wall", sa.Float(precision=53), nullable=False),
        sa.Column("kind", sa.String(length=40), nullable=False),
        sa.Column("user_name", sa.String(length=40), nullable=True),
        sa.Column("message", sa.Text(), nullable=False),
        sa.PrimaryKeyConstraint("id", name=op.f("pk_rig_events")),
    )
    with op.batch_alter_table("rig_events", schema=None) as batch_op:
        batch_op.create_index(batch_op.f("ix_rig_events_rig_name"), ["rig_name"], unique=False)
    with op.batch_alter_table("jobs", schema=None) as batch_op:
        batch_op.add_column(sa.Column("user_name", sa.String(length=40), nullable=True))


def downgrade() -> None:
    """Downgrade schema."""
    with op.batch_alter_table("jobs", schema=None) as batch_op:
        batch_op.drop_column("user_name")
    with op.batch_alter_table("rig_events", schema=None) as batch_op:
        batch_op.drop_index(batch_op.f("ix_rig_events_rig_name"))
    op.drop_table("rig_events")
    op.drop_table("users")
