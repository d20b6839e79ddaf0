"""sample blocks: a run's samples as column arrays, one row per block instead of per sample

Revision ID: 0007
Revises: 0006
Create Date: 2026-11-29

``sample_blocks`` replaces ``samples``: reading a run of 10⁶ samples fetched 10⁶ rows and
unpacked each; now it concatenates the arrays of a few dozen blocks. Every stored sample is
converted, in blocks of 65,536 samples at most (``daq.store.packing.BLOCK_MAX_SAMPLES``),
within the upgrade's one transaction: a failure leaves the database as it was. The layout
written here is the one of this revision, written out in full so later changes to
``daq.store.packing`` cannot change what this step does. SQLite keeps the freed pages in its
file until ``VACUUM``. The downgrade converts the blocks back into one row per sample.
"""

from __future__ import annotations

import json
from collections.abc import Iterator, Sequence

import numpy as np
import sqlalchemy as sa
from alembic import op

# revision identifiers, used by Alembic.
revision: str = "0007"
down_revision: str | Sequence[str] | None = "0006"
branch_labels: str | Sequence[str] | None = None
depends_on: str | Sequence[str] | None = None

#: Most samples a converted block holds.
BLOCK_SAMPLES = 65_536

_samples = sa.table(
    "samples",
    sa.column("run_id", sa.Integer),
    sa.column("seq", sa.BigInteger),
    sa.column("t_mono", sa.Float),
    sa.column("t_wall", sa.Float),
    sa.column("quality", sa.Integer),
    sa.column("stale", sa.Text),
    sa.column("channel_values", sa.LargeBinary),
)
_blocks = sa.table(
    "sample_blocks",
    sa.column("run_id", sa.Integer),
    sa.column("first_seq", sa.BigInteger),
    sa.column("last_seq", sa.BigInteger),
    sa.column("sample_count", sa.Integer),
    sa.column("level", sa.SmallInteger),
    sa.column("t_wall_max", sa.Float),
    sa.column("stale", sa.Text),
    sa.column("seq", sa.LargeBinary),
    sa.column("t_mono", sa.LargeBinary),
    sa.column("t_wall", sa.LargeBinary),
    sa.column("quality", sa.LargeBinary),
    sa.column("channel_values", sa.LargeBinary),
)


def _create_samples() -> None:
    op.create_table(
        "samples",
        sa.Column("run_id", sa.Integer(), nullable=False),
        sa.Column("seq", sa.BigInteger(), autoincrement=False, nullable=False),
        sa.Column("t_mono", sa.Float(precision=53), nullable=False),
        sa.Column("t_wall", sa.Float(precision=53), nullable=False),
        sa.Column("quality", sa.Integer(), nullable=False),
        sa.Column("stale", sa.Text(), nullable=True),
        sa.Column("channel_values", sa.LargeBinary(), nullable=False),
        sa.ForeignKeyConstraint(
            ["run_id"], ["runs.id"], name=op.f("fk_samples_run_id_runs"), ondelete="CASCADE"
        ),
        sa.PrimaryKeyConstraint("run_id", "seq", name=op.f("pk_samples")),
        sqlite_with_rowid=False,
    )


def _sample_pages(conn: sa.Connection, run_id: int) -> Iterator[Sequence[sa.Row]]:
    """The run's sample rows in seq order, ``BLOCK_SAMPLES`` at a time."""
    start = None
    while True:
        query = sa.select(_samples).where(_samples.c.run_id == run_id)
        if start is not None:
            query = query.where(_samples.c.seq > start)
        rows = conn.execute(query.order_by(_samples.c.seq).limit(BLOCK_SAMPLES)).all()
        if not rows:
            return
        yield rows
        start = rows[-1].seq


