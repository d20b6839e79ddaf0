"""The samples of runs, stored in blocks (``sample_blocks``, :mod:`daq.store.packing`): a
batch is one block written in one transaction, and read back as numpy columns.

A batch first takes its run's turn to write (so two writers of one run take turns),
refuses a seq already stored (or, asked to, leaves it out), and rewrites any stored block
whose seq range it overlaps together with it, so a run's blocks never overlap. As a run grows, its
newest :data:`MERGE_FAN_IN` blocks are merged into one once they are all of the same
level and together hold at most ``BLOCK_MAX_SAMPLES``: a recorder's flushes of a few
samples become blocks of thousands (each sample is rewritten about three times), so a
long run reads as a few arrays.
"""

from __future__ import annotations

import functools
from collections.abc import Sequence
from dataclasses import dataclass

import sqlalchemy as sa

from daq.sample import Sample
from daq.store import checks
from daq.store.database import StoreBase
from daq.store.packing import BLOCK_COLUMNS, Block, SamplePacker
from daq.store.run_records import DuplicateSample, SampleTable
from daq.store.schema import sample_blocks as blocks_t

#: How many blocks of one level are merged into one block of the next level.
MERGE_FAN_IN = 16

#: First half of the PostgreSQL advisory-lock key a batch holds on its run ("smpl"; the
#: rig's leases use "towr", ``daq.rig_lock.postgres``).
RUN_WRITE_LOCK = int.from_bytes(b"smpl", "big")

_BLOCK_META = (blocks_t.c.first_seq, blocks_t.c.sample_count, blocks_t.c.level)


def _seq_list(seqs: Sequence[int], shown: int = 5) -> str:
    """``8, 9, 10`` or ``8, 9, 10, 11, 12 and 7 more``."""
    text = ", ".join(str(s) for s in seqs[:shown])
    return text + (f" and {len(seqs) - shown} more" if len(seqs) > shown else "")


@dataclass(frozen=True)
class BatchSql:
    """The statements a batch runs, as the driver's SQL in its parameter style: a recorder
    writes a batch every flush, and SQLAlchemy building each statement again cost more
    than the database did."""

    #: Take the run's turn to write (:meth:`SampleRows._lock_run`): (pk,) or (key, pk).
    lock: str
    #: The stored blocks whose seq range meets (pk, low, high), whole, in seq order.
    overlapping: str
    #: One block row, the values in ``BLOCK_COLUMNS`` order.
    insert: str
    #: Add (count, pk) to the run's ``sample_count``.
    count: str
    #: first_seq, sample_count, level of (pk)'s newest (limit) blocks, newest first.
    newest: str

    @classmethod
    def of(cls, backend: str) -> BatchSql:
        """The statements for ``backend`` (``sqlite`` or ``postgresql``)."""
        mark = "?" if backend == "sqlite" else "%s"
        columns = ", ".join(BLOCK_COLUMNS)
        lock = (
            f"SELECT pg_advisory_xact_lock({mark}, {mark})"
            if backend == "postgresql"
            else f"UPDATE runs SET sample_count = sample_count WHERE id = {mark}"
        )
        return cls(
            lock=lock,
            overlapping=f"SELECT {columns} FROM sample_blocks WHERE run_id = {mark} "
            f"AND last_seq >= {mark} AND first_seq <= {mark} ORDER BY first_seq",
            insert=f"INSERT INTO sample_blocks ({columns}) "
            f"VALUES ({', '.join([mark] * len(BLOCK_COLUMNS))})",
            count=f"UPDATE runs SET sample_count = sample_count + {mark} WHERE id = {mark}",
            newest=f"SELECT first_seq, sample_count, level FROM sample_blocks "
            f"WHERE run_id = {mark} ORDER BY first_seq DESC LIMIT {mark}",
        )


