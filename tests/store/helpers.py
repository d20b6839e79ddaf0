"""Helpers shared by the storage tests."""

from __future__ import annotations

import math
import sqlite3
from collections.abc import Iterable, Iterator
from contextlib import contextmanager
from pathlib import Path

import sqlalchemy as sa

from daq.sample import Quality, Sample
from daq.store import Store

RIG_TOML = '[rig]\nname = "BENBAM"\nmode = "simulated"\n'


def new_run(store: Store, **overrides) -> str:
    """A running tow run with two channels (arguments can be overridden)."""
    arguments = {
        "kind": "tow",
        "parameters": {"force_n": 24.5},
        "channel_names": ["tow_position", "load_cell"],
        "rig_name": "BENBAM",
        "vehicle": "BENBAM-1",
        "rig_toml": RIG_TOML,
    }
    arguments.update(overrides)
    return store.create_run(**arguments)


#: BENBAM's rig file (fixtures/rigs/benbam.toml), as stored with the runs recorded on it.
BENBAM_TOML = (Path(__file__).resolve().parents[2] / "fixtures/rigs/benbam.toml").read_text()
#: A tow pulled by a hung 2.5 kg: its parameters as stored.
HUNG_WEIGHT_TOW = {"force_n": 24.5, "drive": "weight", "hung_mass_kg": 2.5}


def benbam_tow_run(
    store: Store, channel_names: Iterable[str], parameters: dict = HUNG_WEIGHT_TOW
) -> str:
    """A running tow run recorded on BENBAM's rig file with ``channel_names``."""
    return new_run(
        store,
        parameters=parameters,
        channel_names=list(channel_names),
        rig_name="BENBAM tow tank",
        vehicle="BENBAM",
        rig_toml=BENBAM_TOML,
    )


def make_samples(start: int, count: int, *, t0_wall: float = 1.7e9) -> list[Sample]:
    """``count`` samples from seq ``start`` at 10 Hz with recognisable values."""
    return [
        Sample(
            seq=seq,
            t_mono=100.0 + seq * 0.1,
            t_wall=t0_wall + seq * 0.1,
            channels={"tow_position": seq * 0.01, "load_cell": math.sin(seq)},
            quality=Quality.OK,
        )
        for seq in range(start, start + count)
    ]


class DbLimits:
    """Per-connection settings applied to every pooled connection of a store: a page
    limit (SQLite: SQLITE_FULL as from a full disk), a short lock wait, read-only."""

    def __init__(self, store: Store) -> None:
        self.store = store
        self.max_pages: int | None = None
        self.busy_ms: int | None = None
        self.read_only = False
        sa.event.listen(store.engine, "connect", self._apply)

    def _apply(self, dbapi_connection, _record) -> None:
        if self.store.backend == "sqlite":
            if self.max_pages is not None:
                dbapi_connection.execute(f"PRAGMA max_page_count={self.max_pages}")
            if self.busy_ms is not None:
                dbapi_connection.execute(f"PRAGMA busy_timeout={self.busy_ms}")
            if self.read_only:
                dbapi_connection.execute("PRAGMA query_only=ON")
            return
        if self.busy_ms is not None:
            dbapi_connection.execute(f"SET lock_timeout = '{self.busy_ms}ms'")
        if self.read_only:
            dbapi_connection.execute("SET default_transaction_read_only = on")
        dbapi_connection.commit()  # a session setting, kept past the pool's rollback

    def set(
        self, *, max_pages: int | None = None, busy_ms: int | None = None, read_only: bool = False
    ) -> None:
        self.max_pages, self.busy_ms, self.read_only = max_pages, busy_ms, read_only
        self.store.engine.dispose()  # new connections take the new settings

    def fill(self) -> None:
        """SQLite: no room for one more page, the next batch fails with SQLITE_FULL."""
        with self.store.engine.connect() as conn:
            pages = conn.exec_driver_sql("PRAGMA page_count").scalar_one()
        self.set(max_pages=pages)


@contextmanager
def held_write_lock(store: Store) -> Iterator[None]:
    """Another connection holds the write lock (SQLite ``BEGIN EXCLUSIVE``, PostgreSQL
    ``LOCK TABLE sample_blocks, runs``) until the block ends."""
    if store.backend == "sqlite":
        path = sa.make_url(store.url).database
        blocker = sqlite3.connect(path, isolation_level=None)
        blocker.execute("BEGIN EXCLUSIVE")
        try:
            yield
        finally:
            blocker.execute("COMMIT")
            blocker.close()
        return
    engine = sa.create_engine(store.url)
    try:
        with engine.begin() as conn:
            conn.exec_driver_sql("LOCK TABLE sample_blocks, runs, events IN ACCESS EXCLUSIVE MODE")
            yield
    finally:
        engine.dispose()


def no_sql(text: str | None) -> None:
    """``text`` is one line without SQL, parameters or SQLAlchemy's footer."""
    assert text is not None and "\n" not in text, text
    for word in ("INSERT INTO", "SELECT ", "UPDATE ", "[SQL", "parameters", "Background on"):
        assert word not in text, text


def migrate_by_revisions(engine: sa.Engine) -> None:
    """Bring an empty database to head by running Alembic's revisions one by one (what
    ``upgrade_to_head`` does only for a database at an older revision; a new one it makes
    at head at once)."""
    from alembic import command

    from daq.store.migrate import alembic_config

    with engine.begin() as connection:
        command.upgrade(alembic_config(connection), "head")
