"""The run database: runs, samples, events and results behind one URL (SQLite or
PostgreSQL); every write is one transaction. This module holds the runs' rows (the run and
its tags); the samples (``daq.store.samples``), events and results (``annotations``) and
imported calibrations (``calibrations``) are mixed into :class:`Store` from their own
modules, and the start-up recovery of interrupted runs is ``daq.store.recovery``.
"""

from __future__ import annotations

import os
import socket
import time
import uuid
from collections.abc import Sequence
from dataclasses import replace
from datetime import datetime
from pathlib import Path
from typing import TYPE_CHECKING, Any, NotRequired, TypedDict, Unpack

import sqlalchemy as sa

from daq.sample import Sample
from daq.store import checks
from daq.store.annotations import EventsAndResults
from daq.store.calibrations import ImportedCalibrations
from daq.store.database import inserted_id, process_identity, software_version
from daq.store.faults import STORE_RETRY_S
from daq.store.packing import SamplePacker
from daq.store.pending_ends import PendingEnds
from daq.store.recovery import interrupted_runs
from daq.store.run_events import RunEvents, losses_text
from daq.store.run_metadata import check_run_metadata, merge_run_metadata
from daq.store.run_query import RunFilter, drive_of
from daq.store.run_records import RunInfo, to_datetime
from daq.store.samples import SampleRows
from daq.store.schema import (
    END_STATUSES,
    events,
    results,
    rigs,
    run_tags,
    sample_blocks,
    vehicles,
)
from daq.store.schema import runs as runs_t
from daq.store.spill import default_spill_dir, replay_spills

if TYPE_CHECKING:
    from daq.store.loaded_run import LoadedRun


class NewRun(TypedDict):
    """What describes a run when it is started or imported (``Store.create_run``,
    ``Store.import_run``): its kind and validated parameters, the channels it records,
    the rig and vehicle by name, the rig file's (and scenario's) text, and its metadata."""

    kind: str
    parameters: dict
    channel_names: Sequence[str]
    rig_name: str
    vehicle: str
    rig_toml: str
    scenario_toml: NotRequired[str | None]
    metadata: NotRequired[dict[str, Any] | None]