class SampleRows(StoreBase):
    """The samples part of :class:`daq.store.Store`."""

    @functools.cached_property
    def _batch_sql(self) -> BatchSql:
        return BatchSql.of(self.backend)

    def _blocks(self, conn: sa.Connection, where: sa.ColumnElement[bool]) -> Sequence[sa.Row]:
        """The blocks matching ``where``, whole, in seq order."""
        return conn.execute(sa.select(blocks_t).where(where).order_by(blocks_t.c.first_seq)).all()

    def _write_block(self, conn: sa.Connection, pk: int, block: Block) -> None:
        conn.exec_driver_sql(self._batch_sql.insert, [part.row(pk) for part in block.chunks()])

    def _store_batch(
        self,
        conn: sa.Connection,
        run_uuid: str,
        pk: int,
        packer: SamplePacker,
        samples: Sequence[Sample],
        *,
        skip_existing: bool = False,
    ) -> int:
        """Store ``samples`` as a block in the transaction of ``conn``; returns how many."""
        if not samples:
            return 0
        import numpy as np

        sql = self._batch_sql
        block = packer.block(samples)
        self._lock_run(conn, pk)
        low, high = int(block.seq[0]), int(block.seq[-1])
        repeated = block.seq[1:] == block.seq[:-1]
        stored = conn.exec_driver_sql(sql.overlapping, (pk, low, high)).all()
        neighbours = [Block.from_row(row, packer.width) for row in stored]
        clash = np.zeros(len(block), dtype=bool)
        if neighbours:
            clash = np.isin(block.seq, np.concatenate([b.seq for b in neighbours]))
        if not skip_existing and (clash.any() or repeated.any()):
            dupes = np.unique(np.concatenate([block.seq[clash], block.seq[1:][repeated]]))
            raise DuplicateSample(
                f"run {run_uuid}: a sample with seq in {low}..{high} is already stored "
                f"(seq {_seq_list(dupes.tolist())}; seq must be unique per run); nothing "
                "from this batch was written"
            )
        clash[1:] |= repeated  # keep the first of repeats within the batch
        if clash.any():
            block = block.take(~clash)
        if not len(block):
            return 0
        if neighbours:  # rewrite them with the new samples: blocks never overlap
            conn.execute(
                sa.delete(blocks_t).where(
                    blocks_t.c.run_id == pk,
                    blocks_t.c.first_seq.in_([row.first_seq for row in stored]),
                )
            )
            block = Block.joined([*neighbours, block], max(b.level for b in neighbours))
        self._write_block(conn, pk, block)
        added = len(block) - sum(len(b) for b in neighbours)
        conn.exec_driver_sql(sql.count, (added, pk))
        while self._merge_newest(conn, pk, packer.width):
            pass  # 16 blocks of level 0 make the 16th of level 1, which may complete a set
        return added

    def _lock_run(self, conn: sa.Connection, pk: int) -> None:
        """Take the run's turn to write before its stored seqs are read, so no other
        writer of the run slips in between: PostgreSQL a transaction advisory lock on the
        run, SQLite the database's write lock (taken by a write: an update that changes
        nothing)."""
        lock = self._batch_sql.lock
        conn.exec_driver_sql(lock, (RUN_WRITE_LOCK, pk) if self.backend == "postgresql" else (pk,))

    def _merge_newest(self, conn: sa.Connection, pk: int, width: int) -> bool:
        """Merge the run's newest :data:`MERGE_FAN_IN` blocks into one of the next level
        when they are all of one level and together fit in a block; True if merged."""
        from daq.store.packing import BLOCK_MAX_SAMPLES

        newest = conn.exec_driver_sql(self._batch_sql.newest, (pk, MERGE_FAN_IN)).all()
        if (
            len(newest) < MERGE_FAN_IN
            or len({row.level for row in newest}) > 1
            or sum(row.sample_count for row in newest) > BLOCK_MAX_SAMPLES
        ):
            return False
        since = (blocks_t.c.run_id == pk) & (blocks_t.c.first_seq >= newest[-1].first_seq)
        parts = [Block.from_row(row, width) for row in self._blocks(conn, since)]
        conn.execute(sa.delete(blocks_t).where(since))
        self._write_block(conn, pk, Block.joined(parts, newest[0].level + 1))
        return True

    def add_samples(
        self, run_id: str, samples: Sequence[Sample], *, skip_existing: bool = False
    ) -> int:
        """Store a batch of samples in one transaction; returns how many were stored.

        A seq already stored (or repeated in the batch) raises :class:`DuplicateSample`
        (nothing written), or with ``skip_existing`` is left out (a repeat within the batch
        keeps its first) and the rest stored.
        """
        pk, packer = self._packer(run_id)
        with self.transaction() as conn:
            return self._store_batch(conn, run_id, pk, packer, samples, skip_existing=skip_existing)

    def samples(self, run_id: str, *, start_seq: int = 0, limit: int | None = None) -> SampleTable:
        """A run's samples with ``seq ≥ start_seq`` (at most ``limit``) as numpy columns."""
        checks.check_limit("start_seq", start_seq, minimum=0)
        if limit is not None:
            checks.check_limit("limit", limit, minimum=0)
        with self.engine.connect() as conn:
            run = self._resolve(conn, run_id)
            span = self._span(conn, run.id, start_seq, limit)
            rows = () if span is None else self._blocks(conn, span)
        packer = SamplePacker(run.channel_names)
        blocks = [Block.from_row(row, packer.width).from_seq(start_seq) for row in rows]
        return packer.table(blocks, limit)

    @staticmethod
    def _span(
        conn: sa.Connection, pk: int, start_seq: int, limit: int | None
    ) -> sa.ColumnElement[bool] | None:
        """Which blocks of run ``pk`` hold its samples from ``start_seq`` on (at most
        ``limit``), as a range of their ``first_seq``: read from the blocks' sizes first, so
        the blocks themselves are read in key order and never sorted (None: no block).
        The first block may hold samples before ``start_seq``: the span ends where the
        blocks after it hold ``limit``."""
        begin, end, counted = None, None, 0
        sizes = (
            sa.select(*_BLOCK_META)
            .where(blocks_t.c.run_id == pk, blocks_t.c.last_seq >= start_seq)
            .order_by(blocks_t.c.first_seq)
        )
        for index, (first_seq, count, _level) in enumerate(conn.execute(sizes)):
            begin = first_seq if begin is None else begin
            end = first_seq
            counted += count if index else 0
            if limit is not None and counted >= limit:
                break
        if begin is None:
            return None
        return (blocks_t.c.run_id == pk) & blocks_t.c.first_seq.between(begin, end)

    def sample_count(self, run_id: str) -> int:
        """How many samples of the run are stored (counted in its blocks, not cached)."""
        with self.engine.connect() as conn:
            run = self._resolve(conn, run_id)
            total = conn.execute(
                sa.select(sa.func.sum(blocks_t.c.sample_count)).where(blocks_t.c.run_id == run.id)
            ).scalar()
        return int(total or 0)

    def last_sample(self, run_id: str) -> Sample | None:
        """The stored sample with the highest seq (None before the first flush)."""
        with self.engine.connect() as conn:
            run = self._resolve(conn, run_id)
            last = conn.execute(
                sa.select(sa.func.max(blocks_t.c.last_seq)).where(blocks_t.c.run_id == run.id)
            ).scalar()
        if last is None:
            return None
        return self.samples(run.uuid, start_seq=last, limit=1).sample(0)