def _block_row(run_id: int, rows: Sequence[sa.Row]) -> dict:
    """One ``sample_blocks`` row of consecutive sample rows (channel values: each row's
    float64 BLOB in channel order, stored channel after channel)."""
    count = len(rows)
    matrix = np.frombuffer(b"".join(bytes(r.channel_values) for r in rows), dtype="<f8")
    values = matrix.reshape(count, -1).T if count else matrix
    t_wall = np.array([r.t_wall for r in rows], dtype="<f8")
    stale = {str(i): r.stale.split(",") for i, r in enumerate(rows) if r.stale}
    return {
        "run_id": run_id,
        "first_seq": rows[0].seq,
        "last_seq": rows[-1].seq,
        "sample_count": count,
        "level": 0,
        "t_wall_max": float(np.nanmax(t_wall)) if np.isfinite(t_wall).any() else None,
        "stale": json.dumps(stale) if stale else None,
        "seq": np.array([r.seq for r in rows], dtype="<i8").tobytes(),
        "t_mono": np.array([r.t_mono for r in rows], dtype="<f8").tobytes(),
        "t_wall": t_wall.tobytes(),
        "quality": np.array([r.quality for r in rows], dtype="<i8").tobytes(),
        "channel_values": np.ascontiguousarray(values).tobytes(),
    }


def upgrade() -> None:
    """Upgrade schema: create ``sample_blocks``, move every sample into it, drop ``samples``."""
    op.create_table(
        "sample_blocks",
        sa.Column("run_id", sa.Integer(), nullable=False),
        sa.Column("first_seq", sa.BigInteger(), autoincrement=False, nullable=False),
        sa.Column("last_seq", sa.BigInteger(), nullable=False),
        sa.Column("sample_count", sa.Integer(), nullable=False),
        sa.Column("level", sa.SmallInteger(), nullable=False),
        sa.Column("t_wall_max", sa.Float(precision=53), nullable=True),
        sa.Column("stale", sa.Text(), nullable=True),
        sa.Column("seq", sa.LargeBinary(), nullable=False),
        sa.Column("t_mono", sa.LargeBinary(), nullable=False),
        sa.Column("t_wall", sa.LargeBinary(), nullable=False),
        sa.Column("quality", sa.LargeBinary(), nullable=False),
        sa.Column("channel_values", sa.LargeBinary(), nullable=False),
        sa.ForeignKeyConstraint(
            ["run_id"], ["runs.id"], name=op.f("fk_sample_blocks_run_id_runs"), ondelete="CASCADE"
        ),
        sa.PrimaryKeyConstraint("run_id", "first_seq", name=op.f("pk_sample_blocks")),
    )
    op.create_index(
        "ix_sample_blocks_run_id_last_seq", "sample_blocks", ["run_id", "last_seq"], unique=False
    )
    conn = op.get_bind()
    run_ids = conn.execute(sa.select(_samples.c.run_id).distinct()).scalars().all()
    for run_id in run_ids:
        for rows in _sample_pages(conn, run_id):
            conn.execute(sa.insert(_blocks), [_block_row(run_id, rows)])
    op.drop_table("samples")


def downgrade() -> None:
    """Downgrade schema: one ``samples`` row per sample again, then drop ``sample_blocks``."""
    _create_samples()
    conn = op.get_bind()
    for block in conn.execute(sa.select(_blocks).order_by(_blocks.c.run_id, _blocks.c.first_seq)):
        count = block.sample_count
        values = np.frombuffer(block.channel_values, dtype="<f8").reshape(-1, count).T
        stale = {int(i): ",".join(n) for i, n in json.loads(block.stale or "{}").items()}
        rows = [
            {
                "run_id": block.run_id,
                "seq": seq,
                "t_mono": t_mono,
                "t_wall": t_wall,
                "quality": quality,
                "stale": stale.get(i),
                "channel_values": np.ascontiguousarray(values[i]).astype("<f8").tobytes(),
            }
            for i, (seq, t_mono, t_wall, quality) in enumerate(
                zip(
                    np.frombuffer(block.seq, dtype="<i8").tolist(),
                    np.frombuffer(block.t_mono, dtype="<f8").tolist(),
                    np.frombuffer(block.t_wall, dtype="<f8").tolist(),
                    np.frombuffer(block.quality, dtype="<i8").tolist(),
                    strict=True,
                )
            )
        ]
        conn.execute(sa.insert(_samples), rows)
    op.drop_index("ix_sample_blocks_run_id_last_seq", table_name="sample_blocks")
    op.drop_table("sample_blocks")
