"""Events (operator actions, faults, limit trips) and results (estimations,
calibrations) of runs."""

from __future__ import annotations

import time
from collections.abc import Sequence
from datetime import datetime

import sqlalchemy as sa

from daq.store import checks
from daq.store.database import StoreBase, created_stamp, inserted_id
from daq.store.run_records import EventInfo, ResultInfo, ResultNotFound, to_datetime
from daq.store.schema import events, result_runs, results, vehicles
from daq.store.schema import runs as runs_t

#: The largest id a result can have (SQLite and PostgreSQL integer keys are 64-bit).
MAX_RESULT_ID = 2**63 - 1


class EventsAndResults(StoreBase):
    """The events and results half of :class:`daq.store.Store`."""

    def add_event(
        self,
        run_id: str | None,
        kind: str,
        message: str,
        data: dict | None = None,
        *,
        t_wall: float | None = None,
    ) -> None:
        """Log an event (``operator``, ``fault``, ``limit``, ``info``, …), optionally of a run;
        ``t_wall`` (Unix s) is when it happened, default now."""
        checks.check_kind("kind", kind)
        if not isinstance(message, str) or not message.strip():
            raise ValueError(f"message: {message!r} is not allowed; give a non-empty text")
        checks.check_json("data", data, optional=True)
        with self.transaction() as conn:
            pk = None if run_id is None else self._resolve(conn, run_id).id
            self._insert_event(conn, pk, kind, message, data, t_wall)

    @staticmethod
    def _insert_event(
        conn: sa.Connection,
        run_pk: int | None,
        kind: str,
        message: str,
        data: dict | None,
        t_wall: float | None = None,
    ) -> None:
        when = time.time() if t_wall is None else t_wall
        conn.execute(
            sa.insert(events).values(
                run_id=run_pk, t_wall=round(when, 6), kind=kind, message=message, data=data
            )
        )

    def events(self, run_id: str | None = None, *, limit: int | None = None) -> list[EventInfo]:
        """Events in time order: all of them, or those of one run."""
        query = sa.select(events, runs_t.c.uuid).outerjoin(runs_t, runs_t.c.id == events.c.run_id)
        with self.engine.connect() as conn:
            if run_id is not None:
                query = query.where(events.c.run_id == self._resolve(conn, run_id).id)
            query = query.order_by(events.c.t_wall, events.c.id)
            if limit is not None:
                query = query.limit(checks.check_limit("limit", limit, minimum=1))
            rows = conn.execute(query).all()
        return [
            EventInfo(
                id=r.id,
                run_id=r.uuid,
                time=to_datetime(r.t_wall),
                kind=r.kind,
                message=r.message,
                data=r.data,
            )
            for r in rows
        ]

    def add_result(self, run_ids: Sequence[str], kind: str, data: dict) -> int:
        """Store an ``estimation``/``calibration`` result of one or more runs; returns its id."""
        checks.check_kind("kind", kind)
        checks.check_json("data", data)
        if isinstance(run_ids, str) or not run_ids:
            raise ValueError(f"run_ids: {run_ids!r} is not allowed; give a list of ≥ 1 run ids")
        with self.transaction() as conn:
            pks = sorted({self._resolve(conn, r).id for r in run_ids})
            inserted = conn.execute(
                sa.insert(results).values(kind=kind, data=data, **created_stamp())
            )
            result_id = inserted_id(inserted)
            conn.execute(
                sa.insert(result_runs), [{"result_id": result_id, "run_id": pk} for pk in pks]
            )
        return int(result_id)

    def results(self, run_id: str | None = None, kind: str | None = None) -> list[ResultInfo]:
        """Results, oldest first, optionally only those of a run and/or of a kind."""
        query = sa.select(results).order_by(results.c.created_at, results.c.id)
        if kind is not None:
            query = query.where(results.c.kind == checks.check_kind("kind", kind))
        return self._fetch_results(query, run_id)

    def list_results(
        self,
        *,
        run_id: str | None = None,
        vehicle: str | None = None,
        kind: str | None = None,
        since: datetime | None = None,
        until: datetime | None = None,
        limit: int = 100,
        offset: int = 0,
    ) -> list[ResultInfo]:
        """A page of results, newest first: of a run (id or prefix), made from runs of a
        vehicle, of a kind, created in [since, until) (aware datetimes)."""
        query = self._results_where(sa.select(results), run_id, vehicle, kind, since, until)
        query = query.order_by(results.c.created_at.desc(), results.c.id.desc())
        return self._fetch_results(query.limit(limit).offset(offset))

    def count_results(
        self,
        *,
        run_id: str | None = None,
        vehicle: str | None = None,
        kind: str | None = None,
        since: datetime | None = None,
        until: datetime | None = None,
    ) -> int:
        """How many results :meth:`list_results` pages through with these filters."""
        query = sa.select(sa.func.count()).select_from(results)
        query = self._results_where(query, run_id, vehicle, kind, since, until)
        with self.engine.connect() as conn:
            return int(conn.execute(query).scalar_one())

    def _results_where(
        self,
        query: sa.Select,
        run_id: str | None,
        vehicle: str | None,
        kind: str | None,
        since: datetime | None,
        until: datetime | None,
    ) -> sa.Select:
        if kind is not None:
            query = query.where(results.c.kind == checks.check_kind("kind", kind))
        if run_id is not None:
            with self.engine.connect() as conn:
                pk = self._resolve(conn, run_id).id
            linked = sa.select(result_runs.c.result_id).where(result_runs.c.run_id == pk)
            query = query.where(results.c.id.in_(linked))
        if vehicle is not None:
            of_vehicle = (
                sa.select(result_runs.c.result_id)
                .join(runs_t, runs_t.c.id == result_runs.c.run_id)
                .join(vehicles, vehicles.c.id == runs_t.c.vehicle_id)
                .where(vehicles.c.name == vehicle)
            )
            query = query.where(results.c.id.in_(of_vehicle))
        if since is not None:
            query = query.where(results.c.created_at >= since.timestamp())
        if until is not None:
            query = query.where(results.c.created_at < until.timestamp())
        return query

    def result(self, result_id: int | str) -> ResultInfo:
        """One result by id; ``ResultNotFound`` names the id (also for one no row can have:
        not an integer, or beyond the database's 64-bit ids)."""
        if isinstance(result_id, bool) or not isinstance(result_id, int | str):
            raise ResultNotFound(f"no result with id {result_id!r}")
        try:
            key = int(result_id)
        except ValueError:
            raise ResultNotFound(f"no result with id {result_id!r}") from None
        if not 0 < key <= MAX_RESULT_ID:
            raise ResultNotFound(f"no result with id {result_id}")
        found = self._fetch_results(sa.select(results).where(results.c.id == key))
        if not found:
            raise ResultNotFound(f"no result with id {result_id}")
        return found[0]

    def latest_result(self, kind: str) -> ResultInfo | None:
        """The newest result of ``kind`` (e.g. the thrust calibration in force), or None."""
        query = (
            sa.select(results)
            .where(results.c.kind == checks.check_kind("kind", kind))
            .order_by(results.c.created_at.desc(), results.c.id.desc())
            .limit(1)
        )
        found = self._fetch_results(query)
        return found[0] if found else None

    def _fetch_results(self, query: sa.Select, run_id: str | None = None) -> list[ResultInfo]:
        with self.engine.connect() as conn:
            if run_id is not None:
                pk = self._resolve(conn, run_id).id
                linked = sa.select(result_runs.c.result_id).where(result_runs.c.run_id == pk)
                query = query.where(results.c.id.in_(linked))
            rows = conn.execute(query).all()
            links: dict[int, list[str]] = {}
            if rows:
                for result_id, run_uuid in conn.execute(
                    sa.select(result_runs.c.result_id, runs_t.c.uuid)
                    .join(runs_t, runs_t.c.id == result_runs.c.run_id)
                    .where(result_runs.c.result_id.in_([r.id for r in rows]))
                    .order_by(runs_t.c.started_at)
                ):
                    links.setdefault(result_id, []).append(run_uuid)
        return [
            ResultInfo(
                id=r.id,
                kind=r.kind,
                created_at=to_datetime(r.created_at),
                run_ids=tuple(links.get(r.id, ())),
                software_version=r.software_version,
                data=r.data,
            )
            for r in rows
        ]
