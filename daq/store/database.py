"""The store's plumbing: engine, migrations on open, transactions and run-id lookup."""

from __future__ import annotations

import itertools
import logging
import os
import time
from collections.abc import Iterator
from contextlib import contextmanager
from importlib import metadata as importlib_metadata
from typing import Self

import sqlalchemy as sa

from daq.store import checks
from daq.store.faults import (
    STORE_RETRY_S,
    DatabaseNotOpened,
    database_name,
    held_by_another,
    opening_reason,
)
from daq.store.migrate import create_engine, default_database_url, upgrade_to_head
from daq.store.packing import SamplePacker
from daq.store.run_records import AmbiguousRunId, RunNotFound
from daq.store.schema import runs as runs_t

log = logging.getLogger(__name__)


def inserted_id(result: sa.CursorResult) -> int:
    """The primary key of the row an INSERT added."""
    key = result.inserted_primary_key
    assert key is not None, "not an INSERT of one row"
    return int(key[0])


def software_version() -> str:
    """The towrig version: installed metadata, else the checkout's pyproject.toml."""
    try:
        return importlib_metadata.version("towrig")
    except importlib_metadata.PackageNotFoundError:
        pass
    import tomllib  # here: only a checkout without installed metadata reads it (~10 ms)

    from daq.config import PACKAGE_ROOT  # here: daq.config imports pydantic

    try:
        with open(PACKAGE_ROOT / "pyproject.toml", "rb") as f:
            return str(tomllib.load(f)["project"]["version"])
    except (OSError, KeyError, tomllib.TOMLDecodeError):
        return "unknown"


def created_stamp() -> dict[str, float | str]:
    """The columns that stamp a stored result or calibration: ``created_at`` (now, to the
    µs) and the ``software_version`` that wrote it."""
    return {"created_at": round(time.time(), 6), "software_version": software_version()}


def _boot_id() -> str | None:
    try:
        with open("/proc/sys/kernel/random/boot_id", encoding="ascii") as f:
            return f.read().strip() or None
    except OSError:
        return None


def _proc_stat(pid: int) -> list[str] | None:
    """Fields of /proc/<pid>/stat from field 3 (state) on; None if there is no such process."""
    with open(f"/proc/{pid}/stat", encoding="ascii", errors="replace") as f:
        return f.read().rsplit(")", 1)[1].split()


def process_identity(pid: int | None = None) -> tuple[str | None, int | None]:
    """(boot id, start time in clock ticks since boot) of ``pid`` (default: this process);
    None where the system does not tell."""
    try:
        stat = _proc_stat(os.getpid() if pid is None else pid)
    except OSError:
        return _boot_id(), None
    return _boot_id(), int(stat[19]) if stat and len(stat) > 19 else None


def process_alive(pid: int, boot_id: str | None = None, start_ticks: int | None = None) -> bool:
    """Whether process ``pid`` of this host still exists, is not a zombie and (when given)
    is the same process: same boot, same start time (so a reused pid is not taken for it)."""
    current_boot = _boot_id()
    if boot_id and current_boot and boot_id != current_boot:
        return False  # the host rebooted since
    try:
        stat = _proc_stat(pid)
    except FileNotFoundError:
        return False
    except OSError:  # no /proc: ask the kernel
        try:
            os.kill(pid, 0)
        except ProcessLookupError:
            return False
        except PermissionError:
            return True
        return True
    if not stat or stat[0] == "Z":  # zombie = dead
        return False
    return start_ticks is None or len(stat) <= 19 or int(stat[19]) == start_ticks


class StoreBase:
    """Engine and lookups shared by :class:`daq.store.Store`; ``url`` defaults to
    :func:`default_database_url`; opening creates the database if needed and migrates it
    to the newest schema."""

    def __init__(self, url: str | None = None) -> None:
        self.url = url or default_database_url()
        # Another process migrating the same new SQLite file holds its lock; on a loaded
        # machine past the busy wait (migrate.SQLITE_BUSY_MS; a rehearsal beside a busy
        # loop): that lock is waited out as a run's writes wait one out, STORE_RETRY_S.
        give_up_at = time.monotonic() + STORE_RETRY_S
        for attempt in itertools.count():
            try:
                self.engine = create_engine(self.url)
                upgrade_to_head(self.engine)
                break
            except sa.exc.SQLAlchemyError as err:  # a bad URL, no driver, no server, a lock
                if not held_by_another(err) or time.monotonic() >= give_up_at:
                    raise DatabaseNotOpened(opening_reason(err)) from err
                if attempt == 0:
                    log.warning(
                        "%s is locked by another process (migrating it?); waiting up to %g s",
                        database_name(self.engine.url),
                        STORE_RETRY_S,
                    )
                self.engine.dispose()
                time.sleep(0.2)
        self.backend = self.engine.dialect.name
        self._packers: dict[str, tuple[int, SamplePacker]] = {}

    # -- plumbing ---------------------------------------------------------------------
    def close(self) -> None:
        """Release every pooled connection."""
        self.engine.dispose()

    def __enter__(self) -> Self:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def __repr__(self) -> str:
        return f"Store({self.engine.url.render_as_string(hide_password=True)!r})"

    @contextmanager
    def transaction(self) -> Iterator[sa.Connection]:
        """One transaction: committed on success, rolled back (and re-raised) on error."""
        with self.engine.begin() as conn:
            yield conn

    def _named_id(self, conn: sa.Connection, table: sa.Table, name: str) -> int:
        # the backend's own INSERT … ON CONFLICT (imported here: listing runs never needs it)
        if self.backend == "postgresql":
            from sqlalchemy.dialects import postgresql as dialect
        else:
            from sqlalchemy.dialects import sqlite as dialect  # type: ignore[no-redef]
        conn.execute(dialect.insert(table).values(name=name).on_conflict_do_nothing())
        return conn.execute(sa.select(table.c.id).where(table.c.name == name)).scalar_one()

    def _resolve(self, conn: sa.Connection, run_id: str) -> sa.Row:
        """The run row for a uuid or unique uuid prefix."""
        try:
            key = checks.check_run_id(run_id)
        except ValueError as err:  # no run can have this id: the same answer as an unknown one
            raise RunNotFound(f"no run with id {checks.shown_id(run_id)}: {err}") from None
        row = conn.execute(sa.select(runs_t).where(runs_t.c.uuid == key)).first()
        if row is not None:
            return row
        rows = conn.execute(sa.select(runs_t).where(runs_t.c.uuid.like(key + "%")).limit(6)).all()
        if not rows:
            raise RunNotFound(f"no run with id {checks.shown_id(run_id)}")
        if len(rows) > 1:
            shown = ", ".join(r.uuid for r in rows[:5])
            raise AmbiguousRunId(
                f"run id prefix {run_id!r} matches several runs ({shown}"
                f"{', …' if len(rows) > 5 else ''}); give more characters"
            )
        return rows[0]

    def _packer(self, run_id: str) -> tuple[int, SamplePacker]:
        """The primary key and packer of a run (read once per store: they never change)."""
        cached = self._packers.get(run_id)
        if cached is None:
            with self.engine.connect() as conn:
                row = self._resolve(conn, run_id)
            cached = (row.id, SamplePacker(row.channel_names))
            self._packers[row.uuid] = cached
        return cached