class Store(EventsAndResults, ImportedCalibrations, SampleRows):
    """Durable run storage. ``url`` defaults to :func:`default_database_url`; opening
    creates the database if needed, migrates it to the newest schema and writes back the
    spill files of its runs (samples a recorder could not store, see
    :mod:`daq.store.spill`); ``spill_dir`` defaults to :func:`default_spill_dir`.

    Runs whose end this process decided but the database has not taken yet
    (``pending_ends``, :mod:`daq.store.pending_ends`) read as they ended, not ``running``."""

    #: How long a run's recorder retries its end against this database when it delays it, s.
    retry_for_s: float = STORE_RETRY_S

    def __init__(self, url: str | None = None, *, spill_dir: str | Path | None = None) -> None:
        super().__init__(url)
        self.spill_dir = Path(spill_dir) if spill_dir is not None else default_spill_dir()
        self.pending_ends = PendingEnds()
        self.replay_spills()

    def replay_spills(self, *, database_errors: bool = False) -> list[str]:
        """Write back the spill files of this database's runs (see :mod:`daq.store.spill`);
        returns the ids of the runs written back. What still cannot be written stays for
        the next attempt; ``database_errors`` re-raises the database's failure to take it."""
        return replay_spills(self, database_errors=database_errors)

    # -- runs -------------------------------------------------------------------------
    def _insert_run(
        self,
        conn: sa.Connection,
        *,
        kind: str,
        parameters: dict,
        channel_names: Sequence[str],
        rig_name: str,
        vehicle: str,
        rig_toml: str,
        started_at: float,
        scenario_toml: str | None = None,
        metadata: dict[str, Any] | None = None,
        source_file: str | None = None,
    ) -> tuple[str, int]:
        checks.check_kind("kind", kind)
        checks.check_json("parameters", parameters)
        meta = check_run_metadata(metadata)
        if source_file is not None:
            source_file = checks.check_name("source_file", source_file)[-255:]
        names = checks.check_channel_names(channel_names)
        rig_name = checks.check_name("rig_name", rig_name)
        vehicle = checks.check_name("vehicle", vehicle)
        if not isinstance(rig_toml, str):
            raise ValueError(f"rig_toml: expected the rig file's text, got {rig_toml!r}")
        if scenario_toml is not None and not isinstance(scenario_toml, str):
            raise ValueError(f"scenario_toml: expected TOML text or None, got {scenario_toml!r}")
        run_uuid = str(uuid.uuid4())
        boot_id, start_ticks = process_identity()
        inserted = conn.execute(
            sa.insert(runs_t).values(
                uuid=run_uuid,
                kind=kind,
                status="running",
                parameters=parameters,
                rig_id=self._named_id(conn, rigs, rig_name),
                vehicle_id=self._named_id(conn, vehicles, vehicle),
                started_at=round(started_at, 6),  # µs: round-trips via datetime
                channel_names=list(names),
                software_version=software_version(),
                rig_toml=rig_toml,
                scenario_toml=scenario_toml,
                owner_host=socket.gethostname(),
                owner_pid=os.getpid(),
                owner_boot_id=boot_id,
                owner_start_ticks=start_ticks,
                drive=drive_of(kind, parameters),
                source="recorded" if source_file is None else "imported",
                source_file=source_file,
                imported_at=None if source_file is None else round(time.time(), 6),
                metadata=meta or None,
            )
        )
        pk = inserted_id(inserted)
        self._write_tags(conn, pk, meta.get("tags", []))
        return run_uuid, pk

    @staticmethod
    def _write_tags(conn: sa.Connection, pk: int, tags: Sequence[str]) -> None:
        conn.execute(sa.delete(run_tags).where(run_tags.c.run_id == pk))
        if tags:
            conn.execute(sa.insert(run_tags), [{"run_id": pk, "tag": t} for t in tags])

    def set_run_metadata(self, run_id: str, changes: dict[str, Any]) -> RunInfo:
        """Update a run's metadata (any status, imported runs too): the keys given replace
        the stored ones, a None value removes its key, ``tags`` replaces the tag list.
        Returns the run as stored after the change."""
        checked = check_run_metadata(changes, allow_null=True)
        with self.transaction() as conn:
            run = self._resolve(conn, run_id)
            merged = merge_run_metadata(dict(run._mapping["metadata"] or {}), checked)
            conn.execute(
                sa.update(runs_t).where(runs_t.c.id == run.id).values(metadata=merged or None)
            )
            if "tags" in checked:
                self._write_tags(conn, run.id, merged.get("tags", []))
        return self.get_run(run.uuid)

    def create_run(self, **run: Unpack[NewRun]) -> str:
        """Start a run (status ``running``, owned by this process); returns its uuid.
        ``metadata``: operator, water temperature, notes, tags, free keys (checked by
        :func:`daq.store.run_metadata.check_run_metadata`)."""
        with self.transaction() as conn:
            run_uuid, _ = self._insert_run(conn, started_at=time.time(), **run)
        return run_uuid

    def _finish(
        self,
        conn: sa.Connection,
        run: sa.Row,
        status: str,
        reason: str | None,
        stopped_at: float,
    ) -> None:
        checks.check_choice("status", status, END_STATUSES)
        if status == "aborted" and not (reason and reason.strip()):
            raise ValueError("reason: an aborted run needs a reason (e.g. 'device lost')")
        done = conn.execute(
            sa.update(runs_t)
            .where(runs_t.c.id == run.id, runs_t.c.status == "running")
            .values(status=status, reason=reason, stopped_at=round(stopped_at, 6))
        )
        if done.rowcount != 1:
            current = conn.execute(
                sa.select(runs_t.c.status).where(runs_t.c.id == run.id)
            ).scalar_one()
            raise ValueError(
                f"run {run.uuid}: already ended as {current!r}; cannot mark {status!r}"
            )

    def finish_run(
        self,
        run_id: str,
        status: str,
        reason: str | None = None,
        *,
        stopped_at: datetime | float | None = None,
    ) -> None:
        """End a running run as ``completed``, ``aborted`` (reason required) or
        ``interrupted``; the stop time is now unless given."""
        stop = checks.unix_seconds("stopped_at", stopped_at)
        with self.transaction() as conn:
            run = self._resolve(conn, run_id)
            self._finish(conn, run, status, reason, time.time() if stop is None else stop)
        self.pending_ends.discard(run.uuid)

    def import_run(
        self,
        *,
        samples: Sequence[Sample],
        started_at: float,
        stopped_at: float,
        status: str = "completed",
        reason: str | None = None,
        batch_rows: int | None = None,
        source_file: str | None = None,
        **run: Unpack[NewRun],
    ) -> str:
        """Store a whole, already finished run in one transaction (nothing on error).

        With ``source_file`` (the original file's name) the run is marked ``imported``
        (now, ``imported_at``); ``started_at`` stays when it was recorded.

        With ``batch_rows``, a longer run is written in transactions of that many samples
        so the database's write lock is never held for long (a live run's recorder and
        events keep their turn); the run reads ``running`` until the last one, and a
        failure part-way ends it ``aborted`` naming the error."""
        header: dict[str, Any] = {**run, "started_at": started_at, "source_file": source_file}
        if batch_rows is not None and len(samples) > batch_rows:
            return self._import_in_batches(
                samples, batch_rows, status, reason, stopped_at, **header
            )
        with self.transaction() as conn:
            run_uuid, pk = self._insert_run(conn, **header)
            packer = SamplePacker(checks.check_channel_names(run["channel_names"]))
            self._store_batch(conn, run_uuid, pk, packer, samples)
            row = conn.execute(sa.select(runs_t).where(runs_t.c.id == pk)).one()
            self._finish(conn, row, status, reason, stopped_at)
        return run_uuid

    def _import_in_batches(
        self,
        samples: Sequence[Sample],
        batch_rows: int,
        status: str,
        reason: str | None,
        stopped_at: float,
        **run: Any,
    ) -> str:
        packer = SamplePacker(checks.check_channel_names(run["channel_names"]))
        with self.transaction() as conn:
            run_uuid, pk = self._insert_run(conn, **run)
        try:
            for start in range(0, len(samples), batch_rows):
                with self.transaction() as conn:
                    chunk = samples[start : start + batch_rows]
                    self._store_batch(conn, run_uuid, pk, packer, chunk)
        except Exception as exc:
            self.finish_run(run_uuid, "aborted", f"import failed: {exc}", stopped_at=stopped_at)
            raise
        with self.transaction() as conn:
            row = conn.execute(sa.select(runs_t).where(runs_t.c.id == pk)).one()
            self._finish(conn, row, status, reason, stopped_at)
        return run_uuid

    _RUN_COLUMNS = (
        runs_t,
        rigs.c.name.label("rig_name"),
        vehicles.c.name.label("vehicle_name"),
    )

    def _run_query(self) -> sa.Select:
        return (
            sa.select(*self._RUN_COLUMNS)
            .join(rigs, rigs.c.id == runs_t.c.rig_id)
            .join(vehicles, vehicles.c.id == runs_t.c.vehicle_id)
        )

    @staticmethod
    def _run_info(row: sa.Row) -> RunInfo:
        return RunInfo(
            id=row.uuid,
            kind=row.kind,
            status=row.status,
            reason=row.reason,
            parameters=dict(row.parameters),
            started_at=to_datetime(row.started_at),
            stopped_at=to_datetime(row.stopped_at),
            sample_count=int(row.sample_count),
            rig_name=row.rig_name,
            vehicle=row.vehicle_name,
            channel_names=tuple(row.channel_names),
            software_version=row.software_version,
            rig_toml=row.rig_toml,
            scenario_toml=row.scenario_toml,
            drive=row.drive,
            source=row.source,
            source_file=row.source_file,
            imported_at=to_datetime(row.imported_at),
            metadata=dict(row._mapping["metadata"] or {}),
        )

    def get_run(self, run_id_or_unique_prefix: str, *, as_stored: bool = False) -> RunInfo:
        """One run by uuid or unique prefix (RunNotFound / AmbiguousRunId otherwise); as it
        ended when its end is still pending (``as_stored``: as the database holds it)."""
        with self.engine.connect() as conn:
            run = self._resolve(conn, run_id_or_unique_prefix)
            row = conn.execute(self._run_query().where(runs_t.c.id == run.id)).one()
        lost = losses_text(RunEvents.of(self.events(row.uuid)).losses)  # its gap events
        info = replace(self._run_info(row), samples_lost=lost, losses_read=True)
        return info if as_stored else self.pending_ends.apply(info)

    def load(self, run_id_or_unique_prefix: str) -> LoadedRun:
        """One run whole (record, samples, events, results) for a notebook:
        ``.to_pandas()``, ``.to_xarray()``, ``.to_netcdf(path)``, ``.to_parquet(path)``."""
        from daq.store.loaded_run import LoadedRun

        info = self.get_run(run_id_or_unique_prefix)
        events, results = tuple(self.events(info.id)), tuple(self.results(info.id))
        return LoadedRun(info, self.samples(info.id), events, results)

    def stored_metadata(self, run_id: str) -> dict[str, Any] | None:
        """The metadata of the run with exactly this uuid ({} when none, None when there
        is no such run): one indexed read, for caches of ended runs."""
        with self.engine.connect() as conn:
            row = conn.execute(sa.select(runs_t.c.metadata).where(runs_t.c.uuid == run_id)).first()
        return None if row is None else dict(row[0] or {})

    def list_runs(
        self,
        *,
        kind: str | None = None,
        status: str | None = None,
        vehicle: str | None = None,
        drive: str | None = None,
        source: str | None = None,
        tag: str | None = None,
        search: str | None = None,
        since: datetime | None = None,
        until: datetime | None = None,
        limit: int = 100,
        offset: int = 0,
    ) -> list[RunInfo]:
        """Runs, newest first, filtered as :class:`daq.store.run_query.RunFilter` says
        (``since`` ≤ start < ``until``; a naive datetime is taken as UTC; ``drive='none'``
        for runs nothing drove)."""
        where = RunFilter(kind, status, vehicle, drive, source, tag, search, since, until)
        query = (
            where.where(self._run_query())
            .order_by(runs_t.c.started_at.desc(), runs_t.c.id.desc())
            .limit(checks.check_limit("limit", limit, minimum=1))
            .offset(checks.check_limit("offset", offset, minimum=0))
        )
        with self.engine.connect() as conn:
            rows = conn.execute(query).all()
        return [self.pending_ends.apply(self._run_info(row)) for row in rows]

    def count_runs(self, **filters: Any) -> int:
        """How many runs :meth:`list_runs` with these filters finds, without paging."""
        where = RunFilter(**filters)
        query = sa.select(sa.func.count()).select_from(runs_t)
        if where.reads_vehicle:  # else counted from an index, not by reading every run
            query = query.join(vehicles, vehicles.c.id == runs_t.c.vehicle_id)
        query = where.where(query)
        with self.engine.connect() as conn:
            return int(conn.execute(query).scalar_one())

    # -- start-up and health ------------------------------------------------------------
    def recover_interrupted(self, *, include_live_owners: bool = False) -> list[str]:
        """Mark runs left ``running`` by a process that no longer drives the rig as
        ``interrupted``, each with a fault event; returns their ids (which runs:
        :func:`daq.store.recovery.interrupted_runs`)."""
        with self.transaction() as conn:
            found = interrupted_runs(
                conn, self.backend, self.spill_dir, include_live_owners=include_live_owners
            )
            for run in found:
                self._finish(conn, run.run, "interrupted", run.reason, run.stopped_at)
                self._insert_event(conn, run.run.id, "fault", run.event_message, run.event_data)
        return [run.run.uuid for run in found]

    def integrity_check(self) -> str:
        """``ok`` when the database is sound (SQLite PRAGMA integrity_check), else the
        problems found."""
        with self.engine.connect() as conn:
            if self.backend == "sqlite":
                lines = [r[0] for r in conn.exec_driver_sql("PRAGMA integrity_check")]
                return "ok" if lines == ["ok"] else "; ".join(lines)
            conn.execute(sa.select(sa.func.count()).select_from(runs_t)).scalar_one()
            return "ok"

    def stats(self) -> dict[str, Any]:
        """Row counts per table (for status pages); ``samples``: the samples stored (in
        ``sample_blocks`` rows, counted too)."""
        with self.engine.connect() as conn:
            counts = {
                t.name: conn.execute(sa.select(sa.func.count()).select_from(t)).scalar_one()
                for t in (runs_t, sample_blocks, events, results)
            }
            total = sa.select(sa.func.coalesce(sa.func.sum(sample_blocks.c.sample_count), 0))
            counts["samples"] = int(conn.execute(total).scalar_one())
        return counts
