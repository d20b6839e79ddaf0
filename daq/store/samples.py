"""The samples of runs: batched inserts (PostgreSQL ``COPY``, SQLite ``executemany``), one
transaction per batch, read back as numpy columns."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import sqlalchemy as sa

from daq.sample import Sample
from daq.store import checks
from daq.store.database import SAMPLE_COLUMNS, StoreBase
from daq.store.packing import SamplePacker
from daq.store.run_records import DuplicateSample, SampleTable
from daq.store.schema import runs as runs_t
from daq.store.schema import samples as samples_t


class SampleRows(StoreBase):
    """The samples part of :class:`daq.store.Store`."""

    def _insert_rows(
        self,
        conn: sa.Connection,
        run_uuid: str,
        pk: int,
        packer: SamplePacker,
        samples: Sequence[Sample],
    ) -> int:
        if not samples:
            return 0
        rows = packer.rows(pk, samples)
        dbapi = conn.dialect.loaded_dbapi
        try:
            if self.backend == "postgresql":
                driver = conn.connection.driver_connection
                assert driver is not None
                cursor = driver.cursor()
                with cursor, cursor.copy(f"COPY samples ({SAMPLE_COLUMNS}) FROM STDIN") as copy:
                    for row in rows:
                        copy.write_row(row)
            else:
                conn.exec_driver_sql(self._insert_samples_sql, rows)
        except (sa.exc.IntegrityError, dbapi.IntegrityError) as exc:
            seqs = [row[1] for row in rows]
            raise DuplicateSample(
                f"run {run_uuid}: a sample with seq in {min(seqs)}..{max(seqs)} is already "
                "stored (seq must be unique per run); nothing from this batch was written"
            ) from exc
        conn.execute(
            sa.update(runs_t)
            .where(runs_t.c.id == pk)
            .values(sample_count=runs_t.c.sample_count + len(rows))
        )
        return len(rows)

    def add_samples(
        self, run_id: str, samples: Sequence[Sample], *, skip_existing: bool = False
    ) -> int:
        """Store a batch of samples in one transaction; returns how many were stored.

        A seq already stored raises :class:`DuplicateSample` (nothing written), or with
        ``skip_existing`` is left out (as are repeats within the batch) and the rest stored.
        """
        with self.transaction() as conn:
            pk, packer = self._packer(conn, run_id)
            if skip_existing and samples:
                seqs = [s.seq for s in samples]
                stored = set(
                    conn.execute(
                        sa.select(samples_t.c.seq).where(
                            samples_t.c.run_id == pk,
                            samples_t.c.seq.between(min(seqs), max(seqs)),
                        )
                    ).scalars()
                )
                fresh: dict[int, Sample] = {}
                for sample in samples:
                    if sample.seq not in stored:
                        fresh.setdefault(sample.seq, sample)
                samples = list(fresh.values())
            return self._insert_rows(conn, run_id, pk, packer, samples)

    def samples(self, run_id: str, *, start_seq: int = 0, limit: int | None = None) -> SampleTable:
        """A run's samples with ``seq ≥ start_seq`` (at most ``limit``) as numpy columns."""
        checks.check_limit("start_seq", start_seq, minimum=0)
        if limit is not None:
            checks.check_limit("limit", limit, minimum=0)
        with self.engine.connect() as conn:
            run = self._resolve(conn, run_id)
            query = (
                sa.select(
                    samples_t.c.seq,
                    samples_t.c.t_mono,
                    samples_t.c.t_wall,
                    samples_t.c.quality,
                    samples_t.c.stale,
                    samples_t.c.channel_values,
                )
                .where(samples_t.c.run_id == run.id, samples_t.c.seq >= start_seq)
                .order_by(samples_t.c.seq)
            )
            if limit is not None:
                query = query.limit(limit)
            rows = conn.execute(query).all()
        import numpy as np  # here: listing runs starts without it

        packer = SamplePacker(run.channel_names)
        columns: list[Sequence[Any]] = list(zip(*rows, strict=True)) if rows else [[]] * 6
        stale = columns[4]
        return SampleTable(
            seq=np.array(columns[0], dtype=np.int64),
            t_mono=np.array(columns[1], dtype=np.float64),
            t_wall=np.array(columns[2], dtype=np.float64),
            quality=np.array(columns[3], dtype=np.int64),
            channels=packer.unpack([bytes(b) for b in columns[5]]),
            stale=tuple(tuple(s.split(",")) if s else () for s in stale),
        )

    def sample_count(self, run_id: str) -> int:
        """How many samples of the run are stored (counted, not cached)."""
        with self.engine.connect() as conn:
            run = self._resolve(conn, run_id)
            return conn.execute(
                sa.select(sa.func.count()).where(samples_t.c.run_id == run.id)
            ).scalar_one()

    def last_sample(self, run_id: str) -> Sample | None:
        """The stored sample with the highest seq (None before the first flush)."""
        with self.engine.connect() as conn:
            run = self._resolve(conn, run_id)
            last = conn.execute(
                sa.select(sa.func.max(samples_t.c.seq)).where(samples_t.c.run_id == run.id)
            ).scalar()
        if last is None:
            return None
        return self.samples(run.uuid, start_seq=last, limit=1).sample(0)
