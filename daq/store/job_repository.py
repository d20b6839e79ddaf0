"""The jobs repository: jobs, their progress events and report files (the SQL of the job
queue). A job row is a plain dict with the columns of ``schema.jobs``; times are Unix s."""

from __future__ import annotations

import os
import socket
import time
from collections.abc import Iterable, Sequence
from typing import Any

import sqlalchemy as sa

from daq.store.database import StoreBase, process_alive, process_identity
from daq.store.schema import JOB_FINAL, JobState, job_events, jobs, report_files

#: Columns a caller sets (the owner columns are filled in by ``save``).
JOB_FIELDS = tuple(
    c.name for c in jobs.columns if not c.name.startswith("owner_") and c.name != "id"
)
INTERRUPTED_REASON = "the service stopped while the job ran (killed or crashed)"


class JobRepository:
    """Job rows of one database (``store`` gives the engine and transactions)."""

    def __init__(self, store: StoreBase) -> None:
        self.store = store

    # -- jobs ------------------------------------------------------------------------------
    def save(self, job_id: str, row: dict[str, Any]) -> None:
        """Insert or update job ``job_id`` (owned by this process from now on)."""
        values = {k: row[k] for k in JOB_FIELDS if k in row}
        boot_id, ticks = process_identity()
        values |= {
            "owner_host": socket.gethostname(),
            "owner_pid": os.getpid(),
            "owner_boot_id": boot_id,
            "owner_start_ticks": ticks,
        }
        with self.store.transaction() as conn:
            done = conn.execute(sa.update(jobs).where(jobs.c.id == job_id).values(**values))
            if done.rowcount == 0:
                conn.execute(sa.insert(jobs).values(id=job_id, **values))

    def add_event(
        self, job_id: str, state: str, fraction: float, message: str, t_wall: float
    ) -> None:
        """Record one step of a job's progress."""
        with self.store.transaction() as conn:
            conn.execute(
                sa.insert(job_events).values(
                    job_id=job_id, state=state, fraction=fraction, message=message, t_wall=t_wall
                )
            )

    def events(self, job_id: str) -> list[dict[str, Any]]:
        """A job's progress events, oldest first."""
        query = (
            sa.select(job_events.c.t_wall, job_events.c.state, job_events.c.fraction)
            .add_columns(job_events.c.message)
            .where(job_events.c.job_id == job_id)
            .order_by(job_events.c.id)
        )
        with self.store.engine.connect() as conn:
            return [dict(r._mapping) for r in conn.execute(query)]

    def get(self, job_id: str) -> dict[str, Any] | None:
        """One job's row, or None."""
        with self.store.engine.connect() as conn:
            row = conn.execute(sa.select(jobs).where(jobs.c.id == job_id)).first()
        return None if row is None else dict(row._mapping)

    def list_jobs(
        self,
        rig_name: str | None,
        *,
        state: str | None = None,
        limit: int = 500,
        offset: int = 0,
    ) -> list[dict[str, Any]]:
        """The rig's jobs (every rig's with None), newest first, in ``state`` if given,
        ``offset`` of them skipped, at most ``limit``."""
        order = (jobs.c.created_at.desc(), jobs.c.id)
        query = sa.select(jobs).order_by(*order).limit(limit).offset(offset)
        if rig_name is not None:
            query = query.where(jobs.c.rig_name == rig_name)
        if state is not None:
            query = query.where(jobs.c.state == JobState(state))
        with self.store.engine.connect() as conn:
            return [dict(r._mapping) for r in conn.execute(query)]

    def queued(self, rig_name: str | None) -> list[dict[str, Any]]:
        """The rig's queue (every rig's with None): queued procedures in the order they
        will run."""
        query = (
            sa.select(jobs)
            .where(jobs.c.state == JobState.QUEUED, jobs.c.position.is_not(None))
            .order_by(jobs.c.rig_name, jobs.c.position, jobs.c.created_at)
        )
        if rig_name is not None:
            query = query.where(jobs.c.rig_name == rig_name)
        with self.store.engine.connect() as conn:
            return [dict(r._mapping) for r in conn.execute(query)]

    def set_positions(self, ordered_ids: Sequence[str]) -> None:
        """Number the queue 1, 2, … in ``ordered_ids``' order, in one transaction."""
        with self.store.transaction() as conn:
            for position, job_id in enumerate(ordered_ids, start=1):
                conn.execute(sa.update(jobs).where(jobs.c.id == job_id).values(position=position))

    def delete(self, job_id: str) -> bool:
        """Remove a job and its events; whether it existed."""
        with self.store.transaction() as conn:
            return conn.execute(sa.delete(jobs).where(jobs.c.id == job_id)).rowcount == 1

    def recover_interrupted(self, rig_name: str) -> list[str]:
        """Mark the rig's jobs left unfinished by a dead process ``interrupted``; returns
        their ids. A procedure waiting in the queue (a position) stays queued."""
        here = socket.gethostname()
        now = time.time()
        recovered: list[str] = []
        with self.store.transaction() as conn:
            open_jobs = conn.execute(
                sa.select(jobs).where(
                    jobs.c.rig_name == rig_name, jobs.c.state.not_in(list(JOB_FINAL))
                )
            ).all()
            for job in open_jobs:
                if job.state == JobState.QUEUED and job.position is not None:
                    continue
                alive = job.owner_host != here or (
                    job.owner_pid is not None
                    and process_alive(job.owner_pid, job.owner_boot_id, job.owner_start_ticks)
                )
                if alive:
                    continue
                conn.execute(
                    sa.update(jobs)
                    .where(jobs.c.id == job.id)
                    .values(
                        state=JobState.INTERRUPTED,
                        error=INTERRUPTED_REASON,
                        message=f"interrupted: {INTERRUPTED_REASON}",
                        finished_at=now,
                    )
                )
                conn.execute(
                    sa.insert(job_events).values(
                        job_id=job.id,
                        state=JobState.INTERRUPTED,
                        fraction=job.fraction,
                        message=f"interrupted: {INTERRUPTED_REASON}; recovered at start-up",
                        t_wall=now,
                    )
                )
                recovered.append(job.id)
        return recovered

    # -- report files -----------------------------------------------------------------------
    def save_report_files(
        self, result_id: int, files: Iterable[tuple[str, str, bytes]]
    ) -> list[str]:
        """Store ``(name, media_type, content)`` files as the report of ``result_id``
        (replacing same-named ones); returns the names stored."""
        names = []
        with self.store.transaction() as conn:
            for name, media_type, content in files:
                conn.execute(
                    sa.delete(report_files).where(
                        report_files.c.result_id == result_id, report_files.c.name == name
                    )
                )
                conn.execute(
                    sa.insert(report_files).values(
                        result_id=result_id, name=name, media_type=media_type, content=content
                    )
                )
                names.append(name)
        return names

    def report_names(self, result_id: int) -> list[str]:
        """Names of the report files of ``result_id``, sorted."""
        query = (
            sa.select(report_files.c.name)
            .where(report_files.c.result_id == result_id)
            .order_by(report_files.c.name)
        )
        with self.store.engine.connect() as conn:
            return list(conn.execute(query).scalars())

    def report_file(self, result_id: int, name: str) -> tuple[str, bytes] | None:
        """``(media_type, content)`` of one report file, or None."""
        query = sa.select(report_files.c.media_type, report_files.c.content).where(
            report_files.c.result_id == result_id, report_files.c.name == name
        )
        with self.store.engine.connect() as conn:
            row = conn.execute(query).first()
        return None if row is None else (row.media_type, bytes(row.content))
