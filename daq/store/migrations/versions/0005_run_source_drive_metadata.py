"""run source, drive and metadata

Revision ID: 0005
Revises: 0004
Create Date: 2026-11-23

Runs get the drive (weight/thrusters), where they came from (recorded/imported, the
original file, when imported) and free metadata with its tags as rows. Existing runs are
filled in from their parameters: ``drive``, and ``source: import`` / ``file`` of imports.
"""

from collections.abc import Sequence

import sqlalchemy as sa
from alembic import op

# revision identifiers, used by Alembic.
revision: str = "0005"
down_revision: str | Sequence[str] | None = "0004"
branch_labels: str | Sequence[str] | None = None
depends_on: str | Sequence[str] | None = None


def _drive(kind: str, parameters: dict) -> str | None:
    if parameters.get("drive") in ("weight", "thrusters"):
        return parameters["drive"]
    if kind == "thrust_calibration":
        return "thrusters"
    return "weight" if parameters.get("hung_mass_kg") is not None else None


def upgrade() -> None:
    """Upgrade schema."""
    with op.batch_alter_table("runs", schema=None) as batch_op:
        batch_op.add_column(sa.Column("drive", sa.String(length=20), nullable=True))
        batch_op.add_column(
            sa.Column("source", sa.String(length=20), server_default="recorded", nullable=False)
        )
        batch_op.add_column(sa.Column("source_file", sa.String(length=255), nullable=True))
        batch_op.add_column(sa.Column("imported_at", sa.Float(precision=53), nullable=True))
        batch_op.add_column(sa.Column("metadata", sa.JSON(), nullable=True))
        batch_op.create_index(batch_op.f("ix_runs_drive"), ["drive"], unique=False)
        batch_op.create_index(batch_op.f("ix_runs_source"), ["source"], unique=False)
    op.create_table(
        "run_tags",
        sa.Column("run_id", sa.Integer(), nullable=False),
        sa.Column("tag", sa.String(length=40), nullable=False),
        sa.ForeignKeyConstraint(
            ["run_id"], ["runs.id"], name=op.f("fk_run_tags_run_id_runs"), ondelete="CASCADE"
        ),
        sa.PrimaryKeyConstraint("run_id", "tag", name=op.f("pk_run_tags")),
    )
    with op.batch_alter_table("run_tags", schema=None) as batch_op:
        batch_op.create_index(batch_op.f("ix_run_tags_tag"), ["tag"], unique=False)

    runs = sa.table(
        "runs",
        sa.column("id", sa.Integer),
        sa.column("kind", sa.String),
        sa.column("parameters", sa.JSON),
        sa.column("drive", sa.String),
        sa.column("source", sa.String),
        sa.column("source_file", sa.String),
    )
    conn = op.get_bind()
    for row in conn.execute(sa.select(runs.c.id, runs.c.kind, runs.c.parameters)).all():
        params = row.parameters if isinstance(row.parameters, dict) else {}
        imported = params.get("source") == "import"
        name = str(params.get("file") or "").rsplit("/", 1)[-1][-255:]
        source_file = name if imported and name else None
        conn.execute(
            sa.update(runs)
            .where(runs.c.id == row.id)
            .values(
                drive=_drive(row.kind, params),
                source="imported" if imported else "recorded",
                source_file=source_file,
            )
        )


def downgrade() -> None:
    """Downgrade schema."""
    with op.batch_alter_table("run_tags", schema=None) as batch_op:
        batch_op.drop_index(batch_op.f("ix_run_tags_tag"))
    op.drop_table("run_tags")
    with op.batch_alter_table("runs", schema=None) as batch_op:
        batch_op.drop_index(batch_op.f("ix_runs_source"))
        batch_op.drop_index(batch_op.f("ix_runs_drive"))
        batch_op.drop_column("metadata")
        batch_op.drop_column("imported_at")
        batch_op.drop_column("source_file")
        batch_op.drop_column("source")
        batch_op.drop_column("drive")
